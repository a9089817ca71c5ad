/*
 * The processes the browser tests and the latency benchmark stand up, all
 * on 127.0.0.1 and all stopped again by stopAll(): blobcastd on a free
 * port with a throw-away data directory, websockify in front of it, and a
 * static file server for client/web/ (in this process: node's http module,
 * serving only the page's own files). Also the prerequisite check that
 * turns a missing tool into a skip with a message naming it, and what every
 * browser test does alike: loading playwright-core (never a downloaded
 * browser), a watchdog, and polling the page until a condition holds.
 */
import { execFile, spawn, spawnSync } from 'node:child_process';
import { existsSync, mkdtempSync, readdirSync, readFileSync, rmSync, statSync }
	from 'node:fs';
import { createServer } from 'node:http';
import net from 'node:net';
import { tmpdir } from 'node:os';
import { dirname, extname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

import * as P from '../../client/web/protocol.js';

export const HERE = dirname(fileURLToPath(import.meta.url));
export const ROOT = resolve(HERE, '..', '..');
export const WEB = join(ROOT, 'client', 'web');
export const CHROMIUM = '/usr/bin/chromium';
/* PLATFORM.md: headless Debian chromium, no sandbox (root in CI), nothing
 * that reaches out to the network. */
export const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu',
	'--disable-background-networking', '--disable-component-update',
	'--disable-sync', '--no-first-run'];

const children = [];
const cleanups = [];

/* The path of a program on PATH, or null. */
export function which(prog) {
	const r = spawnSync('sh', ['-c', `command -v ${prog}`], {
		encoding: 'utf8' });
	return r.status === 0 ? r.stdout.trim() : null;
}

/* blobcastd: --blobcastd PATH, $BLOBCASTD, or the first build folder that has
 * one. */
export function findDaemon(argv) {
	const i = argv.indexOf('--blobcastd');
	if (i >= 0 && argv[i + 1]) {
		return argv[i + 1];
	}
	if (process.env.BLOBCASTD) {
		return process.env.BLOBCASTD;
	}
	for (const d of ['build', 'build-web', 'build-release']) {
		const p = join(ROOT, d, 'server', 'blobcastd');
		if (existsSync(p)) {
			return p;
		}
	}
	return join(ROOT, 'build', 'server', 'blobcastd');
}

/* Names what is missing for a test that needs the given parts. */
export function missing({ daemon, browser = false, proxy = true }) {
	const out = [];
	if (browser && !existsSync(CHROMIUM)) {
		out.push(`${CHROMIUM} (apt package chromium)`);
	}
	if (browser && !existsSync(join(HERE, 'node_modules', 'playwright-core'))) {
		out.push('tests/web/node_modules/playwright-core (npm ci --prefix ' +
			'tests/web)');
	}
	if (proxy && !which('websockify')) {
		out.push('websockify (apt package websockify)');
	}
	let ok = false;
	try {
		ok = statSync(daemon).isFile();
	} catch {
		ok = false;
	}
	if (!ok) {
		out.push(`blobcastd (not built: ${daemon})`);
	}
	return out;
}

/* A port nobody listens on right now. */
export function freePort() {
	return new Promise((res, rej) => {
		const s = net.createServer();
		s.on('error', rej);
		s.listen(0, '127.0.0.1', () => {
			const { port } = s.address();
			s.close(() => res(port));
		});
	});
}

function started(child, name) {
	children.push(child);
	child.name = name;
	child.log = '';
	const keep = (d) => {
		child.log = (child.log + d.toString()).slice(-8000);
	};
	child.stdout?.on('data', keep);
	child.stderr?.on('data', keep);
	return child;
}

/* Resolves when text appears in the child's output; rejects when it exits
 * first or after ms. */
function waitOutput(child, text, ms) {
	return new Promise((res, rej) => {
		const t = setTimeout(() => rej(new Error(`${child.name}: no ` +
			`"${text}" within ${ms} ms; output:\n${child.log}`)), ms);
		const check = () => {
			if (child.log.includes(text)) {
				clearTimeout(t);
				res();
			}
		};
		child.stdout?.on('data', check);
		child.stderr?.on('data', check);
		child.on('exit', (code) => {
			clearTimeout(t);
			rej(new Error(`${child.name} exited (${code}):\n${child.log}`));
		});
		check();
	});
}

/* Resolves once a TCP connection to port succeeds. */
export async function waitPort(port, ms = 10000) {
	const end = Date.now() + ms;
	for (;;) {
		const ok = await new Promise((res) => {
			const s = net.connect(port, '127.0.0.1');
			s.on('connect', () => {
				s.destroy();
				res(true);
			});
			s.on('error', () => res(false));
		});
		if (ok) {
			return;
		}
		if (Date.now() > end) {
			throw new Error(`nothing listens on ${port} after ${ms} ms`);
		}
		await new Promise((r) => setTimeout(r, 50));
	}
}

/* blobcastd with the default session, on a free port and a throw-away data
 * directory, or on opts.port and opts.data (a restart of an earlier one). */
export async function startDaemon(path, extra = [], opts = {}) {
	const port = opts.port ?? await freePort();
	let data = opts.data;
	if (!data) {
		data = mkdtempSync(join(tmpdir(), 'blobcast-web-'));
		cleanups.push(() => rmSync(data, { recursive: true, force: true }));
	}
	const child = started(spawn(path, ['--listen', `127.0.0.1:${port}`,
		'--data', data, ...extra], { stdio: ['ignore', 'pipe', 'pipe'] }),
	'blobcastd');
	await waitOutput(child, 'listening on', 30000);
	return { port, child, data };
}

/* Stops one child this module started (SIGTERM: blobcastd saves its
 * sessions) and waits for it to exit. */
export async function stopChild(c) {
	if (c.exitCode === null && c.signalCode === null) {
		const gone = new Promise((r) => c.once('exit', r));
		c.kill('SIGTERM');
		const t = setTimeout(() => c.kill('SIGKILL'), 3000);
		await gone;
		clearTimeout(t);
	}
}

/* websockify from a free port to the daemon's. */
export async function startProxy(target) {
	const port = await freePort();
	const child = started(spawn(which('websockify'), [`127.0.0.1:${port}`,
		`127.0.0.1:${target}`], { stdio: ['ignore', 'pipe', 'pipe'] }),
	'websockify');
	await waitPort(port);
	return { port, child };
}

const TYPES = { '.html': 'text/html; charset=utf-8', '.js': 'text/javascript',
	'.css': 'text/css', '.json': 'application/json' };

/* Serves the page's files (the .html, .js and .css of client/web/) and
 * nothing else. */
export async function startStatic() {
	const files = new Set(readdirSync(WEB).filter((f) =>
		/\.(html|js|css)$/.test(f)));
	const server = createServer((req, res) => {
		const name = new URL(req.url, 'http://x').pathname.slice(1) ||
			'index.html';
		if (!files.has(name)) {
			res.writeHead(404).end();
			return;
		}
		res.writeHead(200, { 'content-type': TYPES[extname(name)],
			'cache-control': 'no-store' });
		res.end(readFileSync(join(WEB, name)));
	});
	await new Promise((res) => server.listen(0, '127.0.0.1', res));
	cleanups.push(() => server.close());
	return { port: server.address().port, server };
}

/* blobcastd (with extra arguments), websockify in front of it and the
 * page's files: { d, proxy, web }. */
export async function startStack(daemon, extra = []) {
	const d = await startDaemon(daemon, extra);
	const proxy = await startProxy(d.port);
	const web = await startStatic();
	return { d, proxy, web };
}

/* Uncaught errors of the pages joinPage opened: each fails the test
 * (finish). */
const pageErrors = [];

/* A new page of browser (viewport { width, height }) on the page of
 * stack (startStack) as client name in session; an uncaught error in it
 * is printed and fails the test. */
export async function joinPage(browser, stack, { name, viewport,
	session = 'default' }) {
	const page = await browser.newPage({ viewport });
	page.on('pageerror', (e) => {
		console.error(`page ${name}: ${e.message}`);
		pageErrors.push(e);
	});
	await page.goto(`http://127.0.0.1:${stack.web.port}/?ws=` +
		`${stack.proxy.port}&session=${session}&name=${name}`);
	return page;
}

/* Clicks selector on page and resolves with the file it downloads:
 * { name (the suggested one), bytes }. */
export async function download(page, selector, ms = 60000) {
	const [d] = await Promise.all([page.waitForEvent('download',
		{ timeout: ms }), page.click(selector)]);
	return { name: d.suggestedFilename(), bytes: readFileSync(await d
		.path()) };
}

/* Stops every child this module started (by its own pid) and removes the
 * temporary data. */
export async function stopAll() {
	for (const c of children.splice(0)) {
		if (c.exitCode === null && c.signalCode === null) {
			const gone = new Promise((r) => c.once('exit', r));
			c.kill('SIGTERM');
			const t = setTimeout(() => c.kill('SIGKILL'), 3000);
			await gone;
			clearTimeout(t);
		}
	}
	for (const f of cleanups.splice(0)) {
		f();
	}
}

/* Prints e, what failed a test, with the children's logs. */
export function report(e) {
	console.error(`FAIL: ${e.stack || e}`);
	console.error(logs());
}

/* The log tail of every child, for a failure report. */
export function logs() {
	return children.map((c) => `--- ${c.name}\n${c.log}`).join('\n');
}

/* Ends the test as skipped (exit 77), saying "SKIP: WHAT needs ...",
 * when lacking (from missing()) names anything. */
export function skipIfMissing(what, lacking) {
	if (lacking.length) {
		console.log(`SKIP: ${what} needs ${lacking.join(', ')}`);
		process.exit(77);
	}
}

/* A progress logger: each line starts with the seconds since it was made. */
export function stepper() {
	const t0 = Date.now();
	return (s) => console.log(`[${((Date.now() - t0) / 1000).toFixed(1)} s]` +
		` ${s}`);
}

/* playwright-core's chromium, driving Debian's chromium (CHROMIUM). */
export async function playwright() {
	process.env.PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD = '1';
	const { chromium } = await import(join(HERE, 'node_modules',
		'playwright-core', 'index.mjs'));
	return chromium;
}

/* The start of a browser test of what, against the daemon given as
 * --blobcastd PATH (and, with cli, the CLI as --blobcast PATH): exits 77
 * naming what is missing, else starts the watchdog of ms and returns
 * { daemon, cli, chromium, step (a stepper), watchdog, until (the
 * harness's until, 20 s and 30 ms polls by default) }. */
export async function begin(what, { cli = false, ms }) {
	const daemon = findDaemon(process.argv);
	const lacking = missing({ daemon, browser: true });
	const cliPath = cli ? findCli(process.argv, lacking) : null;
	skipIfMissing(what, lacking);
	return { daemon, cli: cliPath, chromium: await playwright(),
		step: stepper(), watchdog: watchdog(ms),
		until: (page, text, fn, arg, t = 20000) =>
			until(page, text, fn, arg, t, 30) };
}

/* Fails the whole test (exit 1, with the children's logs when withLogs)
 * if it runs past ms; clearTimeout() the result at the end. */
export function watchdog(ms, withLogs = true) {
	return setTimeout(() => {
		console.error(`FAIL: over ${ms} ms` + (withLogs ? `\n${logs()}` : ''));
		process.exit(1);
	}, ms);
}

/* Polls fn (evaluated in page, with arg) every pollMs until it returns a
 * truthy value, which it returns; after ms, throws naming what and the
 * page's state. */
export async function until(page, what, fn, arg, ms, pollMs) {
	const end = Date.now() + ms;
	for (;;) {
		const v = await page.evaluate(fn, arg);
		if (v) {
			return v;
		}
		if (Date.now() > end) {
			const st = await page.evaluate(() => window.blobcast?.state());
			throw new Error(`timed out waiting for ${what}; page state: ` +
				JSON.stringify(st));
		}
		await page.waitForTimeout(pollMs);
	}
}

/* A point on node id's outliner row (scrolled into view), a third of
 * the way across and at fraction f of its height, in page
 * coordinates. The outliner redraws its rows whenever the mirror
 * changes (another member's edit, a refusal), so the row is found,
 * scrolled to and measured in one turn of the page's own loop: a row
 * found by one call and measured by the next may have been replaced
 * in between. */
export async function rowPoint(page, id, f = 0.5) {
	const sel = `#outliner .row[data-id="${id}"]`;
	await page.locator(sel).waitFor({ state: 'attached', timeout: 20000 });
	const box = await page.evaluate((s) => {
		const row = document.querySelector(s);
		if (!row) {
			return null;
		}
		row.scrollIntoView({ block: 'nearest' });
		const r = row.getBoundingClientRect();
		return r.width > 0 && r.height > 0 ?
			{ x: r.x, y: r.y, width: r.width, height: r.height } : null;
	}, sel);
	if (!box) {
		throw new Error(`row #${id} is not drawn`);
	}
	return { x: box.x + box.width / 3, y: box.y + box.height * f };
}

/* A real pointer drag from a to b in steps, the button held: resolves
 * with the function that lets it go (the drop). */
export async function pointerPress(page, a, b, steps = 8) {
	await page.mouse.move(a.x, a.y);
	await page.mouse.down();
	for (let i = 1; i <= steps; i++) {
		await page.mouse.move(a.x + (b.x - a.x) * i / steps,
			a.y + (b.y - a.y) * i / steps);
	}
	return () => page.mouse.up();
}

/* The RGB of every step-th pixel of page's view, as one flat array. */
export function viewPixels(page, step = 3) {
	return page.evaluate((k) => {
		const c = document.getElementById('view');
		const d = c.getContext('2d').getImageData(0, 0, c.width, c.height)
			.data;
		const out = [];
		for (let i = 0; i < d.length; i += 4 * k) {
			out.push(d[i], d[i + 1], d[i + 2]);
		}
		return out;
	}, step);
}

/* How many pixels of two viewPixels arrays differ by more than 40 in
 * R + G + B. */
export function pixelsChanged(a, b) {
	let n = 0;
	for (let i = 0; i < a.length; i += 3) {
		if (Math.abs(a[i] - b[i]) + Math.abs(a[i + 1] - b[i + 1]) +
			Math.abs(a[i + 2] - b[i + 2]) > 40) {
			n++;
		}
	}
	return n;
}

/* Ends a browser test: closes the browser, stops every child this module
 * started, clears the watchdog, prints the count and exits (status 1 when
 * failed). */
export async function finish(browser, failedBefore, watchdog) {
	const failed = failedBefore || pageErrors.length > 0;
	if (browser) {
		await browser.close().catch(() => {});
	}
	await stopAll();
	clearTimeout(watchdog);
	console.log(failed ? '0 passed, 1 failed' : '1 passed, 0 failed');
	process.exit(failed ? 1 : 0);
}

/* The blobcast CLI given as --blobcast PATH, or null after adding what is
 * missing to lacking. */
export function findCli(argv, lacking) {
	const i = argv.indexOf('--blobcast');
	const cli = i > 0 ? argv[i + 1] : null;
	if (!cli || !existsSync(cli)) {
		lacking.push(`the blobcast CLI (${cli ?? 'give --blobcast PATH'})`);
		return null;
	}
	return cli;
}

/* Runs the CLI; resolves with { code, stdout, stderr }. */
export function runCli(cli, args, ms = 15000) {
	return new Promise((resolve) => execFile(cli, args, { timeout: ms },
		(err, stdout, stderr) => resolve({ code: err ? err.code : 0,
			stdout, stderr })));
}

/* A stand-in for blobcastd on a page's WebSocket (routeWebSocket's ws),
 * for what a test wants of a daemon that is not blobcastd. Each message
 * the page sends goes to each(m, send) first (send encodes a message and
 * sends it to the page); then HELLO gets a WELCOME granting features(m)
 * (undefined: no features field, an earlier daemon's), SESSION_JOIN a
 * SESSION_INFO with the page as the one member, named member, and
 * SESSION_LIST an empty SESSIONS. Returns send. */
export function standInDaemon(ws, { features = () => undefined,
	member = 'dave', each = () => {} } = {}) {
	const r = new P.Reader({ side: 'server' });
	const send = (m) => ws.send(Buffer.from(P.encode({ seq: 0, flags: 0,
		...m })));
	ws.onMessage((msg) => {
		r.feed(typeof msg === 'string' ? Buffer.from(msg) : msg);
		for (let m; (m = r.next());) {
			each(m, send);
			if (m.type === P.MSG.HELLO) {
				send({ type: P.MSG.WELCOME, seq: m.seq, version: 1,
					connection_id: 1, max_payload: P.LIMITS.MAX_PAYLOAD,
					max_frame_bytes: P.LIMITS.MAX_PAYLOAD, max_nodes: 1000,
					max_dim: 4096, max_members: 8, max_edit_ops: 64,
					server_id: 'stand-in', features: features(m) });
			} else if (m.type === P.MSG.SESSION_JOIN) {
				send({ type: P.MSG.SESSION_INFO, session_id: 1,
					member_id: 1, role: m.role, name: m.name,
					members: [{ id: 1, role: m.role, name: member }] });
			} else if (m.type === P.MSG.SESSION_LIST) {
				send({ type: P.MSG.SESSIONS, seq: m.seq, sessions: [] });
			}
		}
	});
	return send;
}
