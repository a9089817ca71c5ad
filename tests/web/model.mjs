/*
 * Tree editing from the browser page's Scene panel: blobcastd, websockify
 * and two pages in the same session in headless Debian chromium
 * (playwright-core), small views of the built-in scene.
 *  - page A adds a sphere from the Add menu under the selected operator;
 *    drags its outliner row onto the difference #20 row (one EDIT: REMOVE
 *    and INSERT of the same id), which now subtracts it; turns #20 into a
 *    smooth intersection with the operator form; deletes the sphere.
 *    After each step page B's mirror and outliner rows hold the new tree
 *    and B draws a frame of it whose pixels differ from the step before;
 *  - a pick in A's picture selects the shape's row in A's outliner, a
 *    click on a row selects it, the arrows of rows close groups, and
 *    the down and left keys select the next row and the parent;
 *  - refused in A before anything is sent (no EDIT leaves A, B's scene
 *    does not change), each with a message saying what to do: a menu
 *    entry dropped on a primitive's row (adding under a primitive), a
 *    group dropped on its own child, deleting the root;
 *  - a race: B adds a sphere while the daemon's messages to A are held,
 *    A adds one with the same new id; the daemon refuses A's (EDUPID)
 *    and A shows its ERROR text and what to do;
 *  - A wraps a sphere in a twist from the menu (REPLACE, its id kept) and
 *    duplicates the twist (fresh ids next to it); B's tree follows.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/model.mjs --blobcastd PATH
 */
import assert from 'node:assert/strict';

import * as H from './harness.mjs';
import * as P from '../../client/web/protocol.js';

const DEADLINE_MS = 150000;

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
H.skipIfMissing('web model', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();
const watchdog = H.watchdog(DEADLINE_MS);

const until = (page, what, fn, arg, ms = 20000) =>
	H.until(page, what, fn, arg, ms, 30);

/* Routes a page's WebSocket through this script: its EDIT messages are
 * decoded and kept (edits), and while hold.on the daemon's messages to it
 * wait (an editor that has not yet heard of another's edit) until
 * release(). */
async function route(page) {
	const seen = { edits: [], on: false, queue: [] };
	await page.routeWebSocket(/.*/, (ws) => {
		const server = ws.connectToServer();
		const r = new P.Reader({ side: 'server' });
		ws.onMessage((m) => {
			server.send(m);
			r.feed(new Uint8Array(Buffer.from(m)));
			for (let x; (x = r.next());) {
				if (x.type === P.MSG.EDIT) {
					seen.edits.push(x);
				}
			}
		});
		server.onMessage((m) => (seen.on ? seen.queue.push(m)
			: ws.send(m)));
		seen.release = () => {
			seen.on = false;
			for (const m of seen.queue.splice(0)) {
				ws.send(m);
			}
		};
	});
	return seen;
}

async function openPage(port, ws, name) {
	/* Tall enough for the outliner to show the rows the test drags
	 * between without scrolling. */
	const page = await browser.newPage({ viewport: { width: 600,
		height: 640 } });
	page.on('pageerror', (e) => {
		console.error(`page ${name}: ${e.message}`);
		failed = true;
	});
	const sent = await route(page);
	await page.goto(`http://127.0.0.1:${port}/?ws=${ws}&session=default` +
		`&name=${name}`);
	return { page, sent };
}

const rowAt = (page, id) => H.rowPoint(page, id);

/* A real pointer drag from a to b, in steps. */
const drag = async (page, a, b) => (await H.pointerPress(page, a, b))();

/* Waits until check (run in B with window.blobcast.outliner()) holds and
 * B has drawn a still frame of that edit, whose pixels differ from
 * before; returns the pixels. */
async function bSees(b, what, check, before) {
	await until(b, `B: ${what}`, check);
	const st = await until(b, `B: a still frame of ${what}`, () => {
		const s = window.blobcast.state();
		return s.lastFrame && s.lastFrame.still &&
			BigInt(s.lastFrame.order) >= BigInt(s.order) ? s : null;
	});
	const px = await H.viewPixels(b);
	const n = H.pixelsChanged(before, px);
	assert.ok(n > 20, `B: ${what}: the picture changed (${n} pixels)`);
	step(`B: ${what} (order ${st.order}, ${n} pixels changed)`);
	return px;
}

try {
	const d = await H.startDaemon(daemon);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	step(`blobcastd :${d.port}, websockify :${proxy.port}, page :${web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const A = await openPage(web.port, proxy.port, 'alice');
	const B = await openPage(web.port, proxy.port, 'bob');
	const a = A.page, b = B.page;
	for (const [p, who] of [[a, 'A'], [b, 'B']]) {
		await until(p, `${who}'s first still and outliner`, () => {
			const s = window.blobcast.state();
			return s.lastFrame?.still && window.blobcast.outliner().rows
				.some((r) => r.id === 50);
		}, null, 45000);
	}
	let px = await H.viewPixels(b);
	const rows = (await a.evaluate(() => window.blobcast.outliner())).rows;
	assert.deepEqual(rows.slice(0, 3).map((r) => [r.text, r.level]),
		[['union #1', 1], ['smooth_difference #10 · r 0.05', 2],
			['box #11', 3]], 'the outliner lists the tree, indented');
	step(`both pages show the scene; A's outliner has ${rows.length} rows`);

	/* Selection both ways: a pick in the picture selects the row, a row
	 * selects the node. */
	const at = await a.evaluate(() => window.blobcast.project(50));
	const view = await a.locator('#view').boundingBox();
	const v = await a.evaluate(() => window.blobcast.state().view);
	await a.mouse.click(view.x + at.x * view.width / v.width,
		view.y + at.y * view.height / v.height);
	await until(a, 'the picked row selected', () => window.blobcast
		.outliner().rows.find((r) => r.selected)?.id === 50);
	await a.mouse.click(...Object.values(await rowAt(a, 40)));
	await until(a, 'smooth_union #40 selected by its row', () =>
		window.blobcast.state().selected === 40 && !document
			.getElementById('opedit').hidden);
	step('a pick selects the row; a row click selects smooth_union #40');

	/* Close four groups (their arrows) so the rows dragged between
	 * fit the list. */
	for (const id of [10, 21, 24, 30]) {
		await a.locator(`#outliner .row[data-id="${id}"] .twist`).click();
		await until(a, `group #${id} closed`, (g) => window.blobcast
			.outliner().rows.every((r) => r.id !== g + 1), id);
	}
	step('closed #10, #21, #24 and #30 with their arrows');

	/* The keyboard: down selects the next row, left the parent. */
	await a.focus('#outliner');
	await a.keyboard.press('ArrowDown');
	await until(a, 'torus #41 selected by the down key', () =>
		window.blobcast.state().selected === 41);
	await a.keyboard.press('ArrowLeft');
	await until(a, 'smooth_union #40 selected by the left key', () =>
		window.blobcast.state().selected === 40);
	step('down and left keys select torus #41, then smooth_union #40');

	/* 1. Add a sphere from the menu: it goes under #40. */
	await a.click('#addbtn');
	await a.click('#addprims button[data-prim="1"]');
	const added = await until(a, 'A: the sphere added', () => {
		const o = window.blobcast.outliner();
		return window.blobcast.state().selected === 53 && o.message
			.startsWith('added sphere #53 under smooth_union #40') ? o : null;
	});
	assert.equal(A.sent.edits.length, 1, 'one EDIT');
	assert.deepEqual(A.sent.edits[0].ops.map((o) => o.kind), [P.EDIT.INSERT]);
	px = await bSees(b, 'sphere #53 under smooth_union #40', () => {
		const o = window.blobcast.outliner();
		const g = o.tree.slice(2).find((c) => c[1] === 40);
		return g && g.at(-1)[1] === 53 && o.rows.some((r) => r.id === 53 &&
			r.level === 3);
	}, px);
	step(`A: "${added.message}"`);

	/* 2. Drag its row onto difference #20: one EDIT, REMOVE and INSERT. */
	await drag(a, await rowAt(a, 53), await rowAt(a, 20));
	await until(a, 'A: the sphere moved', () => window.blobcast.outliner()
		.message.startsWith('moved sphere #53 into difference #20'));
	assert.equal(A.sent.edits.length, 2);
	assert.deepEqual(A.sent.edits[1].ops.map((o) => o.kind),
		[P.EDIT.REMOVE, P.EDIT.INSERT]);
	px = await bSees(b, 'sphere #53 moved under difference #20', () => {
		const t = window.blobcast.outliner().tree;
		const g = t.slice(2).find((c) => c[1] === 20);
		const h = t.slice(2).find((c) => c[1] === 40);
		return g && g.at(-1)[1] === 53 && h.length === 4;
	}, px);

	/* 3. #20 becomes a smooth intersection of radius 0.15. */
	await a.mouse.click(...Object.values(await rowAt(a, 20)));
	await until(a, 'the operator form for #20', () => document
		.getElementById('opname').textContent === 'difference #20');
	await a.selectOption('#opbase', '2');
	await a.check('#opsmooth');
	await a.fill('#opradius', '0.15');
	await a.click('#opapply');
	assert.equal((await until(a, 'A: #20 changed', () => window.blobcast
		.outliner().message.startsWith('difference #20 is now ' +
			'smooth_intersection') || null) && A.sent.edits.length), 3);
	const set = A.sent.edits[2].ops[0];
	assert.deepEqual(set.fields.map((f) => [f.field, f.values.map((x) =>
		+x.toFixed(4))]), [[P.FIELD.OP_KIND, [5]], [P.FIELD.BLEND, [0.15]],
		[P.FIELD.RANGE, [0.1875]]], 'kind and blend > 0 in one SET');
	px = await bSees(b, 'smooth_intersection #20 · r 0.15', () => {
		const o = window.blobcast.outliner();
		return o.tree.slice(2).find((c) => c[1] === 20)[0] ===
			'smooth_intersection' && o.rows.some((r) => r.text ===
			'smooth_intersection #20 · r 0.15');
	}, px);

	/* 4. Delete the sphere. */
	await a.mouse.click(...Object.values(await rowAt(a, 53)));
	await until(a, 'sphere #53 selected', () =>
		window.blobcast.state().selected === 53);
	await a.click('#delbtn');
	await until(a, 'A: deleted', () => window.blobcast.outliner().message
		.startsWith('deleted sphere #53'));
	px = await bSees(b, 'sphere #53 deleted', () => {
		const t = window.blobcast.outliner().tree;
		return t.slice(2).find((c) => c[1] === 20).length === 4 &&
			!JSON.stringify(t).includes(',53]');
	}, px);
	assert.equal(A.sent.edits.length, 4, 'four actions, four EDITs');

	/* Refused in the page: nothing sent, B unchanged. */
	const order = (await b.evaluate(() => window.blobcast.state())).order;
	const refuse = async (what, act, re) => {
		await act();
		const o = await until(a, `A: ${what} refused`, (src) => {
			const r = window.blobcast.outliner();
			return r.refusal && new RegExp(src).test(r.message) ? r : null;
		}, re.source);
		assert.match(await a.locator('#outlinermsg').textContent(), re,
			`${what}: the message is shown`);
		assert.equal(A.sent.edits.length, 4, `${what}: nothing sent`);
		step(`refused: "${o.message}"`);
	};
	await refuse('adding under a primitive', async () => {
		const to = await rowAt(a, 50);
		await a.click('#addbtn');
		const item = await a.locator('#addprims button[data-prim="2"]')
			.boundingBox();
		await drag(a, { x: item.x + 5, y: item.y + 5 }, to);
	}, /^cannot add under sphere #50: a primitive has no children\. Select an operator/);
	await refuse('moving a group under its own child', async () => {
		await a.locator('#outliner .row[data-id="30"] .twist').click();
		await until(a, 'group #30 open', () => window.blobcast.outliner()
			.rows.some((r) => r.id === 31));
		await drag(a, await rowAt(a, 30), await rowAt(a, 31));
	},
	/^cannot move union #30 under smooth_union #31: that is inside it, and a node cannot contain itself\. Drop it on an operator outside it/);
	await refuse('deleting the root', async () => {
		await a.mouse.click(...Object.values(await rowAt(a, 1)));
		await until(a, 'the root selected', () =>
			window.blobcast.state().selected === 1);
		await a.click('#delbtn');
	}, /^cannot delete union #1: it is the root, and a scene is never empty/);
	await a.waitForTimeout(300);
	assert.equal((await b.evaluate(() => window.blobcast.state())).order,
		order, "B's scene did not change");
	step('nothing was sent for the refusals');

	/* A race: B adds a sphere while A has not heard of it yet, and A
	 * adds one with the same new id. The daemon refuses A's (EDUPID);
	 * A says so, with the daemon's text, and then holds B's. */
	A.sent.on = true;
	await b.click('#addbtn');
	await b.click('#addprims button[data-prim="1"]');
	await until(b, 'B: its sphere #53', () => window.blobcast.outliner()
		.message.startsWith('added sphere #53'));
	await a.click('#addbtn');
	await a.click('#addprims button[data-prim="1"]');
	for (let t = 0; A.sent.edits.length < 5; t++) {
		assert.ok(t < 800, 'A sent its add'); /* 20 s, as until() */
		await a.waitForTimeout(25);
	}
	A.sent.release();
	const race = await until(a, 'A: the refusal shown', () => {
		const o = window.blobcast.outliner();
		return o.refusal && o.message.includes('EDUPID') ? o : null;
	});
	assert.match(race.message, /^the daemon refused "added sphere #53 under union #1": EDUPID: .*id 53.* \(another member added a node with the same id at the same time\): try again$/);
	assert.equal(race.tree.filter((c) => c[1] === 53).length, 1,
		"A's mirror holds B's sphere #53 once");
	step(`the race: "${race.message}"`);

	/* The daemon takes a wrap (REPLACE, the ids kept) and a duplicate
	 * (fresh ids) as the page builds them. */
	await a.mouse.click(...Object.values(await rowAt(a, 50)));
	await a.click('#addbtn');
	await a.click('#addunary button[data-unary="10"]');
	await until(a, 'A: sphere #50 wrapped', () => window.blobcast.outliner()
		.message === 'wrapped sphere #50 in twist #54');
	await a.click('#dupbtn');
	const dup = await until(a, 'A: twist #54 duplicated', () => {
		const o = window.blobcast.outliner();
		return o.message === 'duplicated twist #54 as twist #55' ? o : null;
	});
	assert.deepEqual(dup.tree.slice(2).filter((c) => c[0] === 'twist'),
		[['twist', 54, ['sphere', 50]], ['twist', 55, ['sphere', 56]]]);
	await until(b, "B: the wrap and the copy", () => JSON.stringify(
		window.blobcast.outliner().tree).includes('["twist",54,["sphere",' +
		'50]],["twist",55,["sphere",56]]'));
	step('sphere #50 wrapped in twist #54, duplicated as twist #55 (#56)');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
	console.error(H.logs());
} finally {
	await H.finish(browser, failed, watchdog);
}
