/*
 * H.264 frames in the browser page (PROTOCOL.md 7.15 encoding 4, 7.27
 * FRAME_ACK): blobcastd on its default scene, websockify and headless
 * Debian chromium (playwright-core).
 *  - in node: the codec string from an SPS (avc1.PPCCLL), and the frame
 *    acknowledgements, which never run ahead of a frame not yet handled;
 *  - against a stand-in server (the page's WebSocket answered here) that
 *    grants ACKS and sends access units made by chromium's own H.264
 *    encoder: a delta before any KEY is not decoded, the page sends its
 *    VIEW again (for a KEY) and acknowledges the frame; then KEY and
 *    deltas are drawn (the picture's colour checked) and every frame is
 *    acknowledged, in order; a decoder that never gives a picture is
 *    reset after 2 s, its frame acknowledged and a KEY asked for;
 *  - enc=h264: the page announces encoding 4 (WebCodecs decodes H.264
 *    here), its VideoDecoder draws the frames, key and delta, and the
 *    still on the canvas is within 30 dB PSNR of a raw SNAPSHOT of the
 *    same camera (and far from a black picture); with ACKS granted every
 *    frame is acknowledged and none had to be let go;
 *  - enc=h264png: H.264 while moving, the still a PNG equal to the raw
 *    snapshot;
 *  - a decoder that fails: the page says so and asks for JPEG;
 *  - without window.VideoDecoder: HELLO lists no encoding 4, the H.264
 *    choices are disabled and enc=h264 gets JPEG frames of the scene.
 * A daemon built without an H.264 encoder refuses encoding 4 (ENOTSUP):
 * then the page's fallback to JPEG is what is checked, and the output
 * says so.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/video.mjs --blobcastd PATH
 */
import assert from 'node:assert/strict';

import * as H from './harness.mjs';
import * as P from '../../client/web/protocol.js';
import { FrameAcks, avcCodec } from '../../client/web/video.js';

const DEADLINE_MS = 60000;

/* ---- in node: nothing of the browser needed ---- */

/* An access unit: AUD, SPS (High, constraint 0, level 4.2), PPS, IDR. */
const au = Uint8Array.from([0, 0, 0, 1, 0x09, 0xf0, 0, 0, 0, 1, 0x67, 0x64,
	0x00, 0x2a, 0xac, 0xd9, 0, 0, 1, 0x68, 0xeb, 0xe3, 0, 0, 1, 0x65,
	0x88, 0x84]);
assert.equal(avcCodec(au), 'avc1.64002a');
assert.equal(avcCodec(Uint8Array.from([0, 0, 1, 0x67, 0x42, 0xe0, 0x1f])),
	'avc1.42e01f');
assert.equal(avcCodec(au.subarray(0, 10)), null, 'no SPS, no codec');
assert.equal(avcCodec(au.subarray(0, 13)), null, 'an SPS cut short');
{
	const sent = [];
	const a = new FrameAcks((n) => sent.push(n));
	[1, 2, 3, 4].forEach((n) => a.got(n, 0));
	a.done(2);
	assert.deepEqual(sent, [], 'frame 1 is not handled yet');
	a.done(1);
	assert.deepEqual(sent, [2], 'frames 1 and 2 at once');
	a.done(4);
	a.done(4);
	a.done(9);
	assert.deepEqual(sent, [2], 'frame 3 holds 4 back; unknown ones count ' +
		'for nothing');
	a.let(1000, 5000);
	assert.deepEqual(sent, [2], 'not yet let go');
	a.let(6000, 5000);
	assert.deepEqual(sent, [2, 4], 'a frame nothing handled is let go');
	assert.deepEqual(a.state(), { last: 4, sent: 2, forced: 1, waiting: 0 });
}
console.log('node: avcCodec and FrameAcks');

/* ---- in the browser ---- */

const { daemon, chromium, step, watchdog, until } = await H.begin(
	'web video', { ms: DEADLINE_MS });

let browser = null;
let failed = false;

/* A page of the stack with query (after ws=), initScript run before the
 * page's own. */
async function open(stack, query, initScript) {
	const page = await browser.newPage({ viewport: { width: 720,
		height: 420 } });
	page.on('pageerror', (e) => {
		console.error(`page (${query}): ${e.message}`);
		failed = true;
	});
	if (initScript) {
		await page.addInitScript(initScript);
	}
	await page.goto(`http://127.0.0.1:${stack.web.port}/?ws=` +
		`${stack.proxy.port}&session=default&${query}`);
	await until(page, 'the session', () => window.blobcast.state()
		.connected && window.blobcast.primitives().length > 0);
	return page;
}

/* Waits for the still in encoding after the page's last camera, at the
 * canvas's size, drawn and answering everything the page asked. */
function settled(page, encoding) {
	return until(page, `a still in encoding ${encoding}`, (e) => {
		const s = window.blobcast.state();
		const f = s.lastFrame;
		const c = document.getElementById('view');
		return f && f.still && f.encoding === e && !s.pending &&
			f.camera_seq === window.blobcast.cameraSeq() &&
			f.width === c.width && f.height === c.height && s;
	}, encoding);
}

/* The view canvas against a raw SNAPSHOT of the same camera and size:
 * PSNR (dB) over R, G, B, the largest difference, and the PSNR a black
 * picture would have. */
function compare(page) {
	return page.evaluate(async () => {
		const snap = await window.blobcast.snapshot(3);
		const c = document.getElementById('view');
		if (!snap || snap.width !== c.width || snap.height !== c.height) {
			return { error: `snapshot ${snap?.width}x${snap?.height}, ` +
				`canvas ${c.width}x${c.height}` };
		}
		const got = c.getContext('2d').getImageData(0, 0, c.width,
			c.height).data;
		const want = snap.data;
		let se = 0, black = 0, max = 0;
		for (let i = 0; i < want.length; i += 4) {
			for (let k = 0; k < 3; k++) {
				const d = got[i + k] - want[i + k];
				se += d * d;
				black += want[i + k] * want[i + k];
				max = Math.max(max, Math.abs(d));
			}
		}
		const n = 3 * c.width * c.height;
		const psnr = (e) => (e ? 10 * Math.log10(255 * 255 * n / e)
			: Infinity);
		return { width: c.width, height: c.height, psnr: psnr(se),
			black: psnr(black), max };
	});
}

const fmt = (r) => `${r.width}x${r.height}: PSNR ${r.psnr.toFixed(1)} dB ` +
	`(black: ${r.black.toFixed(1)} dB), largest difference ${r.max}`;

/* ---- the stand-in server ---- */

/* Access units of a w x h picture (w, h even) from chromium's H.264
 * encoder, Annex B: KEY, then deltas; frames 0, 1 in colour c0, 2, 3 in
 * c1, each with a grey square that moves. Null where the encoder is
 * missing. */
function encodeUnits(page, w, h, c0, c1) {
	return page.evaluate(async ({ w, h, c0, c1 }) => {
		const conf = { codec: 'avc1.42e01f', width: w, height: h,
			avc: { format: 'annexb' }, latencyMode: 'realtime',
			bitrate: 4e6 };
		if (typeof VideoEncoder !== 'function' ||
			!(await VideoEncoder.isConfigSupported(conf)).supported) {
			return null;
		}
		const out = [];
		let err = null;
		const e = new VideoEncoder({
			output: (c) => {
				const b = new Uint8Array(c.byteLength);
				c.copyTo(b);
				out.push({ key: c.type === 'key', data: Array.from(b) });
			},
			error: (x) => {
				err = String(x);
			} });
		e.configure(conf);
		const cv = new OffscreenCanvas(w, h);
		const ctx = cv.getContext('2d');
		for (let i = 0; i < 4; i++) {
			ctx.fillStyle = `rgb(${(i < 2 ? c0 : c1).join(',')})`;
			ctx.fillRect(0, 0, w, h);
			ctx.fillStyle = 'rgb(128,128,128)';
			ctx.fillRect(8 + 4 * i, 8, 32, 32);
			const f = new VideoFrame(cv, { timestamp: i * 33333 });
			e.encode(f, { keyFrame: i === 0 });
			f.close();
		}
		await e.flush();
		return err ? { err } : out;
	}, { w, h, c0, c1 });
}

/* The server's side of the page's connection: WELCOME granting ACKS,
 * SESSION_INFO; keeps HELLO, the VIEWs and the FRAME_ACKs in st. */
function standIn(ws, st) {
	H.standInDaemon(ws, { member: 'video',
		features: (hello) => hello.features & P.FEATURE.ACKS,
		each: (m) => {
			if (m.type === P.MSG.HELLO) {
				st.hello = m;
			} else if (m.type === P.MSG.VIEW) {
				st.views.push(m);
			} else if (m.type === P.MSG.FRAME_ACK) {
				st.acks.push(m.frame_no);
			}
		} });
	st.send = (bytes) => ws.send(Buffer.from(bytes));
}

/* Resolves once f() is true; throws after ms naming what. */
async function wait(what, f, ms = 10000) {
	const end = Date.now() + ms;
	while (!f()) {
		if (Date.now() > end) {
			throw new Error(`timed out waiting for ${what}`);
		}
		await new Promise((res) => setTimeout(res, 30));
	}
}

async function standInChecks(web) {
	const maker = await browser.newPage();
	/* Any page of 127.0.0.1 is a secure context, as WebCodecs wants. */
	await maker.route('**/encoder', (r) => r.fulfill({
		contentType: 'text/html', body: '<!DOCTYPE html><title>e</title>' }));
	await maker.goto(`http://127.0.0.1:${web.port}/encoder`);
	const page = await browser.newPage({ viewport: { width: 720,
		height: 420 } });
	page.on('pageerror', (e) => {
		console.error(`page (stand-in): ${e.message}`);
		failed = true;
	});
	const st = { views: [], acks: [] };
	await page.routeWebSocket(/.*/, (ws) => standIn(ws, st));
	await page.goto(`http://127.0.0.1:${web.port}/?ws=ws://127.0.0.1:9/` +
		'&session=video&name=video&enc=h264');
	await wait('the VIEW', () => st.views.length === 1);
	const v = st.views[0];
	assert.equal(v.encoding, P.ENC.H264, 'VIEW asks for H.264');
	assert.equal(st.hello.encodings & 8, 8, 'HELLO lists encoding 4');
	assert.equal(st.hello.features & P.FEATURE.ACKS, P.FEATURE.ACKS,
		'HELLO announces ACKS');
	/* The view's size, odd sides coded at the next even size. */
	const BLUE = [30, 40, 200], RED = [200, 40, 30];
	const units = await encodeUnits(maker, v.width + (v.width & 1),
		v.height + (v.height & 1), RED, BLUE);
	await maker.close();
	if (!units || units.err) {
		console.log(`NOTE: chromium has no H.264 encoder (${units?.err ??
			'VideoEncoder says no'}): no stand-in stream checked`);
		await page.close();
		return;
	}
	assert.deepEqual(units.map((u) => u.key), [true, false, false, false]);
	let no = 0;
	const frame = (u, flags = 0) => P.encode({ type: P.MSG.FRAME,
		flags: flags | (u.key ? P.FLAG.KEY : 0), seq: 0, frame_no: ++no,
		order: 1n, camera_seq: 0, encoding: P.ENC.H264, width: v.width,
		height: v.height, image_width: v.width, image_height: v.height,
		rects: [{ x: 0, y: 0, w: v.width, h: v.height,
			data: Uint8Array.from(u.data) }] });
	/* A delta with no KEY before it: not decoded; the same VIEW again. */
	st.send(frame(units[1]));
	await wait('the VIEW sent again', () => st.views.length === 2);
	assert.deepEqual({ ...st.views[1], seq: 0 }, { ...v, seq: 0 });
	await wait('the first FRAME_ACK', () => st.acks.length === 1);
	assert.deepEqual(st.acks, [1], 'the dropped delta is acknowledged');
	let s = await page.evaluate(() => window.blobcast.state());
	assert.equal(s.video.chunks, 0, 'nothing fed to the decoder');
	/* KEY and deltas: each drawn, each acknowledged. */
	units.forEach((u, i) => st.send(frame(u, i === 3 ? P.FLAG.STILL : 0)));
	await wait('every FRAME_ACK', () => st.acks.at(-1) === no);
	assert.ok(st.acks.every((n, i) => i === 0 || n > st.acks[i - 1]),
		`acknowledgements in order: ${st.acks}`);
	s = await page.evaluate(() => window.blobcast.state());
	assert.equal(s.video.drawn, 4, JSON.stringify(s.video));
	assert.equal(s.video.keys, 1);
	assert.match(s.video.codec, /^avc1\.42/);
	assert.equal(s.lastFrame.frame_no, no);
	const px = await page.evaluate(() => {
		const c = document.getElementById('view');
		return Array.from(c.getContext('2d').getImageData(c.width - 2,
			c.height - 2, 1, 1).data);
	});
	assert.ok(px.slice(0, 3).every((x, i) => Math.abs(x - BLUE[i]) <= 12),
		`the last picture is blue at the bottom right: ${px}`);
	assert.equal(st.views.length, 2, 'no VIEW more');
	step(`stand-in: a delta before any KEY made the page send VIEW ` +
		`again; ${s.video.drawn} pictures of ${v.width}x${v.height} by ` +
		`${s.video.codec}, FRAME_ACKs ${st.acks.join(' ')}`);
	/* A decoder that takes a chunk and never gives its picture: after
	 * 2 s the page lets the frame go (acknowledged), resets the decoder
	 * and asks for a KEY; it never stops waiting for nothing. */
	await page.evaluate(() => {
		VideoDecoder.prototype.decode = function () {};
	});
	st.send(frame(units[0]));
	await wait('the stuck frame acknowledged', () => st.acks.at(-1) === no);
	await wait('the VIEW sent again', () => st.views.length === 3);
	s = await page.evaluate(() => window.blobcast.state());
	assert.equal(s.video.stuck, 1, JSON.stringify(s.video));
	assert.equal(s.acks.forced, 0, 'handled by the page, not let go');
	step('stand-in: a decoder that gives no picture is reset after 2 s, ' +
		'its frame acknowledged and a KEY asked for');
	await page.close();
}

/* Pans page's camera with a right drag across its view: CAMERAs with
 * INTERACTING (moving frames), then one without (a still follows). */
async function move(page) {
	const box = await page.locator('#view').boundingBox();
	const x = box.x + box.width / 2, y = box.y + box.height / 2;
	await page.mouse.move(x, y);
	await page.mouse.down({ button: 'right' });
	for (let i = 1; i <= 8; i++) {
		await page.mouse.move(x + 6 * i, y + 3 * i);
		await page.waitForTimeout(60);
	}
	await page.mouse.up({ button: 'right' });
}

try {
	const stack = await H.startStack(daemon);
	step(`blobcastd :${stack.d.port}, websockify :${stack.proxy.port}, ` +
		`page :${stack.web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	await standInChecks(stack.web);

	/* ---- enc=h264 ---- */
	const a = await open(stack, 'name=video&enc=h264');
	const sa = await until(a, 'the WebCodecs probe', () => {
		const s = window.blobcast.state();
		return s.videoOk !== null && s;
	});
	const h264 = sa.videoOk;
	let encoder = false;
	if (!h264) {
		console.log('NOTE: this chromium has no WebCodecs H.264 decoder ' +
			'(VideoDecoder.isConfigSupported says no): only the fallback ' +
			'to JPEG is checked');
		assert.equal(sa.encodings & 8, 0, 'no encoding 4 in HELLO');
	} else {
		assert.equal(sa.encodings, 0x0f, 'HELLO lists encoding 4');
		/* The first frames: H.264 from a daemon with an encoder, JPEG
		 * after an ENOTSUP from one without. */
		const first = await until(a, 'the first frame', () => {
			const s = window.blobcast.state();
			return s.lastFrame && s;
		});
		encoder = first.lastFrame.encoding === P.ENC.H264;
		if (!encoder) {
			const refused = await a.evaluate(() =>
				window.blobcast.refusedEncodings());
			assert.equal(first.lastFrame.encoding, P.ENC.JPEG,
				'JPEG after the daemon refused H.264');
			assert.deepEqual(refused, [P.ENC.H264], 'H.264 marked refused');
			assert.equal(first.encoding, P.ENC.JPEG);
			assert.equal(await a.evaluate(() => document.querySelector(
				'#encoding option[value="4"]').disabled), true);
			console.log('NOTE: this blobcastd refuses encoding 4 (no ' +
				'H.264 encoder): the page fell back to JPEG; only the ' +
				'fallbacks are checked');
		}
	}
	if (encoder) {
		await move(a);
		const s = await settled(a, P.ENC.H264);
		const v = s.video;
		assert.equal(v.errors, 0, `decoder errors: ${v.error}`);
		assert.ok(v.keys >= 1 && v.drawn >= 2 && v.chunks > v.keys,
			`key and delta frames decoded and drawn: ${JSON.stringify(v)}`);
		assert.match(v.codec, /^avc1\.(42|4d|64)[0-9a-f]{4}$/);
		assert.equal(v.decoder, 'configured');
		const r = await compare(a);
		assert.ok(!r.error, r.error);
		assert.ok(r.psnr >= 30 && r.psnr >= r.black + 10,
			`the H.264 still against the raw snapshot: ${fmt(r)}`);
		step(`enc=h264: ${v.drawn} pictures from ${v.chunks} chunks ` +
			`(${v.keys} key) by ${v.codec}; still ${fmt(r)}`);
	} else {
		await move(a);
		await settled(a, P.ENC.JPEG);
		const r = await compare(a);
		assert.ok(!r.error, r.error);
		assert.ok(r.psnr >= 25 && r.psnr >= r.black + 10,
			`the JPEG still against the raw snapshot: ${fmt(r)}`);
		step(`enc=h264 fell back to JPEG: ${fmt(r)}`);
	}
	/* Acknowledgements: every frame, none let go. */
	const sk = await a.evaluate(() => window.blobcast.state());
	if (sk.features & P.FEATURE.ACKS) {
		assert.ok(sk.acks && sk.acks.sent > 0 && sk.acks.forced === 0 &&
			sk.acks.last >= sk.lastFrame.frame_no,
			`FRAME_ACKs up to the last frame drawn: ` +
			`${JSON.stringify(sk.acks)} (frame ${sk.lastFrame.frame_no})`);
		step(`ACKS granted: ${sk.acks.sent} FRAME_ACKs, the last for ` +
			`frame ${sk.acks.last}, none let go`);
	} else {
		assert.equal(sk.acks, null, 'no FRAME_ACK without ACKS');
		step('ACKS not granted by this daemon: no FRAME_ACK sent');
	}
	await a.close();

	if (encoder) {
		/* ---- enc=h264png: an exact still after H.264 motion ---- */
		const b = await open(stack, 'name=exact&enc=h264png');
		await move(b);
		const s = await settled(b, P.ENC.PNG);
		assert.equal(s.stillEncoding, P.ENC.PNG);
		assert.ok(s.video.drawn > 0 && s.video.errors === 0,
			`H.264 frames while moving: ${JSON.stringify(s.video)}`);
		const r = await compare(b);
		assert.ok(!r.error, r.error);
		assert.ok(r.max <= 2, `the PNG still against the raw snapshot: ` +
			`${fmt(r)}`);
		step(`enc=h264png: ${s.video.drawn} H.264 pictures, then a PNG ` +
			`still: ${fmt(r)}`);
		await b.close();

		/* ---- a decoder that fails ---- */
		const c = await open(stack, 'name=broken&enc=h264', () => {
			VideoDecoder.prototype.decode = function () {
				throw new DOMException('a decoder that fails', 'EncodingError');
			};
		});
		const sc = await settled(c, P.ENC.JPEG);
		assert.equal(sc.encoding, P.ENC.JPEG, 'the page asked for JPEG');
		assert.ok(sc.video.errors >= 1, JSON.stringify(sc.video));
		assert.match(await c.evaluate(() => document.getElementById(
			'message').textContent), /H\.264 decoding failed.*JPEG/);
		step(`a failing decoder: "${sc.video.error}", JPEG frames instead`);
		await c.close();
	}

	/* ---- no WebCodecs: JPEG ---- */
	const d = await open(stack, 'name=old&enc=h264', () => {
		delete window.VideoDecoder;
	});
	const sd = await settled(d, P.ENC.JPEG);
	assert.equal(sd.videoOk, false);
	assert.equal(sd.encodings, P.ENCODINGS_IMAGES, 'no encoding 4 in HELLO');
	assert.equal(sd.encoding, P.ENC.JPEG);
	assert.equal(sd.video.chunks, 0);
	assert.equal(await d.evaluate(() => [...document.querySelectorAll(
		'#encoding option')].filter((o) => o.value.startsWith('4') &&
		!o.disabled).length), 0, 'the H.264 choices are disabled');
	const rd = await compare(d);
	assert.ok(!rd.error, rd.error);
	assert.ok(rd.psnr >= 25 && rd.psnr >= rd.black + 10,
		`the JPEG still against the raw snapshot: ${fmt(rd)}`);
	step(`without VideoDecoder: JPEG frames, ${fmt(rd)}`);
	await d.close();
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
	console.error(H.logs());
} finally {
	await H.finish(browser, failed, watchdog);
}
