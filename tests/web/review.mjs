/*
 * The page for a reviewer: blobcastd with an editor and a viewer token,
 * websockify, and pages in headless Debian chromium (playwright-core).
 *  - the header says how each page is connected: "editor · token" for the
 *    editor token, "view only · viewer token" with its warning for the
 *    viewer token, "token needed" without one;
 *  - the session list lists the daemon's sessions; its form refuses a bad
 *    name in the page, creates a session and joins it; its join button
 *    moves the page to another session; its delete button deletes one;
 *    with the viewer token the daemon's refusals (EPERM) of delete and
 *    create are shown and nothing changes;
 *  - camera: after a zoom far out, zoom-to-fit (Home) makes the scene
 *    cover a much larger share of the picture with its box inside the
 *    view; reset (R) brings back the session's camera and its picture;
 *    set (Shift-R) makes a zoomed view the session's camera at the daemon
 *    (`blobcast scene` carries it) and R then comes back to it; the
 *    button is off for the viewer token;
 *  - frames: the encoding control switches the FRAMEs between PNG, raw
 *    and JPEG; the header's PNG button downloads a PNG of the view size;
 *    against a stand-in server that refuses raw frames (the page's
 *    WebSocket answered by this script), the control marks raw refused
 *    and goes back to the encoding the server still sends;
 *  - load: a hand-made JSON file (defaults, ids and camera left out,
 *    names, unary nodes), the scene with every kind and a binary file,
 *    each loaded from the page (file input, confirmed), make the session
 *    `blobcast load` makes of the same file, byte for byte (`blobcast
 *    scene`); a bad shape is refused by the daemon with its words, a
 *    duplicate key by the page before anything is sent; each read in the
 *    page's worker (sceneworker.js), and on the page itself where the
 *    worker fails; a big JSON file (131072 spheres) is read in the worker
 *    while the page answers and its animation frames keep coming, a
 *    second load meanwhile is refused, and it makes the session
 *    `blobcast load` makes;
 *  - the JSON button downloads the scene (every primitive kind, unary
 *    nodes, an edit from the page, a session camera set by another
 *    client): the file equals `blobcast scene` of the session byte for
 *    byte; `blobcast load` takes it into another session whose scene is
 *    the same; the binary button's file equals `blobcast scene --binary`
 *    and loads back as the same scene; blobcastd's own loader takes it from a data directory
 *    (--check, then a start) and serves the same scene.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/review.mjs --blobcastd PATH --blobcast PATH
 */
import assert from 'node:assert/strict';
import { copyFileSync, mkdirSync, mkdtempSync, readFileSync, rmSync,
	statSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import * as P from '../../client/web/protocol.js';
import * as H from './harness.mjs';

const DEADLINE_MS = 150000;
/* The big JSON file's spheres: 21.7 MB that take the page's reader a
 * second or more, long enough to watch the read from outside the
 * worker. */
const BIG_COUNT = 131072;
const EDITOR = 'ed-51c0d2e9';
const VIEWER = 'vw-7a44b1f3';
const W = 400, H2 = 260; /* the pages' size (the view is a little less) */

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
const cli = H.findCli(process.argv, lacking);
H.skipIfMissing('web review test', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();
const watchdog = H.watchdog(DEADLINE_MS);
const work = mkdtempSync(join(tmpdir(), 'blobcast-web-review-'));

const until = (page, what, fn, arg, ms = 40000) =>
	H.until(page, what, fn, arg, ms, 40);

async function openPage(url) {
	const page = await browser.newPage({ viewport: { width: W + 280,
		height: H2 + 90 }, acceptDownloads: true });
	page.on('pageerror', (e) => {
		console.error(`page: ${e.message}`);
		failed = true;
	});
	/* The delete button asks first. */
	page.on('dialog', (d) => d.accept());
	await page.goto(url);
	return page;
}

const joined = (page, name) => until(page, `joined ${name}`, (n) => {
	const s = window.blobcast.state();
	return s.connected && s.framesDrawn >= 1 && document.getElementById(
		'session').textContent.startsWith(`session ${n}`) &&
		window.blobcast.primitives().length > 0;
}, name);

/* The list shows names (all of them there, or none of gone). */
const listed = (page, names, gone = []) => until(page, `the list with ` +
	`${names} and without ${gone}`, ([want, not]) => {
	const s = window.blobcast.sessions();
	return !s.busy && s.names && want.every((n) => s.names.includes(n)) &&
		!not.some((n) => s.names.includes(n));
}, [names, gone]);

/* Until the last frame drawn answers this page's last camera, is whole
 * and final; returns it. */
const settled = (page, what) => until(page, what, () => {
	const s = window.blobcast.state();
	const f = s.lastFrame;
	return f && !s.pending && f.still && !f.refining &&
		f.camera_seq >= window.blobcast.cameraSeq() ? f : null;
});

/* The share of the view's pixels that are not the renderer's background
 * (render/common/shade.c: a vertical gradient); keep: the pixels stay in
 * the page as window[keep]; than: the mean difference per channel from
 * the pixels kept as window[than]. */
const coverage = (page, keep, than) => page.evaluate(([k, t]) => {
	const c = document.getElementById('view');
	const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
	let n = 0;
	for (let y = 0; y < c.height; y++) {
		const v = c.height > 1 ? y / (c.height - 1) : 0;
		const bg = [Math.trunc(30 - 22 * v), Math.trunc(33 - 24 * v),
			Math.trunc(42 - 30 * v)];
		for (let x = 0; x < c.width; x++) {
			const i = 4 * (y * c.width + x);
			if (Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) +
				Math.abs(d[i + 2] - bg[2]) > 12) {
				n++;
			}
		}
	}
	let diff = null;
	if (t) {
		const o = window[t];
		diff = o.length === d.length ? 0 : Infinity;
		for (let i = 0; i < d.length && o.length === d.length; i++) {
			diff += Math.abs(d[i] - o[i]);
		}
		diff /= d.length;
	}
	if (k) {
		window[k] = d;
	}
	return { share: n / (c.width * c.height), diff };
}, [keep ?? null, than ?? null]);

/* A stand-in for the daemon on a page's WebSocket that refuses VIEWs
 * asking for raw frames (ERROR EINVAL, as blobcastd refuses an encoding
 * a client did not announce); views: the VIEWs it took. */
function refusingServer(ws, views) {
	H.standInDaemon(ws, { each: (m, send) => {
		if (m.type === P.MSG.VIEW && m.encoding === P.ENC.RAW) {
			send({ type: P.MSG.ERROR, seq: m.seq, code: P.ERR.EINVAL,
				text: 'encoding 3 was not in your HELLO' });
		} else if (m.type === P.MSG.VIEW) {
			views.push(m.encoding);
		}
	} });
}

/* The screen position of world point p with the page's camera (its
 * conventions: forward = target - eye, right = forward x up). */
function project(cam, view, p) {
	const sub = (a, b) => a.map((v, k) => v - b[k]);
	const dot = (a, b) => a.reduce((s, v, k) => s + v * b[k], 0);
	const cross = (a, b) => [a[1] * b[2] - a[2] * b[1],
		a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
	const norm = (a) => a.map((v) => v / Math.hypot(...a));
	const f = norm(sub(cam.target, cam.eye));
	const r = norm(cross(f, cam.up ?? [0, 1, 0]));
	const u = cross(r, f);
	const t = Math.tan(cam.fov * Math.PI / 360);
	const d = sub(p, cam.eye);
	const z = dot(d, f);
	return { x: dot(d, r) / (z * t * view.width / view.height),
		y: dot(d, u) / (z * t), z };
}

const run = (args) => H.runCli(cli, args, 60000);

try {
	const cfg = join(work, 'blobcastd.json');
	writeFileSync(cfg, JSON.stringify({ tokens: [
		{ token: EDITOR, role: 'editor' },
		{ token: VIEWER, role: 'viewer' }] }));
	const d = await H.startDaemon(daemon, ['--config', cfg]);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	const base = `http://127.0.0.1:${web.port}/?ws=${proxy.port}`;
	const srv = ['--server', `127.0.0.1:${d.port}`, '--token', EDITOR];
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	step(`blobcastd :${d.port} (tokens), websockify :${proxy.port}`);

	/* ---- the header's token state ---- */
	const a = await openPage(`${base}&session=default&name=alice&enc=png` +
		`#token=${EDITOR}`);
	await joined(a, 'default');
	step('alice joined');
	const tokenState = (page, state) => until(page, `token state ${state}`,
		(st) => document.getElementById('tokenstate').dataset.state === st,
		state);
	await tokenState(a, 'editor');
	assert.equal(await a.textContent('#tokenstate'), 'editor · token');
	assert.equal(await a.isVisible('#tokenwarn'), false, 'no warning');
	const b = await openPage(`${base}&session=default&name=bob` +
		`#token=${VIEWER}`);
	await joined(b, 'default');
	step('bob joined');
	await tokenState(b, 'view-only');
	assert.equal(await b.textContent('#tokenstate'),
		'view only · viewer token ⚠');
	assert.match(await b.textContent('#tokenwarn'), /viewing only/);
	assert.ok(await b.isVisible('#tokenwarn'), 'the warning shows');
	const c = await openPage(`${base}&session=default&name=carol`);
	await until(c, 'the EAUTH stop', () =>
		window.blobcast.state().halted?.code === 'EAUTH');
	await tokenState(c, 'refused');
	assert.match(await c.textContent('#tokenstate'), /^token needed/);
	assert.match(await c.textContent('#tokenwarn'), /wants a token/);
	await c.close();
	step('header: "editor · token", "view only · viewer token" with its ' +
		'warning, "token needed"');

	/* ---- the session list ---- */
	await listed(a, ['default']);
	/* Its status line: the sessions, and the daemon's scene memory
	 * (STATS's memory section). */
	await until(a, 'the scene memory in the list\'s status line', () =>
		/^\d+ sessions? on this daemon · scene memory [\d,]+ of [\d,]+ nodes \(\d+ %\)$/
			.test(document.getElementById('sessioninfo').textContent));
	await a.fill('#sessionname', '.bad');
	await a.click('#sessionform button');
	assert.match(await a.textContent('#sessioninfo'), /not starting with/);
	await a.fill('#sessionname', 'review-a');
	await a.click('#sessionform button');
	await joined(a, 'review-a');
	await listed(a, ['default', 'review-a']);
	await a.fill('#sessionname', 'review-b');
	await a.press('#sessionname', 'Enter');
	await joined(a, 'review-b');
	await listed(a, ['default', 'review-a', 'review-b']);
	await until(a, 'review-b marked as this page\'s', () => document
		.querySelector('#sessionlist li.here')?.dataset.session ===
		'review-b');
	assert.ok(await a.isDisabled(
		'#sessionlist li[data-session="review-b"] button.delete'),
	'the session the page is in cannot be deleted from it');
	step('created review-a and review-b from the form, each joined');
	await a.click('#sessionlist li[data-session="review-a"] button.join');
	await joined(a, 'review-a');
	assert.match(await a.evaluate(() => location.search), /session=review-a/);
	await a.click('#sessionlist li[data-session="review-b"] button.delete');
	await listed(a, ['default', 'review-a'], ['review-b']);
	const cliList = await run(['sessions', ...srv]);
	assert.ok(!/^review-b /m.test(cliList.stdout) &&
		/^review-a /m.test(cliList.stdout), cliList.stdout);
	step('joined review-a from the list; deleted review-b');

	/* The viewer token: the daemon refuses, the panel says so. */
	await b.click('#sessionrefresh');
	await listed(b, ['default', 'review-a']);
	await b.click('#sessionlist li[data-session="review-a"] button.delete');
	await until(b, 'the refusal of delete', () => /refused by the daemon.*EPERM/
		.test(document.getElementById('sessioninfo').textContent));
	await b.fill('#sessionname', 'nope');
	await b.click('#sessionform button');
	await until(b, 'the refusal of create', () =>
		/create “nope”: refused.*EPERM/.test(document.getElementById(
			'sessioninfo').textContent));
	await b.click('#sessionrefresh');
	await listed(b, ['default', 'review-a'], ['nope']);
	step('viewer token: delete and create refused (EPERM), shown, nothing ' +
		'changed');
	assert.ok(await b.isDisabled('#setcambtn'),
		'a viewer cannot set the session\'s camera');
	assert.ok(await b.isDisabled('#loadbtn'), 'a viewer cannot load');
	assert.ok(!(await a.isDisabled('#loadbtn')), 'an editor can load');
	await b.close();

	/* ---- camera: far, fit, reset (PNG frames: exact pixels) ---- */
	const first = await settled(a, 'the first still');
	step('the first still');
	assert.equal(first.encoding, 2, 'enc=png gives PNG frames');
	const home = await coverage(a, 'homePixels');
	const sessionCam = await a.evaluate(() =>
		window.blobcast.sessionCamera());
	const box = await a.evaluate(() => {
		const r = document.getElementById('view').getBoundingClientRect();
		return { x: r.left, y: r.top, w: r.width, h: r.height };
	});
	await a.mouse.move(box.x + box.w / 2, box.y + box.h / 2);
	for (let i = 0; i < 4; i++) {
		await a.mouse.wheel(0, 500);
	}
	await a.waitForTimeout(300);
	await settled(a, 'the far still');
	step('zoomed out');
	const far = await coverage(a);
	await a.press('#view', 'Home');
	await settled(a, 'the fitted still');
	const fit = await coverage(a);
	const st = await a.evaluate(() => window.blobcast.state());
	const sbox = await a.evaluate(() => window.blobcast.sceneBox());
	for (let i = 0; i < 8; i++) {
		const p = project(st.camera, st.view, [0, 1, 2].map((k) =>
			sbox[(i >> k) & 1][k]));
		assert.ok(p.z > 0 && Math.abs(p.x) <= 1 && Math.abs(p.y) <= 1,
			`box corner ${i} at ${p.x}, ${p.y} after fit`);
	}
	assert.ok(fit.share > 4 * far.share, `fit covers ${fit.share}, far ` +
		`${far.share}`);
	/* The session's camera is framed by hand, tightly; the fit frames a
	 * bounding sphere, so less, but not much less. */
	assert.ok(fit.share > 0.4 * home.share, `fit covers ${fit.share}, ` +
		`the session's camera ${home.share}`);
	step(`the session's camera: scene on ${(100 * home.share).toFixed(1)}` +
		` % of the view; zoomed out: ${(100 * far.share).toFixed(1)} %; ` +
		`Home (fit): ${(100 * fit.share).toFixed(1)} %, its box inside`);
	await a.press('#view', 'r');
	await settled(a, 'the reset still');
	const back = await coverage(a, null, 'homePixels');
	const cam = (await a.evaluate(() => window.blobcast.state())).camera;
	sessionCam.eye.forEach((v, k) => assert.ok(Math.abs(v - cam.eye[k]) <
		1e-5, `eye ${cam.eye} vs the session's ${sessionCam.eye}`));
	const diff = back.diff;
	assert.ok(diff < 1, `reset: mean pixel difference ${diff} from the ` +
		'first picture');
	step(`R (reset): the session's camera and its picture again (mean ` +
		`difference ${diff.toFixed(3)}; ${(100 * back.share).toFixed(1)} %)`);

	/* ---- set (Shift-R): this view becomes the session's camera ---- */
	await a.mouse.move(box.x + box.w / 2, box.y + box.h / 2);
	await a.mouse.wheel(0, 300);
	await a.waitForTimeout(300);
	await settled(a, 'the zoomed still');
	const mine = (await a.evaluate(() => window.blobcast.state())).camera;
	const near = (u, v) => u.every((x, k) => Math.abs(x - v[k]) < 1e-4);
	assert.ok(!near(mine.eye, sessionCam.eye), 'the view moved');
	await a.press('#view', 'Shift+R');
	await until(a, 'the session camera is the view', (eye) => window
		.blobcast.sessionCamera().eye.every((x, k) =>
			Math.abs(x - eye[k]) < 1e-4), mine.eye);
	const sceneNow = await run(['scene', ...srv, '--session', 'review-a']);
	assert.equal(sceneNow.code, 0, `blobcast scene: ${sceneNow.stderr}`);
	const daemonCam = JSON.parse(sceneNow.stdout).camera;
	assert.ok(near(daemonCam.eye, mine.eye) &&
		near(daemonCam.target, mine.target), `the daemon's camera ` +
		`${JSON.stringify(daemonCam)}, the view's ${JSON.stringify(mine)}`);
	await a.mouse.wheel(0, 300);
	await a.waitForTimeout(300);
	await a.press('#view', 'r');
	await until(a, 'R back to the camera set', (eye) => window.blobcast
		.state().camera.eye.every((x, k) => Math.abs(x - eye[k]) < 1e-4),
	mine.eye);
	step('Shift-R (set): the view became the session\'s camera at the ' +
		'daemon (blobcast scene), and R comes back to it');

	/* ---- frames: encoding control, PNG download ---- */
	const encoded = async (enc, name) => {
		await a.selectOption('#encoding', String(enc));
		return until(a, `${name} frames`, (e) => {
			const f = window.blobcast.state().lastFrame;
			return f && f.encoding === e && f.still && !window.blobcast
				.state().pending ? f : null;
		}, enc);
	};
	await encoded(3, 'raw');
	await encoded(1, 'jpeg');
	await a.fill('#quality', '30');
	await a.press('#quality', 'Enter');
	await until(a, 'quality 30 in the address', () =>
		/quality=30/.test(location.search) && /enc=jpeg/.test(location
			.search));
	assert.equal(await a.isDisabled('#quality'), false);
	await encoded(2, 'png');
	assert.ok(await a.isDisabled('#quality'), 'quality is for JPEG only');
	step('encoding control: raw, jpeg (quality 30), png frames');
	const view = (await a.evaluate(() => window.blobcast.state())).view;
	const png = await H.download(a, '#pngbtn');
	assert.equal(png.bytes.subarray(1, 4).toString('latin1'), 'PNG');
	assert.deepEqual([png.bytes.readUInt32BE(16), png.bytes.readUInt32BE(20)],
		[view.width, view.height]);
	assert.match(png.name, /^blobcast-review-a-\d+\.png$/);
	step(`PNG button: ${png.name}, ${view.width}x${view.height}`);

	/* A server that refuses raw frames. */
	const e = await browser.newPage({ viewport: { width: W + 280,
		height: H2 + 90 } });
	e.on('pageerror', (err) => {
		console.error(`page: ${err.message}`);
		failed = true;
	});
	const views = [];
	await e.routeWebSocket(/.*/, (ws) => refusingServer(ws, views));
	await e.goto(`http://127.0.0.1:${web.port}/?ws=ws://127.0.0.1:9/` +
		'&session=s&name=dave&enc=png');
	await until(e, 'the stand-in\'s session', () =>
		window.blobcast.state().connected);
	await e.selectOption('#encoding', String(P.ENC.RAW));
	await until(e, 'raw marked refused', () => {
		const o = document.querySelector('#encoding option[value="3"]');
		return o.disabled && o.textContent === 'raw (refused)' &&
			document.getElementById('encoding').value === '2';
	});
	assert.match(await e.textContent('#message'), /raw frames refused by /);
	await e.selectOption('#encoding', String(P.ENC.JPEG));
	for (const end = Date.now() + 10000; views.at(-1) !== P.ENC.JPEG;) {
		assert.ok(Date.now() < end, `a JPEG VIEW; VIEWs taken: ${views}`);
		await e.waitForTimeout(30);
	}
	assert.deepEqual(views.filter((v) => v === P.ENC.RAW), []);
	await e.close();
	step('a server refusing raw: "raw (refused)", the control back on png');

	/* ---- the scene as JSON, and back ---- */
	const gen = JSON.parse((await run(['gen', 'catalogue', '--blend',
		'smooth'])).stdout);
	const kids = gen.root.children;
	let next = 1000;
	const wrap = (k, type, params) => {
		kids[k] = { type, id: next++, ...params, children: [kids[k]] };
	};
	wrap(0, 'twist', { rate: 0.7 });
	wrap(1, 'mirror', { axes: 'xz' });
	wrap(2, 'repeat', { spacing: [0.5, 1, 1], count: [2, 1, 1] });
	wrap(3, 'onion', { thickness: 0.05 });
	wrap(4, 'scale', { factor: 0.8 });
	wrap(4, 'elongate', { half_extents: [0.2, 0, 0.1] });
	const scene = join(work, 'rich.json');
	writeFileSync(scene, JSON.stringify(gen));
	let r = await run(['load', ...srv, '--session', 'rich', scene]);
	assert.equal(r.code, 0, `blobcast load: ${r.stderr}`);
	await a.click('#sessionrefresh');
	await listed(a, ['rich']);
	await a.click('#sessionlist li[data-session="rich"] button.join');
	await joined(a, 'rich');
	const moved = kids.find((k) => !k.children).id;
	await a.evaluate((id) => window.blobcast.moveTo(id, [0.1234567, 2.5,
		-3.75]), moved);
	r = await run(['camera', ...srv, '--session', 'rich', '--eye',
		'3.3,14.1,17.7', '--target', '0.5,0,-0.25', '--fov', '41.5']);
	assert.equal(r.code, 0, `blobcast camera: ${r.stderr}`);
	await until(a, 'the session camera in the mirror', () =>
		window.blobcast.sessionCamera().fov_y_deg === 41.5);
	/* An edit from the CLI with --name: the page names its author
	 * after the CLI has left the session. */
	r = await run(['edit', ...srv, '--session', 'rich', '--name', 'dave',
		String(moved), 'translate=0.25,2.5,-3.75']);
	assert.equal(r.code, 0, `blobcast edit: ${r.stderr}`);
	await until(a, 'dave gone from the roster', () => !window.blobcast
		.state().members.some((m) => m.name === 'dave') &&
		/^last edit: dave /.test(document.getElementById('lastedit')
			.textContent));
	step('the CLI\'s --name names its edit in the page after it left');
	const json = await H.download(a, '#jsonbtn');
	assert.match(json.name, /^blobcast-rich-\d+\.json$/);
	const text = json.bytes.toString('utf8');
	const fromCli = (await run(['scene', ...srv, '--session', 'rich']))
		.stdout;
	assert.equal(text, fromCli, 'the download is what `blobcast scene` ' +
		'writes');
	/* The binary button: what `blobcast scene --binary` writes, byte
	 * for byte, and `blobcast load` takes it back. */
	const bin = await H.download(a, '#binbtn');
	assert.match(bin.name, /^blobcast-rich-\d+\.bin$/);
	const binCli = join(work, 'cli.bin');
	r = await run(['scene', ...srv, '--session', 'rich', '--out', binCli,
		'--binary']);
	assert.equal(r.code, 0, `blobcast scene --binary: ${r.stderr}`);
	assert.ok(Buffer.compare(bin.bytes, readFileSync(binCli)) === 0,
		'the binary download is what `blobcast scene --binary` writes');
	const binFile = join(work, 'download.bin');
	writeFileSync(binFile, bin.bytes);
	r = await run(['load', ...srv, '--session', 'copybin', binFile]);
	assert.equal(r.code, 0, `blobcast load of the binary download: ${
		r.stderr}`);
	assert.equal((await run(['scene', ...srv, '--session', 'copybin']))
		.stdout, text, 'the scene loaded from the binary download');
	step(`binary button: ${bin.name} (${bin.bytes.length} bytes) equals ` +
		'`blobcast scene --binary` and loads back as the same scene');
	const file = join(work, 'download.json');
	writeFileSync(file, json.bytes);
	r = await run(['load', ...srv, '--session', 'copy', file]);
	assert.equal(r.code, 0, `blobcast load of the download: ${r.stderr}`);
	assert.equal((await run(['scene', ...srv, '--session', 'copy'])).stdout,
		text, 'the scene loaded from the download');
	step(`JSON button: ${json.name} (${text.length} bytes) equals ` +
		'`blobcast scene`; `blobcast load` gives the same scene back');

	/* blobcastd's own loader, from a data directory. */
	const data = join(work, 'data2');
	mkdirSync(join(data, 'sessions', 'copy2'), { recursive: true });
	copyFileSync(file, join(data, 'sessions', 'copy2', 'snap-1.json'));
	r = await H.runCli(daemon, ['--check', data]);
	assert.equal(r.code, 0, `blobcastd --check: ${r.stdout}${r.stderr}`);
	assert.match(r.stdout + r.stderr, /copy2: whole/);
	const d2 = await H.startDaemon(daemon, [], { data });
	const loaded = await run(['scene', '--server', `127.0.0.1:${d2.port}`,
		'--session', 'copy2']);
	await H.stopChild(d2.child);
	assert.equal(loaded.stdout, text, 'blobcastd serves the same scene');
	step('blobcastd --check and a start take the download as a session\'s ' +
		'snapshot: the same scene');

	/* ---- load: scene files from the page, against `blobcast load` ---- */
	const handmade = join(work, 'handmade.json');
	writeFileSync(handmade, JSON.stringify({ blobcast: 1,
		root: { type: 'smooth_union', blend: 0.2, name: 'top', children: [
			{ type: 'box', half_extents: [1, 0.5, 0.25],
				rotate: [0, 0.3826, 0, 0.9239] },
			{ type: 'sphere', id: 2, radius: 0.5, translate: [0.1, 0.2, 0.3],
				color: [0.25, 0.5, 1] },
			{ type: 'twist', rate: 0.5, children: [
				{ type: 'mirror', id: 1, axes: 'zx', children: [
					{ type: 'cylinder', radius: 0.2, half_height: 1,
						name: 'pin' }] }] }] } }));
	const shape = join(work, 'shape.json');
	writeFileSync(shape, JSON.stringify({ blobcast: 1,
		root: { type: 'sphere', radius: -1 } }));
	const loadFrom = async (path, want) => {
		/* openPage's pages accept every dialog: the confirm. */
		await a.setInputFiles('#loadfile', path);
		return until(a, `the page's answer to ${path}`, (re) =>
			new RegExp(re).test(document.getElementById('message')
				.textContent), want.source, 60000);
	};
	/* The last read the page did: { name, reader, nodes, ms }. */
	const lastRead = () => a.evaluate(() => window.blobcast.loading().last);
	/* The session rich (loaded from the page) is what `blobcast load` of
	 * file makes, byte for byte (`blobcast scene`, through files: a big
	 * scene is more than execFile keeps of a child's output). */
	const sameAsCli = async (file) => {
		const name = file.split('/').pop();
		r = await run(['load', ...srv, '--session', 'viacli', file]);
		assert.equal(r.code, 0, `blobcast load ${name}: ${r.stderr}`);
		const out = {};
		for (const s of ['rich', 'viacli']) {
			out[s] = join(work, `scene-${s}.json`);
			r = await run(['scene', ...srv, '--session', s, '--out',
				out[s]]);
			assert.equal(r.code, 0, `blobcast scene ${s}: ${r.stderr}`);
		}
		assert.ok(Buffer.compare(readFileSync(out.rich),
			readFileSync(out.viacli)) === 0, `${name} loaded from the ` +
			'page is not the scene `blobcast load` makes of it');
	};
	const loadedRe = (name) => new RegExp(`^loaded ${name.replace('.',
		'\\.')}: \\d+ nodes, edit order \\d+`);
	for (const f of [handmade, scene, binFile]) {
		const name = f.split('/').pop();
		await loadFrom(f, loadedRe(name));
		assert.deepEqual(await lastRead().then((l) => [l.name, l.reader]),
			[name, 'worker'], `${name} read in the worker`);
		await sameAsCli(f);
	}
	step('load: a hand-made file (defaults, ids and camera left out, ' +
		'names, unary nodes), every kind, and a binary file, each read ' +
		'in the worker and the session `blobcast load` of the same file ' +
		'makes, byte for byte');
	/* A worker whose script does not load (as from a page opened from a
	 * file: URL): the page reads the file itself, to the same session. */
	await a.evaluate(() => {
		const W = window.Worker;
		window.realWorker = W;
		window.Worker = class extends W {
			constructor(url, opts) {
				super(new URL('./no-such-worker.js', url), opts);
			}
		};
	});
	await loadFrom(handmade, loadedRe('handmade.json'));
	assert.deepEqual(await lastRead().then((l) => [l.name, l.reader]),
		['handmade.json', 'page'], 'read on the page without a worker');
	await sameAsCli(handmade);
	await a.evaluate(() => {
		window.Worker = window.realWorker;
	});
	step('load: a worker that fails to start: the page reads the file ' +
		'itself, to the same session');
	const before = (await run(['scene', ...srv, '--session', 'rich'])).stdout;
	await loadFrom(shape, /^shape\.json not loaded: .*radius -1.*\(ERANGE\)$/);
	const bad = join(work, 'bad.json');
	writeFileSync(bad, '{"blobcast": 1, "root": {"type": "sphere", ' +
		'"radius": 1, "radius": 2}}');
	await a.setInputFiles('#loadfile', bad);
	await until(a, 'the page refusing a duplicate key', () =>
		/^bad\.json not loaded: line 1 column \d+: duplicate object key/
			.test(document.getElementById('message').textContent));
	assert.deepEqual(await lastRead().then((l) => [l.name, l.reader,
		l.nodes]), ['bad.json', 'worker', 0], 'refused by the worker\'s read');
	assert.equal((await run(['scene', ...srv, '--session', 'rich'])).stdout,
		before, 'a refused load changed the scene');
	step('load: a bad shape refused by the daemon (ERANGE, its words), a ' +
		'duplicate key refused by the page (its worker) before sending; ' +
		'the scene stays');

	/* ---- load: a big JSON file, read off the page's thread ---- */
	const big = join(work, 'big.json');
	r = await run(['gen', 'fig18', '--count', String(BIG_COUNT), '--kind',
		'spheres', '--blend', 'smooth', '--out', big]);
	assert.equal(r.code, 0, `blobcast gen: ${r.stderr}`);
	const mb = (statSync(big).size / 1e6).toFixed(1);
	/* Animation frames the page runs while its worker reads the file
	 * (until the read is done): a page whose own thread were reading
	 * would run none. */
	await a.evaluate(() => {
		const t = { frames: 0, done: false };
		window.readTicks = t;
		const tick = () => {
			const l = window.blobcast.loading();
			if (l.state === 'reading' && l.reader === 'worker') {
				t.frames++;
			} else if (l.last?.name === 'big.json') {
				t.done = true;
				return;
			}
			requestAnimationFrame(tick);
		};
		requestAnimationFrame(tick);
	});
	await a.setInputFiles('#loadfile', big);
	/* The page answers while the worker reads, and refuses a second file
	 * meanwhile (tried in the same turn of its loop that saw the read). */
	const during = await until(a, 'the page answering during the read',
		() => {
			const l = window.blobcast.loading();
			if (l.state !== 'reading' || l.reader !== 'worker') {
				return null;
			}
			const said = document.getElementById('message').textContent;
			const dt = new DataTransfer();
			dt.items.add(new File(['{}'], 'second.json'));
			const input = document.getElementById('loadfile');
			input.files = dt.files;
			input.dispatchEvent(new Event('change'));
			return { l, said, state: window.blobcast.state().loading,
				second: document.getElementById('message').textContent };
		});
	assert.deepEqual([during.l.name, during.l.reader, during.state],
		['big.json', 'worker', 'reading']);
	assert.equal(during.said, `reading big.json (${mb} MB)...`);
	assert.equal(during.second, 'big.json is still being read; load ' +
		'another once it is');
	await until(a, 'the page\'s answer to big.json', (re) =>
		new RegExp(re).test(document.getElementById('message')
			.textContent), loadedRe('big.json').source, 60000);
	const ticks = await until(a, 'the end of the read', () =>
		window.readTicks.done && window.readTicks);
	const bigRead = await lastRead();
	assert.deepEqual([bigRead.name, bigRead.reader, bigRead.nodes],
		['big.json', 'worker', BIG_COUNT + 1]);
	assert.ok(ticks.frames >= 3, `${ticks.frames} animation frames ` +
		'during the read');
	await sameAsCli(big);
	step(`load: big.json (${BIG_COUNT} spheres, ${mb} MB) read in the ` +
		`worker in ${bigRead.ms} ms, ${ticks.frames} animation frames ` +
		'meanwhile, the page answering and refusing a second file; the ' +
		'session `blobcast load` makes, byte for byte');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}\n${H.logs()}`);
} finally {
	rmSync(work, { recursive: true, force: true });
	await H.finish(browser, failed, watchdog);
}
