/*
 * Big pictures from the browser page: blobcastd, websockify and one page
 * in headless Debian chromium (playwright-core).
 *  - the page's "save PNG" form asks for a picture in tiles (SNAPSHOT's
 *    tile form) and the browser downloads a PNG of the size typed;
 *  - a picture assembled from 64-pixel tiles (ragged at two edges) equals,
 *    pixel for pixel, `blobcast snapshot` of the same size and camera in
 *    one piece;
 *  - a size outside 1..8192 is refused in the page with a message, and
 *    nothing is sent.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/picture.mjs --blobcastd PATH --blobcast PATH
 */
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import * as H from './harness.mjs';

const DEADLINE_MS = 90000;

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon, browser: true });
const cli = H.findCli(process.argv, lacking);
H.skipIfMissing('web picture', lacking);
const chromium = await H.playwright();

let browser = null;
let failed = false;
const step = H.stepper();
const watchdog = H.watchdog(DEADLINE_MS);

const until = (page, what, fn, arg, ms = 30000) =>
	H.until(page, what, fn, arg, ms, 30);

const run = (args) => H.runCli(cli, args, 60000);

/* Width and height from a PNG's IHDR. */
function pngSize(bytes) {
	assert.equal(bytes.subarray(1, 4).toString('latin1'), 'PNG',
		'a PNG signature');
	return { w: bytes.readUInt32BE(16), h: bytes.readUInt32BE(20) };
}

try {
	const d = await H.startDaemon(daemon);
	const proxy = await H.startProxy(d.port);
	const web = await H.startStatic();
	step(`blobcastd :${d.port}, websockify :${proxy.port}, page :${web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const page = await browser.newPage({ viewport: { width: 640,
		height: 400 }, acceptDownloads: true });
	page.on('pageerror', (e) => {
		console.error(`page: ${e.message}`);
		failed = true;
	});
	await page.goto(`http://127.0.0.1:${web.port}/?ws=${proxy.port}` +
		'&session=default&name=carol');
	await until(page, 'the scene', () => window.blobcast.state().connected &&
		window.blobcast.primitives().length > 0 &&
		!document.getElementById('picturebtn').disabled);
	step('joined; the picture form is enabled (the daemon granted TILES)');

	/* The form: a download of the size typed. */
	await page.fill('#picturesize', '1100x700');
	const [download] = await Promise.all([
		page.waitForEvent('download', { timeout: 60000 }),
		page.click('#picturebtn'),
	]);
	const file = await download.path();
	const size = pngSize(readFileSync(file));
	assert.deepEqual(size, { w: 1100, h: 700 }, 'the downloaded PNG');
	assert.match(download.suggestedFilename(), /^blobcast-default-\d+\.png$/);
	const info = await page.evaluate(() =>
		document.getElementById('pictureinfo').textContent);
	assert.match(info, /^saved 1100×700 of edit \d+ \(2 tiles\)$/,
		`the form says what it saved: "${info}"`);
	step(`"save PNG" downloaded ${download.suggestedFilename()}, ` +
		`${size.w}x${size.h}, after "${info}"`);

	/* Tiles of 64 against one snapshot of the same size and camera. */
	const W = 300, H2 = 200;
	const pic = await page.evaluate(({ w, h }) =>
		window.blobcast.picture(w, h, 64), { w: W, h: H2 });
	assert.deepEqual([pic.width, pic.height], [W, H2]);
	const out = join(tmpdir(), `bc-picture-${process.pid}.png`);
	const r = await run(['snapshot', '--server', `127.0.0.1:${d.port}`,
		'--session', 'default', '--size', `${W}x${H2}`, '--out', out]);
	assert.equal(r.code, 0, `blobcast snapshot: ${r.stderr}`);
	const bad = await page.evaluate(async ({ b64, w, h }) => {
		const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
		const bmp = await createImageBitmap(new Blob([bytes],
			{ type: 'image/png' }), { premultiplyAlpha: 'none',
			colorSpaceConversion: 'none' });
		const c = document.createElement('canvas');
		c.width = w;
		c.height = h;
		const ctx = c.getContext('2d');
		ctx.drawImage(bmp, 0, 0);
		const want = ctx.getImageData(0, 0, w, h).data;
		const got = window.blobcast.picturePixels(0, 0, w, h);
		let n = 0;
		for (let i = 0; i < want.length; i += 4) {
			if (want[i] !== got[i] || want[i + 1] !== got[i + 1] ||
				want[i + 2] !== got[i + 2]) {
				n++;
			}
		}
		return n;
	}, { b64: readFileSync(out).toString('base64'), w: W, h: H2 });
	assert.equal(bad, 0, `${bad} pixels of the tiled picture differ from ` +
		'the one-piece snapshot');
	step(`${W}x${H2} in 64-pixel tiles equals blobcast snapshot pixel ` +
		`for pixel (edit ${pic.order})`);

	/* A size out of range: a message, nothing sent. */
	await page.fill('#picturesize', '9000x100');
	await page.click('#picturebtn');
	await until(page, 'the refusal', () => document.getElementById('message')
		.textContent.includes('1..8192'));
	step('9000x100 is refused in the page');
} catch (e) {
	failed = true;
	console.error(`FAIL: ${e.stack || e}`);
	console.error(H.logs());
} finally {
	await H.finish(browser, failed, watchdog);
}
