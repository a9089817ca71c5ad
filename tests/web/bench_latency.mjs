/*
 * Benchmark: edit -> frame latency through websockify against direct TCP,
 * measured the same way on both paths in one run against one blobcastd.
 *
 * Two clients speak the protocol with client/web/protocol.js: one over a
 * plain TCP socket to the daemon, one over a WebSocket (binary
 * subprotocol) through websockify, the page's transport. Each creates its
 * own session with the same small scene and view, so neither renders for
 * the other. Then, taking turns so that drift in the machine's load hits
 * every path alike, each round sends one EDIT (a sphere moved, no
 * INTERACTING flag) and times:
 *   ack:   EDIT sent -> its EDIT_APPLIED received,
 *   frame: EDIT sent -> the first still FRAME whose order reflects it,
 *          received whole.
 * When chromium and playwright-core are there, the page itself is a third
 * path (its own session, same scene, a view of the same size): the page's
 * edit -> frame, from sending the EDIT to having decoded and drawn the
 * frame, which is what its overlay shows.
 * Prints median, mean, p90 and min per path and the ws/tcp ratio.
 *
 * Usage: node tests/web/bench_latency.mjs [--blobcastd PATH] [--n N]
 *        [--size WxH] [--no-page]
 */
import { spawnSync } from 'node:child_process';
import { join } from 'node:path';
import net from 'node:net';

import * as P from '../../client/web/protocol.js';
import * as H from './harness.mjs';

/* node 20 has WebSocket behind a flag: run again with it. */
if (typeof WebSocket === 'undefined') {
	const r = spawnSync(process.execPath, ['--experimental-websocket',
		'--no-warnings', ...process.argv.slice(1)], { stdio: 'inherit' });
	process.exit(r.status ?? 1);
}

const arg = (name, def) => {
	const i = process.argv.indexOf(name);
	return i >= 0 ? process.argv[i + 1] : def;
};
const N = Number(arg('--n', '40'));
const [W, HT] = arg('--size', '640x480').split('x').map(Number);

/* A protocol client over some byte transport. */
class Client {
	constructor(name, sendBytes) {
		this.name = name;
		this.sendBytes = sendBytes;
		this.reader = new P.Reader({ side: 'client' });
		this.seq = 0;
		this.waiters = [];
		this.bytes = 0;
	}

	feed(b) {
		this.bytes += b.byteLength;
		this.reader.feed(b);
		for (let m; (m = this.reader.next());) {
			const now = performance.now();
			if (m.type === P.MSG.ERROR) {
				throw new Error(`${this.name}: ${P.errName(m.code)} ${m.text}`);
			}
			if (m.type === P.MSG.PING) {
				this.send(P.MSG.PONG, { stamp: m.stamp });
			}
			this.waiters = this.waiters.filter((w) => !w(m, now));
		}
	}

	send(type, fields = {}, flags = 0) {
		this.seq++;
		this.sendBytes(P.encode({ ...fields, type, flags, seq: this.seq }));
		return this.seq;
	}

	/* Resolves with [message, time] for the first message pred accepts. */
	wait(pred, ms = 20000) {
		return new Promise((res, rej) => {
			const t = setTimeout(() => rej(new Error(`${this.name}: timed ` +
				'out')), ms);
			this.waiters.push((m, now) => {
				if (!pred(m)) {
					return false;
				}
				clearTimeout(t);
				res([m, now]);
				return true;
			});
		});
	}
}

function tcpClient(port) {
	return new Promise((res, rej) => {
		const s = net.connect(port, '127.0.0.1');
		s.setNoDelay(true);
		const c = new Client('tcp', (b) => s.write(b));
		s.on('data', (d) => c.feed(d));
		s.on('error', rej);
		s.on('connect', () => res(c));
		c.close = () => s.destroy();
	});
}

function wsClient(port) {
	return new Promise((res, rej) => {
		const ws = new WebSocket(`ws://127.0.0.1:${port}/`, ['binary']);
		ws.binaryType = 'arraybuffer';
		const c = new Client('ws', (b) => ws.send(b));
		ws.onmessage = (e) => c.feed(new Uint8Array(e.data));
		ws.onerror = () => rej(new Error('websocket error'));
		ws.onopen = () => res(c);
		c.close = () => ws.close();
	});
}

/* Three spheres under a smooth union; the benchmark moves sphere 2. */
function sceneBytes() {
	const prim = (id, x, r, color) => ({ isOp: false, kind: 1, id,
		translate: [x, 0, 0], rotate: [0, 0, 0, 1], color, params: [r] });
	return P.encodeScene({
		camera: { eye: [0, 1, 5], target: [0, 0, 0], up: [0, 1, 0],
			fov_y_deg: 45 },
		root: { isOp: true, kind: 4, id: 1, blend: 0.3, range: 0.3,
			children: [prim(2, -0.8, 0.6, [0.9, 0.3, 0.2]),
				prim(3, 0.2, 0.5, [0.3, 0.7, 0.4]),
				prim(4, 1.0, 0.4, [0.3, 0.4, 0.9])] },
	});
}

/* The page as a third path: its session gets the same scene from a
 * short-lived TCP client, then the page joins it with a view of the
 * benchmark's size. Returns { round(i) -> ms, close() } or null. */
async function pagePath(daemonPort, wsPort) {
	if (process.argv.includes('--no-page') ||
		H.missing({ daemon: H.findDaemon(process.argv), browser: true })
			.length) {
		return null;
	}
	const seed = await tcpClient(daemonPort);
	await setUp(seed, 'bench-page');
	seed.close();
	const web = await H.startStatic();
	const { chromium } = await import(join(H.HERE, 'node_modules',
		'playwright-core', 'index.mjs'));
	const browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	/* The stage is the viewport less the 280-pixel side panel and the
	 * header, measured once the page is up. */
	const page = await browser.newPage({ viewport: { width: W + 280,
		height: HT + 40 } });
	await page.goto(`http://127.0.0.1:${web.port}/?ws=${wsPort}` +
		'&session=bench-page&name=bench-page&downscale=1&quality=85');
	const header = await page.evaluate(() =>
		document.querySelector('header').getBoundingClientRect().height);
	await page.setViewportSize({ width: W + 280,
		height: HT + Math.round(header) });
	await page.waitForFunction(([w, h]) => {
		const s = window.blobcast.state();
		return s.view && s.view.width === w && s.view.height === h &&
			s.lastFrame && s.lastFrame.still && s.lastFrame.width === w;
	}, [W, HT], { timeout: 30000 });
	return {
		round: (i) => page.evaluate(([x, y]) => window.blobcast.moveTo(2,
			[x, y, 0]), [i % 2 ? -0.7 : -0.9, 0.05 * (i % 3)]),
		close: () => browser.close(),
	};
}

async function setUp(c, session) {
	c.send(P.MSG.HELLO, { version_min: 1, version_max: 1,
		encodings: P.ENCODINGS_ALL, max_frame_bytes: 0,
		client_name: `bench-${c.name}`, token: '' });
	await c.wait((m) => m.type === P.MSG.WELCOME);
	c.send(P.MSG.SESSION_CREATE, { role: P.ROLE.EDITOR, name: session });
	await c.wait((m) => m.type === P.MSG.SESSION_INFO);
	const load = c.send(P.MSG.SCENE_LOAD, { scene: sceneBytes() });
	await c.wait((m) => m.type === P.MSG.SCENE_STATE &&
		m.author_seq === load);
	c.send(P.MSG.VIEW, { width: W, height: HT, encoding: P.ENC.JPEG,
		quality_interactive: 70, quality_still: 85, downscale: 1 });
	await c.wait((m) => m.type === P.MSG.FRAME && (m.flags & P.FLAG.STILL));
}

/* One round: returns { ack, frame, bytes } in ms and bytes. */
async function round(c, i) {
	const x = i % 2 ? -0.7 : -0.9;
	const t0 = performance.now();
	const seq = c.send(P.MSG.EDIT, { ops: [{ kind: P.EDIT.SET, node: 2,
		fields: [{ field: P.FIELD.TRANSLATE, values: [x, 0.05 * (i % 3), 0] }] }] });
	const [applied, t1] = await c.wait((m) => m.type === P.MSG.EDIT_APPLIED &&
		m.author_seq === seq);
	const [frame, t2] = await c.wait((m) => m.type === P.MSG.FRAME &&
		m.order >= applied.order && (m.flags & P.FLAG.STILL));
	/* Let the daemon go idle so rounds do not overlap. */
	await new Promise((r) => setTimeout(r, 30));
	return { ack: t1 - t0, frame: t2 - t0, bytes: frame.rects.reduce((n, r) =>
		n + r.data.length, 0) };
}

function summary(xs) {
	const s = xs.slice().sort((a, b) => a - b);
	const q = (p) => s[Math.min(s.length - 1, Math.floor(p * s.length))];
	return { median: q(0.5), mean: s.reduce((a, b) => a + b, 0) / s.length,
		p90: q(0.9), min: s[0] };
}

const fmt = (v) => v.toFixed(2).padStart(7);

const daemon = H.findDaemon(process.argv);
const lacking = H.missing({ daemon });
if (lacking.length) {
	console.log(`bench needs ${lacking.join(', ')}`);
	process.exit(77);
}
try {
	const d = await H.startDaemon(daemon);
	const proxy = await H.startProxy(d.port);
	const tcp = await tcpClient(d.port);
	const ws = await wsClient(proxy.port);
	await setUp(tcp, 'bench-tcp');
	await setUp(ws, 'bench-ws');
	const page = await pagePath(d.port, proxy.port);
	const res = { tcp: [], ws: [], page: [] };
	/* Two warm-up rounds each, then N measured, taking turns. */
	for (let i = 0; i < N + 2; i++) {
		for (const c of i % 2 ? [ws, tcp] : [tcp, ws]) {
			const r = await round(c, i);
			if (i >= 2) {
				res[c.name].push(r);
			}
		}
		if (page) {
			const ms = await page.round(i);
			await new Promise((r) => setTimeout(r, 30));
			if (i >= 2) {
				res.page.push({ frame: ms });
			}
		}
	}
	if (page) {
		await page.close();
	}
	console.log(`edit -> frame, ${W}x${HT} JPEG q85 still frames, ${N} ` +
		'rounds per path, taking turns');
	console.log('path        what     median    mean     p90     min  (ms)');
	const med = {};
	for (const path of ['tcp', 'ws']) {
		for (const what of ['ack', 'frame']) {
			const s = summary(res[path].map((r) => r[what]));
			med[`${path}.${what}`] = s.median;
			console.log(`${path.padEnd(11)} ${what.padEnd(6)} ${fmt(s.median)}` +
				` ${fmt(s.mean)} ${fmt(s.p90)} ${fmt(s.min)}`);
		}
	}
	if (res.page.length) {
		const s = summary(res.page.map((r) => r.frame));
		med['page.frame'] = s.median;
		console.log(`${'page (ws)'.padEnd(11)} ${'drawn'.padEnd(6)} ` +
			`${fmt(s.median)} ${fmt(s.mean)} ${fmt(s.p90)} ${fmt(s.min)}`);
	}
	const kb = res.ws.reduce((a, r) => a + r.bytes, 0) / res.ws.length / 1024;
	console.log(`frame size ${kb.toFixed(1)} kB; ws/tcp median ratio: ack ` +
		`${(med['ws.ack'] / med['tcp.ack']).toFixed(2)}, frame ` +
		`${(med['ws.frame'] / med['tcp.frame']).toFixed(2)}; websockify ` +
		`adds ${(med['ws.frame'] - med['tcp.frame']).toFixed(2)} ms to ` +
		'the median edit -> frame');
	tcp.close();
	ws.close();
} catch (e) {
	console.error(`bench failed: ${e.stack || e}\n${H.logs()}`);
	process.exitCode = 1;
} finally {
	await H.stopAll();
}
