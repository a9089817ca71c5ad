/*
 * The browser page against a daemon that requires tokens, through
 * websockify, in headless Debian chromium (playwright-core):
 *  - without a token the daemon answers EAUTH: the page stops with a notice
 *    naming EAUTH and a token form, and opens no second connection;
 *  - a wrong token typed in the form: EAUTH again, one more connection;
 *  - the editor token typed in the form: the page joins as an editor and
 *    draws frames; the token is in this tab's sessionStorage, the input is
 *    cleared, and a reload joins again without typing;
 *  - a viewer token given as `#token=`: the fragment is scrubbed from the
 *    address bar, the page joins as a viewer (the editor role is refused
 *    with EPERM) and says "view only"; no request URL the page made, page
 *    or WebSocket, carries a token;
 *  - a session that does not exist: the page stops with ENOSESSION and a
 *    create button instead of creating it; the button creates and joins;
 *  - the daemon stops and starts again on the same port: the page notices,
 *    retries, rejoins and draws new frames.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/access.mjs [--blobcastd PATH]
 */
import assert from 'node:assert/strict';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import * as H from './harness.mjs';

const DEADLINE_MS = 110000;
const EDITOR = 'ed-3f9c1a7b';
const VIEWER = 'vw-82d4e650';

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
H.skipIfMissing('web access test', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();
const watchdog = H.watchdog(DEADLINE_MS);

const until = (page, what, fn, arg, ms = 30000) =>
	H.until(page, what, fn, arg, ms, 50);

/* A page that records every URL it asks for and counts its WebSockets. */
async function openPage(url) {
	const page = await browser.newPage({ viewport: { width: 800,
		height: 500 } });
	page.urls = [];
	page.sockets = 0;
	page.on('pageerror', (e) => {
		console.error(`page: ${e.message}`);
		failed = true;
	});
	page.on('request', (r) => page.urls.push(r.url()));
	page.on('websocket', (ws) => {
		page.sockets++;
		page.urls.push(ws.url());
	});
	await page.goto(url);
	return page;
}

const cfgDir = mkdtempSync(join(tmpdir(), 'blobcast-web-access-'));
try {
	const cfg = join(cfgDir, 'blobcastd.json');
	writeFileSync(cfg, JSON.stringify({ tokens: [
		{ token: EDITOR, role: 'editor' },
		{ token: VIEWER, role: 'viewer' }] }));
	let d = await H.startDaemon(daemon, ['--config', cfg]);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	const base = `http://127.0.0.1:${web.port}/?ws=${proxy.port}`;
	step(`blobcastd :${d.port} (tokens), websockify :${proxy.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });

	/* No token: EAUTH stops the page. */
	const a = await openPage(`${base}&session=default&name=alice`);
	await until(a, 'the EAUTH notice', () =>
		window.blobcast.state().halted?.code === 'EAUTH');
	assert.ok(await a.isVisible('#alert'), 'the notice shows');
	assert.ok(await a.isVisible('#tokenform'), 'the token form shows');
	assert.match(await a.textContent('#alerttext'), /EAUTH/);
	assert.match(await a.textContent('#conn'), /stopped \(EAUTH\)/);
	await a.waitForTimeout(2500);
	assert.equal(a.sockets, 1, 'no retry after EAUTH');
	step('no token: EAUTH shown, one connection in 2.5 s');

	/* A wrong token. */
	await a.fill('#token', 'not-the-token');
	await a.click('#tokenform button');
	await until(a, 'a second EAUTH', (n) => window.blobcast.state().halted &&
		document.getElementById('alert').hidden === false, a.sockets);
	await a.waitForTimeout(1500);
	assert.equal(a.sockets, 2, 'one connection per token tried');
	assert.equal((await a.evaluate(() => window.blobcast.state())).halted
		?.code, 'EAUTH');

	/* The editor token. */
	await a.fill('#token', EDITOR);
	await a.click('#tokenform button');
	await until(a, 'frames after the editor token', () => {
		const s = window.blobcast.state();
		return s.connected && s.role === 1 && s.framesDrawn >= 1;
	}, null, 45000);
	assert.equal(await a.isVisible('#alert'), false, 'the notice goes');
	assert.equal(await a.inputValue('#token'), '', 'the input is cleared');
	assert.equal(await a.evaluate(() =>
		sessionStorage.getItem('blobcast.token')), EDITOR);
	step('editor token typed: joined as editor, frames drawn');
	await a.reload();
	await until(a, 'frames after a reload', () => {
		const s = window.blobcast.state();
		return s.connected && s.role === 1 && s.framesDrawn >= 1;
	}, null, 45000);
	step('reload: joined again with the stored token');

	/* A viewer token in the fragment. */
	const b = await openPage(`${base}&session=default&name=bob` +
		`#token=${VIEWER}`);
	await until(b, 'bob as a viewer', () => {
		const s = window.blobcast.state();
		return s.connected && s.role === 2 && s.framesDrawn >= 1;
	}, null, 45000);
	assert.equal(await b.evaluate(() => location.hash), '',
		'the fragment is scrubbed');
	assert.ok(!(await b.evaluate(() => location.href)).includes(VIEWER));
	assert.match(await b.textContent('#session'), /view only/);
	for (const p of [a, b]) {
		for (const u of p.urls) {
			assert.ok(!u.includes(EDITOR) && !u.includes(VIEWER),
				`a token in a requested URL: ${u}`);
		}
	}
	step('viewer token in #token=: fragment scrubbed, joined view only');
	await b.close();

	/* A session that does not exist. */
	const c = await openPage(`${base}&session=nosuch&name=carol` +
		`#token=${EDITOR}`);
	await until(c, 'the ENOSESSION notice', () =>
		window.blobcast.state().halted?.code === 'ENOSESSION');
	assert.ok(await c.isVisible('#create'), 'a create button');
	assert.equal(await c.evaluate(() => window.blobcast.state().connected),
		false, 'not joined');
	await c.click('#create');
	await until(c, 'carol in the new session', () => {
		const s = window.blobcast.state();
		return s.connected && s.framesDrawn >= 1 &&
			document.getElementById('session').textContent ===
				'session nosuch';
	}, null, 45000);
	step('missing session: ENOSESSION shown; created on request');
	await c.close();

	/* The daemon restarts: the page rejoins. */
	const before = (await a.evaluate(() => window.blobcast.state()))
		.framesDrawn;
	await H.stopChild(d.child);
	await until(a, 'the page to notice', () =>
		!window.blobcast.state().connected);
	d = await H.startDaemon(daemon, ['--config', cfg], { port: d.port,
		data: d.data });
	await until(a, 'the page to rejoin', (n) => {
		const s = window.blobcast.state();
		return s.connected && s.framesDrawn > n;
	}, before, 45000);
	step('daemon restarted: the page rejoined and draws frames');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}\n${H.logs()}`);
} finally {
	rmSync(cfgDir, { recursive: true, force: true });
	await H.finish(browser, failed, watchdog);
}
