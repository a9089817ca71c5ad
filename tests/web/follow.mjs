/*
 * Presenting and following from the browser page: blobcastd, websockify
 * and two pages in headless Debian chromium (playwright-core), "alice" (an
 * editor, 640x400) and "bob" (a viewer, 480x300).
 *  - alice's "present" button makes her the presenter: both pages mark her
 *    in the members list;
 *  - bob's F key follows: his button reads "following alice", his camera
 *    becomes alice's, and when alice turns her camera bob's follows and his
 *    frames come at his own view size;
 *  - bob turning his own camera leaves the follow; the "follow" button
 *    follows again;
 *  - alice's "presenting" button stops: nobody presents, bob no longer
 *    follows.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/follow.mjs --blobcastd PATH
 */
import assert from 'node:assert/strict';

import * as H from './harness.mjs';

const DEADLINE_MS = 60000;

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
H.skipIfMissing('web follow', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();
const watchdog = H.watchdog(DEADLINE_MS);
const until = (page, what, fn, arg, ms = 15000) =>
	H.until(page, what, fn, arg, ms, 30);
const near = (a, b) => a.every((v, i) => Math.abs(v - b[i]) < 1e-4);

async function open(port, web, name, role, width, height) {
	const page = await browser.newPage({ viewport: { width, height } });
	page.on('pageerror', (e) => {
		console.error(`${name}: ${e.message}`);
		failed = true;
	});
	await page.goto(`http://127.0.0.1:${web.port}/?ws=${port}` +
		`&session=default&name=${name}&role=${role}`);
	await until(page, `${name} joined`, () =>
		window.blobcast.state().connected &&
		window.blobcast.state().lastFrame);
	return page;
}

const text = (page, id) => page.evaluate((i) =>
	document.getElementById(i).textContent, id);

try {
	const d = await H.startDaemon(daemon);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	step(`blobcastd :${d.port}, websockify :${proxy.port}, page :${web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const alice = await open(proxy.port, web, 'alice', 'editor', 640, 400);
	const bob = await open(proxy.port, web, 'bob', 'viewer', 480, 300);
	const aliceId = (await alice.evaluate(() =>
		window.blobcast.state())).memberId;

	await alice.click('#presentbtn');
	for (const [p, who] of [[alice, 'alice'], [bob, 'bob']]) {
		await until(p, `${who} sees alice present`, (id) =>
			window.blobcast.state().presenter === id, aliceId);
		const li = await p.evaluate((id) => document.querySelector(
			`#members li[data-member="${id}"] .presenting`)?.textContent,
		aliceId);
		assert.ok(li && li.includes('presenting'),
			`${who}: the members list marks alice (${li})`);
	}
	assert.equal(await text(alice, 'presentbtn'), 'presenting');
	step('alice presents; both pages mark her');

	await bob.keyboard.press('f');
	await until(bob, 'bob follows', () => window.blobcast.state().following);
	assert.equal(await text(bob, 'followbtn'), 'following alice');
	const ac = (await alice.evaluate(() => window.blobcast.state())).camera;
	await until(bob, 'bob has alice\'s camera', (c) => {
		const b = window.blobcast.state().camera;
		return b.eye.every((v, i) => Math.abs(v - c.eye[i]) < 1e-4);
	}, ac);
	step('F: bob follows alice, with her camera');

	/* alice turns: bob's camera and frames follow, at bob's size. */
	const frames = (await bob.evaluate(() =>
		window.blobcast.state())).framesDrawn;
	await alice.evaluate(() => window.blobcast.orbit(120, 30));
	const turned = (await alice.evaluate(() =>
		window.blobcast.state())).camera;
	assert.ok(!near(turned.eye, ac.eye), 'alice\'s camera turned');
	const bs = await until(bob, 'bob\'s camera follows alice\'s turn',
		({ c, n }) => {
			const s = window.blobcast.state();
			return s.camera.eye.every((v, i) =>
				Math.abs(v - c.eye[i]) < 1e-4) && s.framesDrawn > n &&
				s.lastFrame ? s : null;
		}, { c: turned, n: frames });
	const as = await alice.evaluate(() => window.blobcast.state());
	assert.deepEqual([bs.lastFrame.width, bs.lastFrame.height],
		[bs.view.width, bs.view.height], 'bob\'s frames are his view size');
	assert.notDeepEqual(bs.view, as.view, 'the two views differ in size');
	step(`alice turned; bob follows at ${bs.view.width}x${bs.view.height}` +
		` (alice ${as.view.width}x${as.view.height})`);

	/* bob turns his own camera: the follow ends; the button follows
	 * again. */
	await bob.evaluate(() => window.blobcast.orbit(-60, 0));
	await until(bob, 'bob left the follow', () =>
		!window.blobcast.state().following &&
		!window.blobcast.state().followWanted);
	assert.equal(await text(bob, 'followbtn'), 'follow');
	await bob.click('#followbtn');
	await until(bob, 'bob follows again', () =>
		window.blobcast.state().following);
	step('bob\'s own turn left the follow; the button followed again');

	await alice.click('#presentbtn');
	await until(bob, 'nobody presents', () =>
		window.blobcast.state().presenter === 0 &&
		!window.blobcast.state().following);
	/* alice's own page hears it in its own time (bob may be first). */
	await until(alice, 'alice\'s button offers to present again', () =>
		document.getElementById('presentbtn').textContent === 'present');
	step('alice stopped: nobody presents, bob follows no one');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
	console.error(H.logs());
} finally {
	await H.finish(browser, failed, watchdog);
}
