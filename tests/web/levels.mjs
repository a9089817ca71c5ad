/*
 * The browser page with refinement levels, without a daemon: the page runs
 * in headless Debian chromium (playwright-core) and its WebSocket is
 * answered by this script, which speaks the server's side through the
 * page's own codec (WELCOME, SESSION_INFO, then FRAMEs it builds):
 *  - a level-2 frame (a quarter-size image, left half red, right half
 *    blue) is drawn over the whole view, each image pixel a 4 x 4 block
 *    from the top-left, and the "refining · level 2" mark shows;
 *  - before any frame, the VIEW the page sent shows "render pending";
 *    the first frame hides it;
 *  - a level-0 INCOMPLETE frame keeps the mark, now at level 0 and
 *    "cut by time budget";
 *  - a level-0 still (green) hides it.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/levels.mjs
 */
import assert from 'node:assert/strict';

import * as P from '../../client/web/protocol.js';
import * as H from './harness.mjs';

const DEADLINE_MS = 60000;

/* No daemon and no proxy: name this script as the "daemon" so that only
 * the browser parts are checked. */
const lacking = H.missing({ daemon: process.argv[1], browser: true,
	proxy: false });
H.skipIfMissing('web levels test', lacking);
const chromium = await H.playwright();

const watchdog = H.watchdog(DEADLINE_MS, false);

const RED = [255, 0, 0, 255], BLUE = [0, 0, 255, 255];
const GREEN = [0, 255, 0, 255];

/* A raw FRAME of the view at level, every pixel from colour(i, j). */
function frame(view, level, flags, frameNo, colour) {
	const iw = P.levelDim(view.width, level);
	const ih = P.levelDim(view.height, level);
	const data = new Uint8Array(iw * ih * 4);
	for (let j = 0; j < ih; j++) {
		for (let i = 0; i < iw; i++) {
			data.set(colour(i, j, iw), (j * iw + i) * 4);
		}
	}
	return P.encode({ type: P.MSG.FRAME,
		flags: P.flagsWithLevel(flags, level), seq: 0, frame_no: frameNo,
		order: 1n, camera_seq: 0, encoding: P.ENC.RAW, width: view.width,
		height: view.height, image_width: iw, image_height: ih,
		rects: [{ x: 0, y: 0, w: iw, h: ih, data }] });
}

/* The server's side of one connection: answers HELLO and SESSION_JOIN,
 * keeps the latest VIEW. */
function fakeServer(ws, state) {
	const r = new P.Reader({ side: 'server' });
	ws.onMessage((msg) => {
		r.feed(typeof msg === 'string' ? Buffer.from(msg) : msg);
		for (let m; (m = r.next());) {
			if (m.type === P.MSG.HELLO) {
				ws.send(Buffer.from(P.encode({ type: P.MSG.WELCOME,
					seq: m.seq, version: 1, connection_id: 1,
					max_payload: P.LIMITS.MAX_PAYLOAD,
					max_frame_bytes: P.LIMITS.MAX_PAYLOAD,
					max_nodes: 1000, max_dim: 4096, max_members: 8,
					max_edit_ops: 64, server_id: 'fake' })));
			} else if (m.type === P.MSG.SESSION_JOIN) {
				ws.send(Buffer.from(P.encode({ type: P.MSG.SESSION_INFO,
					seq: 0, session_id: 1, member_id: 1, role: m.role,
					name: m.name, members: [{ id: 1, role: m.role,
						name: 'levels' }] })));
			} else if (m.type === P.MSG.VIEW) {
				state.view = m;
			}
		}
	});
	state.send = (bytes) => ws.send(Buffer.from(bytes));
}

/* The page's view canvas pixel at (x, y), and the mark. */
function probe({ x, y }) {
	const c = document.getElementById('view');
	const d = c.getContext('2d').getImageData(x, y, 1, 1).data;
	const mark = document.getElementById('refining');
	return { px: Array.from(d), hidden: mark.hidden,
		text: mark.textContent, visible: mark.offsetParent !== null,
		last: window.blobcast.state().lastFrame };
}

const until = (page, what, fn, arg, ms = 15000) =>
	H.until(page, what, fn, arg, ms, 30);

const near = (a, b) => a.every((v, i) => Math.abs(v - b[i]) <= 8);

let browser = null;
let failed = false;
try {
	const web = await H.startStatic();
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const page = await browser.newPage({ viewport: { width: 960,
		height: 600 } });
	page.on('pageerror', (e) => {
		console.error(`page: ${e.message}`);
		failed = true;
	});
	const state = {};
	await page.routeWebSocket(/.*/, (ws) => fakeServer(ws, state));
	await page.goto(`http://127.0.0.1:${web.port}/?ws=ws://127.0.0.1:9/` +
		'&session=levels&name=levels');
	const end = Date.now() + 15000;
	while (!state.view && Date.now() < end) {
		await new Promise((res) => setTimeout(res, 30));
	}
	assert.ok(state.view, 'the page sent VIEW');
	const view = state.view;
	const mark0 = await page.evaluate(probe, { x: 0, y: 0 });
	assert.equal(mark0.hidden, true, 'no mark before a frame');
	/* The VIEW is not answered yet: the page says a render is pending. */
	const pend = await until(page, 'the pending mark', () => {
		const el = document.getElementById('pending');
		return !el.hidden && el.offsetParent !== null && el.textContent;
	});
	assert.match(pend, /^render pending · [0-9.]+ s$/);

	/* Level 2: left half of the image red, right half blue. The colour
	 * edge in the view is at 4 * (iw / 2), whatever the view's width. */
	state.send(frame(view, 2, 0, 1, (i, j, iw) =>
		(i < (iw >> 1) ? RED : BLUE)));
	let s = await until(page, 'the level-2 frame', () => {
		const l = window.blobcast.state().lastFrame;
		return l && l.frame_no === 1;
	});
	const edge = 4 * (P.levelDim(view.width, 2) >> 1);
	const y = view.height >> 1;
	const left = await page.evaluate(probe, { x: edge - 6, y });
	const right = await page.evaluate(probe, { x: edge + 6, y });
	const far = await page.evaluate(probe, { x: view.width - 2,
		y: view.height - 2 });
	assert.ok(near(left.px, RED), `red left of ${edge}: ${left.px}`);
	assert.ok(near(right.px, BLUE), `blue right of ${edge}: ${right.px}`);
	assert.ok(near(far.px, BLUE), `the picture reaches the bottom-right ` +
		`corner: ${far.px}`);
	assert.equal(left.hidden, false, 'the mark shows at level 2');
	assert.equal(left.visible, true, 'the mark is laid out');
	assert.equal(left.text, 'refining · level 2');
	assert.equal(left.last.level, 2);
	assert.equal(left.last.image_width, P.levelDim(view.width, 2));
	assert.equal(await page.evaluate(() =>
		document.getElementById('pending').hidden), true,
	'the first frame answers the VIEW: nothing pending');
	console.log(`level 2: ${view.width}x${view.height} as ` +
		`${left.last.image_width}x${left.last.image_height}, edge at ` +
		`${edge}, mark "${left.text}"`);

	/* Level 0 cut by the time budget: still refining. */
	state.send(frame(view, 0, P.FLAG.INCOMPLETE, 2, () => RED));
	s = await until(page, 'the incomplete frame', () =>
		window.blobcast.state().lastFrame.frame_no === 2);
	s = await page.evaluate(probe, { x: 4, y: 4 });
	assert.equal(s.hidden, false, 'INCOMPLETE keeps the mark');
	assert.equal(s.text, 'refining · level 0 · cut by time budget');

	/* The still: the mark goes. */
	state.send(frame(view, 0, P.FLAG.STILL, 3, () => GREEN));
	await until(page, 'the still', () =>
		window.blobcast.state().lastFrame.frame_no === 3);
	s = await page.evaluate(probe, { x: view.width >> 1, y });
	assert.ok(near(s.px, GREEN), `the still is drawn: ${s.px}`);
	assert.equal(s.hidden, true, 'a finished level-0 frame hides the mark');
	assert.equal(s.visible, false, 'the hidden mark takes no space');
	assert.equal(s.last.level, 0);
	console.log('level 0 incomplete kept the mark; the still hid it');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
} finally {
	await H.finish(browser, failed, watchdog);
}
