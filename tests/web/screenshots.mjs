/*
 * Makes docs/web-outliner.png, docs/web.png and docs/viewer.png.
 * web-outliner.png: the page as "dana", who names union #30 "body" and
 * smooth_union #31 "dome" in the outliner (double-click, type, Enter),
 * with #31 selected in the Scene panel (its row, the operator form) and
 * the Add menu open; the page then leaves, the shapes unchanged. With
 * --outliner-only the script stops there (no viewer needed).
 * web.png and viewer.png: one session, three members. A
 * blobcastd with websockify in front, the page as "alice" (editor) and
 * "bob" (viewer) in headless chromium, and blobcast-view as "carol" under
 * Xvfb. Alice drags the red marble (an edit every member sees, "last edit").
 * Bob presents (his "present" button); carol follows with F and alice with
 * her "follow" button. Bob then orbits and holds the button: alice's and
 * carol's pictures follow his camera at their own sizes, at a coarse
 * refinement level ("refining · level 1") when web.png is taken and when
 * carol's window is saved with P.
 * Not a test: run it by hand when the pictures should change.
 *
 * usage: xvfb-run -a -s "-screen 0 1280x800x24" node tests/web/screenshots.mjs
 *            --blobcastd PATH --viewer PATH --xpoke PATH [--out DIR]
 *        node tests/web/screenshots.mjs --blobcastd PATH --outliner-only
 */
import { spawn } from 'node:child_process';
import { copyFileSync, existsSync, mkdtempSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';

import * as H from './harness.mjs';

const arg = (name, def) => {
	const i = process.argv.indexOf(name);
	return i >= 0 ? process.argv[i + 1] : def;
};
const daemon = arg('--blobcastd', H.findDaemon(process.argv));
const viewer = resolve(arg('--viewer', 'build/client/viewer/blobcast-view'));
const xpoke = resolve(arg('--xpoke', 'build/tests/viewer/viewer_xpoke'));
const out = arg('--out', join(H.ROOT, 'docs'));
const chromium = await H.playwright();

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const until = (page, fn, arg1, ms = 30000) =>
	H.until(page, String(fn), fn, arg1, ms, 40);
function run(cmd, args) {
	return new Promise((res, rej) => {
		const c = spawn(cmd, args, { stdio: 'inherit' });
		c.on('exit', (code) => (code === 0 ? res() : rej(new Error(
			`${cmd} ${args.join(' ')}: exit ${code}`))));
	});
}

/* Thrown to end the script early (--outliner-only), not a failure. */
const DONE = new Error('done');
let browser = null;
let view = null;
const work = mkdtempSync(join(tmpdir(), 'blobcast-shots-'));
try {
	const d = await H.startDaemon(daemon, ['--backend', 'cpu']);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const open = async (name, role) => {
		const p = await browser.newPage({ viewport: { width: 1100,
			height: 640 } });
		await p.goto(`http://127.0.0.1:${web.port}/?ws=${proxy.port}` +
			`&session=default&name=${name}&role=${role}`);
		await until(p, () => window.blobcast.state().framesDrawn >= 1);
		return p;
	};
	/* The Scene panel: a group selected by its row, the Add menu open. */
	const dana = await open('dana', 'editor');
	for (const [id, name] of [[30, 'body'], [31, 'dome']]) {
		await dana.locator(`#outliner .row[data-id="${id}"] .label`)
			.dblclick();
		await dana.locator('#outliner input.rename').fill(name);
		await dana.keyboard.press('Enter');
		await until(dana, (a) => window.blobcast.node(a.id)?.name ===
			a.name, { id, name });
	}
	await dana.locator('#outliner .row[data-id="31"]').click();
	await until(dana, () => !document.getElementById('opedit').hidden);
	await dana.click('#addbtn');
	await dana.hover('#addprims button[data-prim="5"]');
	await sleep(800);
	await dana.screenshot({ path: join(out, 'web-outliner.png') });
	console.log(`wrote ${join(out, 'web-outliner.png')}`);
	await dana.close();
	if (process.argv.includes('--outliner-only')) {
		throw DONE;
	}
	const alice = await open('alice', 'editor');
	const bob = await open('bob', 'viewer');
	view = spawn(viewer, ['--server', `127.0.0.1:${d.port}`, '--name',
		'carol', '--size', '960x600', '--snapshot-dir', work], {
		cwd: work, stdio: 'inherit' });
	await until(alice, () => window.blobcast.state().members.length === 3);

	/* Alice moves the red marble (node 50 of the built-in scene). */
	const s = { at: await alice.evaluate(() => window.blobcast.project(50)) };
	const hit = await alice.evaluate(({ x, y }) => window.blobcast.pick(
		Math.round(x), Math.round(y)), s.at);
	if (!hit || hit.node !== 50) {
		throw new Error(`the marble is not under its centre: ${
			JSON.stringify(hit)}`);
	}
	const box = await alice.evaluate(() => {
		const r = document.getElementById('view').getBoundingClientRect();
		const v = window.blobcast.state().view;
		return { x: r.left, y: r.top, sx: r.width / v.width,
			sy: r.height / v.height };
	});
	const px = box.x + s.at.x * box.sx, py = box.y + s.at.y * box.sy;
	await alice.mouse.move(px, py);
	await alice.mouse.down();
	for (let i = 1; i <= 10; i++) {
		await alice.mouse.move(px + 4 * i, py - i);
		await alice.waitForTimeout(30);
	}
	await alice.mouse.up();
	await sleep(1500);

	/* Bob presents; carol (F) and alice (the button) follow him. */
	const bobId = (await bob.evaluate(() => window.blobcast.state())).memberId;
	await bob.click('#presentbtn');
	await until(alice, (id) => window.blobcast.state().presenter === id,
		bobId);
	await run(xpoke, ['blobcast-view', 'wait', '5000', 'key', 'f']);
	await alice.click('#followbtn');
	await until(alice, () => window.blobcast.state().following);
	await sleep(1500);

	/* Bob's orbit, held down: his followers get coarse frames of his
	 * camera; then the screenshots. */
	const bb = await bob.evaluate(() => {
		const r = document.getElementById('view').getBoundingClientRect();
		return { x: r.left, y: r.top };
	});
	const ex = bb.x + 40, ey = bb.y + 80;
	await bob.mouse.move(ex, ey);
	await bob.mouse.down();
	for (let i = 1; i <= 8; i++) {
		await bob.mouse.move(ex + 6 * i, ey + i);
		await bob.waitForTimeout(25);
	}
	await until(alice, () => window.blobcast.state().lastFrame?.refining);
	await alice.screenshot({ path: join(out, 'web.png') });
	console.log(`wrote ${join(out, 'web.png')}`);
	for (let i = 9; i <= 12; i++) {
		await bob.mouse.move(ex + 6 * i, ey + i);
		await bob.waitForTimeout(25);
	}
	await run(xpoke, ['blobcast-view', 'key', 'p', 'sleep', '500']);
	await bob.mouse.up();
	await run(xpoke, ['blobcast-view', 'sleep', '300', 'keydown', 'q']);
	await new Promise((r) => view.on('exit', r));
	view = null;
	const shot = join(work, 'blobcast-view-001.png');
	if (!existsSync(shot)) {
		throw new Error('the viewer saved no screenshot');
	}
	copyFileSync(shot, join(out, 'viewer.png'));
	console.log(`wrote ${join(out, 'viewer.png')}`);
	await bob.close();
} catch (e) {
	if (e !== DONE) {
		console.error(`FAIL: ${e.stack || e}\n${H.logs()}`);
		process.exitCode = 1;
	}
} finally {
	view?.kill();
	if (browser) {
		await browser.close().catch(() => {});
	}
	await H.stopAll();
}
