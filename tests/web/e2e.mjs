/*
 * End-to-end test of the browser client: blobcastd, websockify and the
 * page in headless Debian chromium (driven by playwright-core; never a
 * downloaded browser). Two pages join the same session:
 *  - each shows a frame that is a picture, not a blank canvas, and lists
 *    both members;
 *  - a real mouse drag on a primitive in page A moves it: page B receives
 *    A's edit (EDIT_APPLIED naming A as author and the dragged node), its
 *    model of the node follows A's, B draws a frame whose order reflects
 *    the edit, and B's member list marks A as the last editor; A measured
 *    its edit -> frame latency;
 *  - a slider on A edits a shape parameter and B sees it;
 *  - an orbit drag on empty space in A gives A a new view and leaves B's
 *    camera alone (each member has its own camera).
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/e2e.mjs [--blobcastd PATH]
 * BC_WEB_SCREENSHOT=FILE saves page A after the drag (docs/web.png).
 */
import assert from 'node:assert/strict';

import * as H from './harness.mjs';

const DEADLINE_MS = 110000;

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
H.skipIfMissing('web e2e', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();

const watchdog = H.watchdog(DEADLINE_MS);

const until = (page, what, fn, arg, ms = 20000) =>
	H.until(page, what, fn, arg, ms, 50);

/* Counts canvas pixels that differ from the corner colour, and the
 * distinct colours among a sample: a rendered scene has many of both. */
function canvasContent() {
	const c = document.getElementById('view');
	const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
	let differ = 0;
	const colours = new Set();
	for (let i = 0; i < d.length; i += 4 * 7) {
		if (Math.abs(d[i] - d[0]) + Math.abs(d[i + 1] - d[1]) +
			Math.abs(d[i + 2] - d[2]) > 30) {
			differ++;
		}
		colours.add((d[i] >> 4) << 8 | (d[i + 1] >> 4) << 4 | d[i + 2] >> 4);
	}
	return { differ, samples: Math.floor(d.length / 28), colours: colours.size };
}

/* Page coordinates of a view pixel of page's canvas. */
async function toPage(page, p) {
	return page.evaluate(({ x, y }) => {
		const c = document.getElementById('view');
		const r = c.getBoundingClientRect();
		const v = window.blobcast.state().view;
		return { x: r.left + (x + 0.5) * r.width / v.width,
			y: r.top + (y + 0.5) * r.height / v.height };
	}, p);
}

/* A primitive under its own centre in page's view: { id, x, y } in view
 * pixels, confirmed by the server's PICK. Spheres first (their centre is
 * always on them), largest on screen first, so the drag grabs something
 * easy to hit and easy to see. */
async function findTarget(page) {
	const prims = await page.evaluate(() => window.blobcast.primitives()
		.map((p) => ({ ...p, at: window.blobcast.project(p.id) }))
		.filter((p) => p.at));
	prims.sort((a, b) => (b.kind === 'sphere') - (a.kind === 'sphere') ||
		b.at.r - a.at.r);
	const v = await page.evaluate(() => window.blobcast.state().view);
	for (const p of prims) {
		const x = Math.round(p.at.x), y = Math.round(p.at.y);
		if (x < 20 || y < 20 || x > v.width - 120 || y > v.height - 40) {
			continue;
		}
		const hit = await page.evaluate(({ x: px, y: py }) =>
			window.blobcast.pick(px, py), { x, y });
		if (hit && hit.node === p.id) {
			return { id: p.id, kind: p.kind, x, y };
		}
	}
	throw new Error('no primitive is under its own centre');
}

async function openPage(port, ws, name) {
	const page = await browser.newPage({ viewport: { width: 960,
		height: 600 } });
	page.on('pageerror', (e) => {
		console.error(`page ${name}: ${e.message}`);
		failed = true;
	});
	await page.goto(`http://127.0.0.1:${port}/?ws=${ws}&session=default` +
		`&name=${name}`);
	return page;
}

try {
	const d = await H.startDaemon(daemon);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	step(`blobcastd :${d.port}, websockify :${proxy.port}, page :${web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const a = await openPage(web.port, proxy.port, 'alice');
	const b = await openPage(web.port, proxy.port, 'bob');

	/* Both pages show a frame and both members. */
	for (const [p, who] of [[a, 'alice'], [b, 'bob']]) {
		/* The first frame pays for starting the renderer, slow under
		 * the sanitizers on a busy machine. */
		await until(p, `${who}'s first frame`, () =>
			window.blobcast.state().framesDrawn >= 1, null, 45000);
		await until(p, `${who} to see two members`, () =>
			window.blobcast.state().members.length === 2);
		const c = await p.evaluate(canvasContent);
		assert.ok(c.differ > c.samples / 10, `${who}: the canvas is ` +
			`mostly one colour (${JSON.stringify(c)})`);
		assert.ok(c.colours > 50, `${who}: too few colours ` +
			`(${JSON.stringify(c)})`);
	}
	const sa = await a.evaluate(() => window.blobcast.state());
	const names = sa.members.map((m) => m.name).sort();
	assert.deepEqual(names, ['alice', 'bob']);
	step('both pages show the scene and both members');

	/* A drag on a primitive in A. */
	const target = await findTarget(a);
	const before = await b.evaluate((id) => window.blobcast.node(id),
		target.id);
	const bFrames = (await b.evaluate(() => window.blobcast.state()))
		.framesDrawn;
	step(`dragging ${target.kind} #${target.id} at (${target.x}, ` +
		`${target.y}); B has drawn ${bFrames} frames`);
	const from = await toPage(a, target);
	await a.mouse.move(from.x, from.y);
	await a.mouse.down();
	for (let i = 1; i <= 12; i++) {
		await a.mouse.move(from.x + 6 * i, from.y - 2 * i);
		await a.waitForTimeout(30);
	}
	await a.mouse.up();
	const edited = await until(a, 'A to see its own edit applied', (id) => {
		const s = window.blobcast.state();
		return s.lastEdit && s.lastEdit.author === s.memberId &&
			s.lastEdit.node === id && !s.lastEdit.interacting ? s : null;
	}, target.id);
	assert.equal(edited.selected, target.id, 'the dragged shape is selected');
	const moved = await a.evaluate((id) => window.blobcast.node(id),
		target.id);
	const shift = moved.translate.map((v, i) => v - before.translate[i]);
	assert.ok(Math.hypot(...shift) > 0.05, `the shape moved: ${shift}`);

	/* B hears of it from the server and draws it. */
	const remote = await until(b, 'B to receive the edit and a frame of it',
		({ id, author }) => {
			const s = window.blobcast.state();
			const e = s.lastRemoteEdit;
			return e && e.author === author && e.node === id &&
				!e.interacting && s.lastFrame &&
				BigInt(s.lastFrame.order) >= BigInt(e.order) &&
				s.lastFrame.at >= e.at ? s : null;
		}, { id: target.id, author: edited.memberId });
	assert.ok(remote.framesDrawn > bFrames, 'B drew a new frame');
	const seen = await b.evaluate((id) => window.blobcast.node(id),
		target.id);
	seen.translate.forEach((v, i) => assert.ok(
		Math.abs(v - moved.translate[i]) < 1e-6,
		`B's copy of the node follows A's: ${seen.translate} vs ` +
		`${moved.translate}`));
	const mark = await b.evaluate((id) => document.querySelector(
		`#members li[data-member="${id}"] .last`) !== null, edited.memberId);
	assert.ok(mark, "B's member list marks alice as the last editor");
	/* The frame that answers A's last edit may come after the page
	 * saw the edit applied (a loaded machine): wait for the sample. */
	await until(a, 'A to measure edit -> frame', () =>
		window.blobcast.state().latencies.length > 0);
	const hud = await a.evaluate(() =>
		document.getElementById('latency').textContent);
	step(`B drew order ${remote.lastFrame.order} (edit order ` +
		`${remote.lastRemoteEdit.order}); A's edit -> frame: ${hud}`);
	if (process.env.BC_WEB_SCREENSHOT) {
		await a.waitForTimeout(600);
		await a.screenshot({ path: process.env.BC_WEB_SCREENSHOT });
		step(`screenshot: ${process.env.BC_WEB_SCREENSHOT}`);
	}

	/* A slider on A edits the first shape parameter; B sees the value. */
	const p0 = moved.params[0];
	const slid = await a.evaluate(() => {
		const s = document.querySelector('#sliders input[data-key^="shape/"]');
		if (!s) {
			return null;
		}
		const v = Number(s.min) + 0.6 * (Number(s.max) - Number(s.min));
		s.value = String(v);
		s.dispatchEvent(new Event('input'));
		s.dispatchEvent(new Event('change'));
		return { label: s.getAttribute('aria-label'), value: Number(s.value) };
	});
	assert.ok(slid, 'the selection panel has a shape slider');
	await until(b, 'B to see the slider edit', ({ id, v, was }) => {
		const n = window.blobcast.node(id);
		return n && n.params[0] !== was && Math.abs(n.params[0] - v) < 1e-3;
	}, { id: target.id, v: slid.value, was: p0 });
	step(`slider ${slid.label} = ${slid.value.toFixed(3)} reached B`);

	/* An orbit in A: A gets a new view, B's camera stays where it was. */
	await until(b, 'B to settle', () => {
		const s = window.blobcast.state();
		return s.lastFrame && s.lastFrame.still &&
			BigInt(s.lastFrame.order) >= BigInt(s.order) &&
			performance.now() - s.lastFrame.at > 800;
	});
	const bSettled = (await b.evaluate(() => window.blobcast.state()))
		.framesDrawn;
	const aBefore = (await a.evaluate(() => window.blobcast.state()))
		.framesDrawn;
	const corner = await toPage(a, { x: 12, y: 12 });
	const miss = await a.evaluate(() => window.blobcast.pick(12, 12));
	assert.equal(miss?.node, 0, 'the corner is empty space');
	await a.mouse.move(corner.x, corner.y);
	await a.mouse.down();
	for (let i = 1; i <= 8; i++) {
		await a.mouse.move(corner.x + 10 * i, corner.y + 3 * i);
		await a.waitForTimeout(30);
	}
	await a.mouse.up();
	await until(a, 'A to draw its orbited view', (n) => {
		const s = window.blobcast.state();
		return s.framesDrawn > n && s.lastFrame.still;
	}, aBefore);
	await b.waitForTimeout(300);
	const bAfter = (await b.evaluate(() => window.blobcast.state()))
		.framesDrawn;
	assert.equal(bAfter, bSettled, "A's camera does not re-render B");
	step('orbit in A re-rendered A only');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
	console.error(H.logs());
} finally {
	await H.finish(browser, failed, watchdog);
}
