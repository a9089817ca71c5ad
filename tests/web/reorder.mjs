/*
 * Reordering in the browser page's outliner: blobcastd, websockify and
 * two pages ("alice" and "bob") in one session in headless Debian
 * chromium (playwright-core), small views of the built-in scene.
 *  - alice drags sphere #50's row to the upper edge of the
 *    smooth_intersection #21 row: while she holds it an insertion line
 *    shows above that row; dropped, it is one EDIT (REMOVE, INSERT at
 *    place 0 of difference #20), and the sphere is now the shape the
 *    others are cut from;
 *  - she selects #21 and presses Alt+Up: one EDIT (REMOVE, INSERT at 0
 *    of the same group) puts it first again;
 *  - after each step bob's outliner lists the new order, bob draws a new
 *    picture, and alice's and bob's pictures are the same;
 *  - alice's Ctrl-Z takes the Alt+Up back as one step on both pages (the
 *    picture of the drag comes back);
 *  - a drop at the node's own place (just below the row above it) sends
 *    nothing and says so;
 *  - Alt+Down on the first of two children is one REPLACE of their
 *    group (a REMOVE would dissolve it) that the daemon takes;
 *  - a regroup over a limit: a scene loaded with `blobcast load` has 16
 *    twists over a union and 17 over a sphere (each path within the 32
 *    domain nodes of blobtree's BC_DOMAIN_MAX_CHAIN); dragging the 17
 *    into the union would put 33 on one path: alice's page refuses with
 *    its message, sends nothing, and the daemon's order stays.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/reorder.mjs --blobcastd PATH
 * --blobcast PATH
 */
import assert from 'node:assert/strict';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import * as H from './harness.mjs';
import * as P from '../../client/web/protocol.js';
import { DOMAIN_CHAIN } from '../../client/web/model.js';

const DEADLINE_MS = 90000;
const VIEW = { width: 600, height: 640 };
const { REMOVE, INSERT } = P.EDIT;

const { daemon, cli, chromium, step, watchdog, until } = await H.begin(
	'web reorder', { cli: true, ms: DEADLINE_MS });

let browser = null;
let failed = false;

const outliner = (page) => page.evaluate(() => window.blobcast.outliner());

const rowAt = H.rowPoint;
const press = (page, a, b) => H.pointerPress(page, a, b, 6);

/* Selects node id by a click on its row, presses key and waits for the
 * panel's message to read text (the edit applied); returns the
 * outliner's state. */
async function keyMove(page, id, key, text) {
	await page.mouse.click(...Object.values(await rowAt(page, id)));
	await until(page, `#${id} selected`, (n) =>
		window.blobcast.state().selected === n, id);
	await page.keyboard.press(key);
	return until(page, `${key} on #${id}: "${text}"`, (t) => {
		const o = window.blobcast.outliner();
		return o.message === t ? o : null;
	}, text);
}

/* The order of the last edit and the view's pixels (RGB of every 4th
 * pixel) once page has drawn a still frame of it. */
async function picture(page, who) {
	const st = await until(page, `${who}: a still frame of the last edit`,
		() => {
			const s = window.blobcast.state();
			const f = s.lastFrame;
			/* Whole: on a busy machine a still frame may come cut by
			 * the time budget (refining), its rest in frames after. */
			return f && f.still && !f.refining &&
				BigInt(f.order) >= BigInt(s.order) &&
				f.width === s.view.width && f.height === s.view.height ? s
				: null;
		});
	const px = await H.viewPixels(page, 4);
	return { order: st.order, px };
}

/* Pixels of a and b whose RGB differ by more than 40 in all. */
function differing(a, b) {
	assert.equal(a.length, b.length, 'pictures of the same size');
	return H.pixelsChanged(a, b);
}

/* After an edit of alice's: bob's tree holds children of difference #20
 * in order, his rows list them so, and both draw a still frame of the
 * edit, the same picture, which differs from before (when given).
 * Returns bob's picture. */
async function bothSee(alice, bob, what, order, before) {
	await until(bob, `bob: ${what}`, (ids) => {
		const o = window.blobcast.outliner();
		const g = o.tree.slice(2).find((c) => c[1] === 20);
		/* The rows one level below #20's, up to the next at its level. */
		const at = o.rows.findIndex((r) => r.id === 20);
		const level = o.rows[at]?.level;
		const rows = [];
		for (let i = at + 1; i < o.rows.length && o.rows[i].level > level;
			i++) {
			if (o.rows[i].level === level + 1) {
				rows.push(o.rows[i].id);
			}
		}
		return g && JSON.stringify(g.slice(2).map((c) => c[1])) ===
			JSON.stringify(ids) && JSON.stringify(rows) === JSON.stringify(ids);
	}, order);
	const b = await picture(bob, 'bob');
	const a = await picture(alice, 'alice');
	assert.equal(a.order, b.order, `${what}: the same edit on both`);
	const same = differing(a.px, b.px);
	assert.ok(same <= a.px.length / 3 / 200, `${what}: alice's and bob's ` +
		`pictures match (${same} pixels differ)`);
	const moved = before ? differing(before, b.px) : 0;
	if (before) {
		assert.ok(moved > 20, `${what}: the picture changed (${moved} ` +
			'pixels)');
	}
	step(`bob: ${what}: #20 holds ${order.join(', ')}; pictures match ` +
		`(${same} pixels differ), ${moved} pixels changed (edit ${b.order})`);
	return b.px;
}

try {
	const stack = await H.startStack(daemon);
	const port = stack.d.port;
	step(`blobcastd :${port}, websockify :${stack.proxy.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const open = async (name) => {
		const page = await H.joinPage(browser, stack, { name,
			viewport: VIEW });
		await until(page, `${name}: a still frame and the outliner`, () =>
			window.blobcast.state().lastFrame?.still && window.blobcast
				.outliner().rows.some((r) => r.id === 50), null, 45000);
		return page;
	};
	const alice = await open('alice');
	const bob = await open('bob');
	/* Close groups so that every row dragged between fits the list. */
	for (const id of [10, 21, 24, 30]) {
		await alice.locator(`#outliner .row[data-id="${id}"] .twist`).click();
		await until(alice, `group #${id} closed`, (g) => window.blobcast
			.outliner().rows.every((r) => r.id !== g + 1), id);
	}
	let px = (await picture(bob, 'bob')).px;
	const tip = await alice.locator('#outliner .row[data-id="21"]')
		.getAttribute('title');
	assert.match(tip,
		/^the shape the other children of difference #20 are cut from/);
	step('both pages show the built-in scene; #21\'s tooltip: ' +
		`"${tip.slice(0, 50)}…"`);

	/* 1. Drag sphere #50 to the upper edge of #21's row. */
	const drop = await press(alice, await rowAt(alice, 50),
		await rowAt(alice, 21, 0.15));
	const line = await alice.evaluate(() => {
		const r = document.querySelector('#outliner .row[data-id="21"]');
		const s = getComputedStyle(r, '::after');
		return { cls: r.className, content: s.content, height: s.height,
			top: s.top, bg: s.backgroundColor };
	});
	assert.match(line.cls, /\bdrop-line\b/, 'an insertion line is shown');
	assert.match(line.cls, /\bdrop-before\b/, 'above the row');
	assert.equal(line.height, '2px', 'the line is drawn');
	assert.equal(line.top, '-1px', 'at the top edge');
	assert.notEqual(line.bg, 'rgba(0, 0, 0, 0)', 'in a colour');
	await drop();
	const moved = await until(alice, 'alice: sphere #50 placed', () => {
		const o = window.blobcast.outliner();
		return o.message.startsWith('moved sphere #50 to place 1 of ' +
			'difference #20') && !o.message.endsWith('…') ? o : null;
	});
	assert.match(moved.message,
		/: sphere #50 is now the shape the others are cut from$/);
	assert.deepEqual(moved.lastOps, [[REMOVE, 50, null], [INSERT, 20, 0]],
		'one EDIT: REMOVE, INSERT at place 0');
	assert.equal(await alice.locator('#outliner .drop-line').count(), 0,
		'the line is gone after the drop');
	const sent = moved.sent;
	const dragged = px = await bothSee(alice, bob, 'the drag', [50, 21, 24],
		px);

	/* 2. Alt+Up on #21. */
	const up = await keyMove(alice, 21, 'Alt+ArrowUp', 'moved ' +
		'smooth_intersection #21 to place 1 of difference #20: ' +
		'smooth_intersection #21 is now the shape the others are cut from');
	assert.deepEqual(up.lastOps, [[REMOVE, 21, null], [INSERT, 20, 0]]);
	assert.equal(up.sent, sent + 1, 'one EDIT');
	px = await bothSee(alice, bob, 'Alt+Up', [21, 50, 24], px);
	assert.equal((await alice.evaluate(() => window.blobcast.state()))
		.selected, 21, '#21 stays selected');

	/* 3. Ctrl-Z: the Alt+Up goes back in one step. */
	await alice.keyboard.press('Control+z');
	/* Both pages say who undid what; the line is cleared again so that
	 * the views keep the size of the pictures before. */
	for (const [page, who] of [[alice, 'alice'], [bob, 'bob']]) {
		await until(page, `${who}: the undo's notice`, () =>
			document.getElementById('message').textContent ===
			'alice undid alice\'s edit 2');
		await page.evaluate(() => {
			document.getElementById('message').textContent = '';
		});
	}
	px = await bothSee(alice, bob, 'Ctrl-Z', [50, 21, 24], px);
	const back = differing(dragged, px);
	assert.ok(back <= px.length / 3 / 200, `the drag's picture is back ` +
		`(${back} pixels differ)`);

	/* 4. Dropping #21 at its own place (below #50, the row above it). */
	const o0 = await outliner(alice);
	await (await press(alice, await rowAt(alice, 21),
		await rowAt(alice, 50, 0.85)))();
	const own = await until(alice, 'alice: the own place refused', () => {
		const o = window.blobcast.outliner();
		return o.refusal ? o : null;
	});
	assert.equal(own.message, 'smooth_intersection #21 is already at that ' +
		'place in difference #20: nothing to move');
	assert.equal(own.sent, o0.sent, 'nothing sent');
	step(`own place: "${own.message}"`);

	/* 5. Alt+Down in a group of two: one REPLACE, the ids kept. */
	const swap = await keyMove(alice, 41, 'Alt+ArrowDown',
		'moved torus #41 to place 2 of smooth_union #40');
	assert.deepEqual(swap.lastOps, [[P.EDIT.REPLACE, 40, null]]);
	await until(bob, 'bob: #40 holds #42, #41', () => JSON.stringify(
		window.blobcast.outliner().tree).includes('["smooth_union",40,' +
		'["capsule",42],["torus",41]]'));
	step('Alt+Down in smooth_union #40 (two children): one REPLACE; bob ' +
		'lists capsule #42 first');

	/* 6. A regroup over the domain chain limit. */
	const chain = (first, n, child) => {
		let c = child;
		for (let i = n - 1; i >= 0; i--) {
			c = { type: 'twist', id: first + i, rate: 0.05, children: [c] };
		}
		return c;
	};
	const half = DOMAIN_CHAIN / 2;
	const work = mkdtempSync(join(tmpdir(), 'blobcast-reorder-'));
	const file = join(work, 'chains.json');
	writeFileSync(file, JSON.stringify({ blobcast: 1, root: { type: 'union',
		id: 1, children: [
			chain(100, half, { type: 'union', id: 2, children: [
				{ type: 'sphere', id: 3, radius: 0.5 },
				{ type: 'sphere', id: 4, radius: 0.3,
					translate: [0.6, 0, 0] }] }),
			chain(200, half + 1, { type: 'sphere', id: 5, radius: 0.4,
				translate: [0, 1, 0] })] } }));
	const r = await H.runCli(cli, ['load', '--server', `127.0.0.1:${port}`,
		'--session', 'default', file]);
	rmSync(work, { recursive: true, force: true });
	assert.equal(r.code, 0, `blobcast load: ${r.stderr}`);
	/* Tall enough for every row from union #2 up to twist #200. */
	await alice.setViewportSize({ width: VIEW.width, height: 1300 });
	await until(alice, 'alice: the loaded scene', () => window.blobcast
		.outliner().rows.some((r) => r.id === 200));
	/* Down the chain with the keys: Right opens a group, Down goes on. */
	await alice.mouse.click(...Object.values(await rowAt(alice, 100)));
	await alice.focus('#outliner');
	for (let i = 0; i < 3 * half; i++) {
		if ((await alice.evaluate(() => window.blobcast.state().selected)) ===
			2) {
			break;
		}
		await alice.keyboard.press('ArrowRight');
		await alice.keyboard.press('ArrowDown');
	}
	await until(alice, 'union #2 selected by the keys', () =>
		window.blobcast.state().selected === 2);
	await alice.locator('#outliner .row[data-id="201"] .twist').click();
	await until(alice, 'twist #201 closed', () => window.blobcast.outliner()
		.rows.every((r) => r.id !== 202));
	const before = await alice.evaluate(() => ({
		order: window.blobcast.state().order,
		sent: window.blobcast.outliner().sent }));
	await (await press(alice, await rowAt(alice, 200),
		await rowAt(alice, 2)))();
	const limit = await until(alice, 'alice: the regroup refused', () => {
		const o = window.blobcast.outliner();
		return o.refusal && o.message.includes('domain') ? o : null;
	});
	assert.match(limit.message, new RegExp(`^a path would pass ${
		DOMAIN_CHAIN + 1} domain nodes \\(elongate, twist, bend, mirror, ` +
		`repeat, scale\\), more than ${DOMAIN_CHAIN}: remove one of them ` +
		'first$'));
	assert.match(await alice.locator('#outlinermsg').textContent(),
		/domain nodes/, 'the message is shown');
	assert.equal(limit.sent, before.sent, 'nothing sent');
	await alice.waitForTimeout(300);
	const after = await alice.evaluate(() => window.blobcast.state().order);
	assert.equal(after, before.order, "the daemon's order did not change");
	const s = await H.runCli(cli, ['scene', '--server', `127.0.0.1:${port}`,
		'--session', 'default']);
	assert.equal(s.code, 0, `blobcast scene: ${s.stderr}`);
	const root = JSON.parse(s.stdout).root;
	assert.deepEqual(root.children.map((c) => c.id), [100, 200],
		'the daemon\'s tree is as loaded');
	step(`over the limit: "${limit.message}"; nothing sent, the ` +
		`daemon's order stays ${after}`);
} catch (e) {
	failed = true;
	H.report(e);
} finally {
	await H.finish(browser, failed, watchdog);
}
