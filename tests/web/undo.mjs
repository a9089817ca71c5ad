/*
 * Undo and redo from the browser page: blobcastd, websockify and one page
 * ("alice") in headless Debian chromium (playwright-core).
 *  - alice moves a primitive; Ctrl-Z puts it back where it was (the
 *    page's mirror applies the EDIT_APPLIED flagged UNDO) and the page
 *    says "alice undid alice's edit N" naming the edit's order;
 *  - Ctrl-Shift-Z moves it again ("alice redid ..."), Ctrl-Y after a
 *    second Ctrl-Z too;
 *  - `blobcast undo --name bob` takes the move back from another client:
 *    the page follows and says "bob undid alice's edit N";
 *  - one more Ctrl-Z, with nothing left to undo: "nothing to undo";
 *  - Ctrl-Z typed in the token field is the field's own: nothing is sent.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/undo.mjs --blobcastd PATH --blobcast PATH
 */
import assert from 'node:assert/strict';

import * as H from './harness.mjs';

const DEADLINE_MS = 60000;

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
const cli = H.findCli(process.argv, lacking);
H.skipIfMissing('web undo', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();

const watchdog = H.watchdog(DEADLINE_MS);

const until = (page, what, fn, arg, ms = 15000) =>
	H.until(page, what, fn, arg, ms, 30);

const run = (args) => H.runCli(cli, args, 15000);

const near = (a, b) => a.every((v, i) => Math.abs(v - b[i]) < 1e-5);

/* Waits until node id is at translate t and the notice reads text. */
async function expect(page, what, id, t, text) {
	const st = await until(page, what, ({ id, t, text }) => {
		const n = window.blobcast.node(id);
		const s = window.blobcast.state();
		return n && n.translate.every((v, i) => Math.abs(v - t[i]) < 1e-5) &&
			s.notice === text ? s : null;
	}, { id, t, text });
	const shown = await page.evaluate(() =>
		document.getElementById('message').textContent);
	assert.equal(shown, text, `${what}: the header shows the notice`);
	step(`${what}: "${text}"`);
	return st;
}

try {
	const d = await H.startDaemon(daemon);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	step(`blobcastd :${d.port}, websockify :${proxy.port}, page :${web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const page = await browser.newPage({ viewport: { width: 640,
		height: 400 } });
	page.on('pageerror', (e) => {
		console.error(`page: ${e.message}`);
		failed = true;
	});
	await page.goto(`http://127.0.0.1:${web.port}/?ws=${proxy.port}` +
		'&session=default&name=alice');
	await until(page, 'the scene', () => window.blobcast.state().connected &&
		window.blobcast.primitives().length > 0);
	assert.equal(await page.evaluate(() =>
		document.getElementById('undobtn').disabled), false,
	'the undo button is enabled for an editor');

	const p = (await page.evaluate(() => window.blobcast.primitives()))[0];
	const moved = [p.translate[0] + 0.25, p.translate[1], p.translate[2]];
	await page.evaluate(({ id, t }) => window.blobcast.moveTo(id, t),
		{ id: p.id, t: moved }).catch(() => {});
	const edit = await until(page, 'the move applied', ({ id, t }) => {
		const n = window.blobcast.node(id);
		const s = window.blobcast.state();
		return n && n.translate.every((v, i) => Math.abs(v - t[i]) < 1e-5)
			? s.lastEdit : null;
	}, { id: p.id, t: moved });
	step(`moved ${p.kind} #${p.id}: edit ${edit.order}`);

	await page.keyboard.press('Control+z');
	await expect(page, 'Ctrl-Z', p.id, p.translate,
		`alice undid alice's edit ${edit.order}`);
	await page.keyboard.press('Control+Shift+Z');
	await expect(page, 'Ctrl-Shift-Z', p.id, moved,
		`alice redid alice's edit ${edit.order}`);
	await page.keyboard.press('Control+z');
	await expect(page, 'Ctrl-Z again', p.id, p.translate,
		`alice undid alice's edit ${edit.order}`);
	await page.keyboard.press('Control+y');
	await expect(page, 'Ctrl-Y', p.id, moved,
		`alice redid alice's edit ${edit.order}`);

	const r = await run(['undo', '--server', `127.0.0.1:${d.port}`,
		'--session', 'default', '--name', 'bob']);
	assert.equal(r.code, 0, `blobcast undo: ${r.stderr}`);
	await expect(page, 'blobcast undo by bob', p.id, p.translate,
		`bob undid alice's edit ${edit.order}`);

	await page.keyboard.press('Control+z');
	await expect(page, 'Ctrl-Z with nothing left', p.id, p.translate,
		'nothing to undo');

	/* In a text field Ctrl-Z belongs to the field. */
	const order = (await page.evaluate(() => window.blobcast.state())).order;
	await page.evaluate(() => {
		document.getElementById('alert').hidden = false;
		document.getElementById('tokenform').hidden = false;
		document.getElementById('token').focus();
	});
	await page.keyboard.press('Control+Shift+Z');
	await page.waitForTimeout(400);
	const after = await page.evaluate(() => window.blobcast.state());
	assert.equal(after.order, order, 'Ctrl-Shift-Z in a field sent no REDO');
	assert.ok(near((await page.evaluate((id) => window.blobcast.node(id),
		p.id)).translate, p.translate), 'the node stayed put');
	step('Ctrl-Shift-Z in the token field sent nothing');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
	console.error(H.logs());
} finally {
	await H.finish(browser, failed, watchdog);
}
