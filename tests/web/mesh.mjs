/*
 * The page's mesh download (client/web/review.js; MESH and MESH_DATA,
 * PROTOCOL.md 7.28): blobcastd, websockify and pages in headless Debian
 * chromium (playwright-core).
 *  - alice (an editor) moves a shape, then saves the session's solid as
 *    glb at the default resolution: while the daemon's MESH_DATA is held
 *    back (her WebSocket is routed through this script) the page says
 *    "meshing on the daemon (glb, 128)...", the button reads "meshing…",
 *    a second click says the mesh is still being made and sends no
 *    second MESH, and another edit and a turn of the camera are applied
 *    and drawn (the page goes on; the answers to later requests come
 *    before the MESH's). Once let through, the file is downloaded as
 *    blobcast-default-ORDER.glb, ORDER the edit the mesh is of (not the
 *    page's newer one), the page says "saved ...: N triangles, edit
 *    order ORDER", and its bytes are those `blobcast mesh --session
 *    default --out X.glb` wrote of that edit;
 *  - OBJ at 48 cells, raw PLY at 40 and STL at 24 equal the CLI's files
 *    of the same options;
 *  - 600 cells (over blobcastd's bound) are refused by the daemon (ELIMIT)
 *    and the page shows its words; nothing is downloaded; 3 cells are
 *    refused in the page, and nothing is sent;
 *  - the connection dropped while a mesh is made: the page forgets it
 *    and says so; after it rejoins it meshes again;
 *  - bob (a viewer) saves the same glb;
 *  - against a stand-in server that does not grant MESH the control is
 *    off and its title says why.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/mesh.mjs --blobcastd PATH --blobcast PATH
 */
import assert from 'node:assert/strict';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import * as H from './harness.mjs';
import * as P from '../../client/web/protocol.js';

const DEADLINE_MS = 120000;
/* Long enough for a first frame or a mesh on a loaded 2-core machine;
 * a condition that holds returns at once. */
const WAIT_MS = 60000;

const { daemon, cli, chromium, step, watchdog, until: until0 } =
	await H.begin('web mesh', { cli: true, ms: DEADLINE_MS });
const until = (page, what, fn, arg) => until0(page, what, fn, arg,
	WAIT_MS);

let browser = null;
let failed = false;
const work = mkdtempSync(join(tmpdir(), 'blobcast-web-mesh-'));

/* Waits in this script until check() holds (a condition on what the
 * route saw), polling as the harness does. */
async function waitFor(page, what, check) {
	for (const end = Date.now() + WAIT_MS; !check();) {
		assert.ok(Date.now() < end, `timed out waiting for ${what}`);
		await page.waitForTimeout(30);
	}
}

/* Routes page's WebSockets through this script: the MESH messages the
 * page sends are decoded and kept (meshes); the daemon's stream is cut
 * into whole messages, and while hold is set its MESH_DATA waits in
 * held until release(); drop() closes the page's connection (and the
 * daemon's leg of it) with reason "dropped by the test". */
async function route(page) {
	const r = { meshes: [], hold: false, held: [], conn: null };
	await page.routeWebSocket(/.*/, (ws) => {
		const server = ws.connectToServer();
		const fromPage = new P.Reader({ side: 'server' });
		const conn = { ws, server, gone: false };
		ws.onMessage((m) => {
			server.send(m);
			fromPage.feed(new Uint8Array(Buffer.from(m)));
			for (let x; (x = fromPage.next());) {
				if (x.type === P.MSG.SESSION_JOIN) {
					r.conn = conn; /* the page's own connection */
				} else if (x.type === P.MSG.MESH) {
					r.meshes.push(x);
				}
			}
		});
		let buf = Buffer.alloc(0);
		server.onMessage((m) => {
			buf = Buffer.concat([buf, Buffer.from(m)]);
			while (buf.length >= P.HEADER_SIZE) {
				const n = P.HEADER_SIZE + buf.readUInt32LE(8);
				if (buf.length < n) {
					break;
				}
				const msg = buf.subarray(0, n);
				buf = buf.subarray(n);
				if (conn.gone) {
					continue;
				}
				if (r.hold && msg[5] === P.MSG.MESH_DATA) {
					r.held.push(msg);
				} else {
					ws.send(msg);
				}
			}
		});
	});
	r.release = () => {
		r.hold = false;
		for (const m of r.held.splice(0)) {
			r.conn.ws.send(m);
		}
	};
	r.drop = async () => {
		const c = r.conn;
		c.gone = true;
		r.held.length = 0;
		r.hold = false;
		await c.ws.close({ code: 4000, reason: 'dropped by the test' });
		await c.server.close();
	};
	return r;
}

/* A page of browser as name (role: editor or viewer) in session default,
 * its downloads counted; routed through route() when routed. */
async function openPage(stack, name, role, routed) {
	const page = await browser.newPage({ viewport: { width: 980,
		height: 560 }, acceptDownloads: true });
	page.on('pageerror', (e) => {
		console.error(`page ${name}: ${e.message}`);
		failed = true;
	});
	page.downloads = [];
	page.on('download', (d) => page.downloads.push(d.suggestedFilename()));
	const r = routed ? await route(page) : null;
	await page.goto(`http://127.0.0.1:${stack.web.port}/?ws=` +
		`${stack.proxy.port}&session=default&name=${name}&role=${role}`);
	await until(page, `${name} joined`, () => {
		const s = window.blobcast.state();
		return s.connected && s.framesDrawn >= 1 &&
			window.blobcast.mesh().granted;
	});
	return { page, r };
}

const mesh = (page) => page.evaluate(() => window.blobcast.mesh());
const message = (page) => page.textContent('#message');

/* A download that click (a promise) brings: { name, bytes }. */
async function downloaded(page, click) {
	const [d] = await Promise.all([page.waitForEvent('download',
		{ timeout: WAIT_MS }), click]);
	return { name: d.suggestedFilename(), bytes: readFileSync(await d
		.path()) };
}

try {
	const stack = await H.startStack(daemon);
	const srv = ['--server', `127.0.0.1:${stack.d.port}`, '--session',
		'default'];
	step(`blobcastd :${stack.d.port}, websockify :${stack.proxy.port}`);
	/* `blobcast mesh` of the session with args: the file's bytes. */
	const cliMesh = async (file, args = []) => {
		const out = join(work, file);
		const r = await H.runCli(cli, ['mesh', ...srv, '--out', out,
			'--quiet', ...args], WAIT_MS);
		assert.equal(r.code, 0, `blobcast mesh ${args}: ${r.stderr}`);
		return readFileSync(out);
	};
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const { page: alice, r } = await openPage(stack, 'alice', 'editor',
		true);
	const st = await alice.evaluate(() => window.blobcast.state());
	assert.ok(st.features & P.FEATURE.MESH, 'the daemon granted MESH');
	assert.ok(!await alice.isDisabled('#meshbtn'), 'the button is on');

	/* An edit first: the mesh is of the scene with it. */
	const shape = (await alice.evaluate(() =>
		window.blobcast.primitives()))[0];
	await alice.evaluate(([id, t]) => window.blobcast.moveTo(id, t),
		[shape.id, [shape.translate[0] + 0.25, shape.translate[1],
			shape.translate[2]]]);
	const order = (await alice.evaluate(() => window.blobcast.state()))
		.order;
	step(`alice joined, the daemon granted MESH; she moved #${shape.id} ` +
		`(edit order ${order})`);

	/* glb at the default, its answer held back a while. */
	r.hold = true;
	await alice.click('#meshbtn');
	const asked = await until(alice, 'the page meshing', () => {
		const m = window.blobcast.mesh();
		return m.pending && document.getElementById('meshbtn')
			.textContent === 'meshing…' ? { ...m, message: document
				.getElementById('message').textContent } : null;
	});
	assert.deepEqual({ ...asked.pending, seq: 0 }, { seq: 0, format: 'glb',
		resolution: 128, raw: false });
	assert.equal(asked.message, 'meshing on the daemon (glb, 128)...');
	await alice.click('#meshbtn');
	await until(alice, 'a second click refused', () => document
		.getElementById('message').textContent === 'the mesh (glb, 128) ' +
		'is still being made on the daemon: one at a time');
	/* The daemon's answer arrives (held here); `blobcast mesh` of the
	 * scene as it is now, that of the MESH. */
	await waitFor(alice, 'the daemon\'s MESH_DATA', () =>
		r.held.length === 1);
	const glbCli = await cliMesh('cli.glb');
	/* Another edit and a turn of the camera: applied and drawn while
	 * the mesh is held (the answers to later requests first), and by
	 * then everything the page sent before them has reached the
	 * route. */
	await alice.evaluate(([id, t]) => window.blobcast.moveTo(id, t),
		[shape.id, shape.translate]);
	await alice.evaluate(() => window.blobcast.orbit(40, 0));
	await until(alice, 'a frame of the turned camera', () => {
		const s = window.blobcast.state();
		return s.lastFrame?.camera_seq >= window.blobcast.cameraSeq() &&
			window.blobcast.cameraSeq() > 0;
	});
	const now = (await alice.evaluate(() => window.blobcast.state()))
		.order;
	assert.notEqual(now, order, 'the edit applied');
	assert.equal(r.meshes.length, 1, 'one MESH sent');
	assert.equal(r.meshes[0].seq, asked.pending.seq);
	assert.deepEqual([r.meshes[0].format, r.meshes[0].options,
		r.meshes[0].resolution], [P.MESH_FORMAT.GLB, 0, 128]);
	assert.equal(r.held.length, 1);
	assert.ok((await mesh(alice)).pending, 'still waiting for it');
	assert.equal(alice.downloads.length, 0);
	step('meshing: the page said so, refused a second click; while the ' +
		`daemon's MESH_DATA was held it applied edit ${now} and drew a ` +
		'later camera');
	const glb = await downloaded(alice, r.release());
	const said = await message(alice);
	/* Named for the order the mesh is of, not the page's. */
	assert.equal(glb.name, `blobcast-default-${order}.glb`);
	assert.equal(glb.bytes.subarray(0, 4).toString('latin1'), 'glTF');
	assert.ok(glb.bytes.equals(glbCli), `the page's glb (${glb.bytes
		.length} bytes) is \`blobcast mesh\`'s (${glbCli.length})`);
	const last = (await mesh(alice)).last;
	assert.deepEqual({ name: last.name, format: last.format,
		resolution: last.resolution, raw: last.raw, order: last.order,
		bytes: last.bytes }, { name: glb.name, format: 'glb',
		resolution: 128, raw: false, order, bytes: glb.bytes.length });
	assert.ok(last.triangles > 0);
	assert.match(said, new RegExp(`^saved ` +
		`${glb.name.replace('.', '\\.')}: ${last.triangles} triangles, ` +
		`edit order ${order} \\(`));
	step(`${glb.name}: ${last.triangles} triangles, ${glb.bytes.length} ` +
		'bytes, equal to `blobcast mesh --session default --out X.glb` ' +
		`of edit ${order}`);
	/* The scene from here on: the edit moved the shape back. */
	const glbNow = await cliMesh('cli-now.glb');

	/* The other formats and options. */
	for (const [format, cells, raw, args] of [
		['obj', 48, false, ['--format', 'obj', '--resolution', '48']],
		['ply', 40, true, ['--format', 'ply', '--resolution', '40',
			'--raw']],
		['stl', 24, false, ['--format', 'stl', '--resolution', '24']],
	]) {
		await alice.selectOption('#meshformat', format);
		await alice.fill('#meshres', String(cells));
		await alice.setChecked('#meshraw', raw);
		const f = await downloaded(alice, alice.click('#meshbtn'));
		const c = await cliMesh(`cli-${cells}.${format}`, args);
		assert.equal(f.name, `blobcast-default-${now}.${format}`);
		assert.ok(f.bytes.equals(c), `${format} at ${cells}: the page's ` +
			`${f.bytes.length} bytes are \`blobcast mesh ${args.join(' ')}` +
			`\`'s ${c.length}`);
		const m = await mesh(alice);
		assert.deepEqual([m.last.format, m.last.resolution, m.last.raw],
			[format, cells, raw]);
		step(`${f.name} (${cells} cells${raw ? ', raw' : ''}): ` +
			`${m.last.triangles} triangles, equal to \`blobcast mesh ` +
			`${args.join(' ')}\``);
	}
	await alice.setChecked('#meshraw', false);
	await alice.selectOption('#meshformat', 'glb');

	/* Over the daemon's bound: its words, nothing downloaded. */
	const saved = alice.downloads.length;
	const sent = r.meshes.length;
	await alice.fill('#meshres', '600');
	await alice.click('#meshbtn');
	const refused = await until(alice, 'the daemon\'s ELIMIT', () => {
		const m = window.blobcast.mesh();
		return !m.pending && m.error ? { ...m.error, message: document
			.getElementById('message').textContent } : null;
	});
	assert.equal(refused.code, 'ELIMIT');
	assert.match(refused.text, /resolution 600: .* up to \d+ cells/);
	assert.equal(refused.message, `mesh (glb, 600) not made: ` +
		`${refused.text} (ELIMIT)`);
	assert.equal(r.meshes.length, sent + 1);
	assert.equal(r.meshes.at(-1).resolution, 600);
	assert.ok((await alice.getAttribute('#meshbtn', 'title')).endsWith(
		`\nlast: ${refused.message}`), 'the button keeps the words');
	step(`600 cells: "${refused.message}"`);
	/* 3 cells: refused here. */
	await alice.fill('#meshres', '3');
	await alice.click('#meshbtn');
	await until(alice, '3 cells refused in the page', () => document
		.getElementById('message').textContent.startsWith(
			'mesh resolution: a whole number of cells from 5 to '));
	/* A later request's answer: whatever the page sent before it has
	 * been seen, and nothing came of either. */
	await alice.evaluate(() => window.blobcast.orbit(-40, 0));
	await until(alice, 'a frame of the camera turned back', () => window
		.blobcast.state().lastFrame?.camera_seq >=
		window.blobcast.cameraSeq());
	assert.equal(r.meshes.length, sent + 1, 'no MESH for 3 cells');
	assert.equal(alice.downloads.length, saved, 'nothing downloaded');
	assert.equal((await mesh(alice)).pending, null);
	step('3 cells refused in the page, nothing sent; nothing downloaded');

	/* The connection dropped while the daemon meshes. */
	await alice.fill('#meshres', '');
	r.hold = true;
	await alice.click('#meshbtn');
	await waitFor(alice, 'the MESH sent', () => r.meshes.length ===
		sent + 2);
	assert.equal(r.meshes.at(-1).resolution, 128, 'an empty field: 128');
	await r.drop();
	const lost = await until(alice, 'the mesh forgotten', () => {
		const m = window.blobcast.mesh();
		return !m.pending && m.error?.code === 'lost' ? { ...m.error,
			message: document.getElementById('message').textContent }
			: null;
	});
	assert.equal(lost.text, 'dropped by the test');
	assert.equal(lost.message, 'mesh (glb, 128) not made: the ' +
		'connection was lost (dropped by the test); ask again once the ' +
		'page is back');
	await until(alice, 'alice back', () => window.blobcast.state()
		.connected && window.blobcast.mesh().granted &&
		!document.getElementById('meshbtn').disabled);
	const again = await downloaded(alice, alice.click('#meshbtn'));
	assert.ok(again.bytes.equals(glbNow), 'the CLI\'s glb after the ' +
		'rejoin');
	assert.equal(alice.downloads.length, saved + 1, 'one download: the ' +
		'dropped mesh never came');
	step('a dropped connection: the page forgot the mesh and said so; ' +
		'after the rejoin it meshed again');

	/* A viewer meshes too. */
	const { page: bob } = await openPage(stack, 'bob', 'viewer', false);
	assert.equal((await bob.evaluate(() => window.blobcast.state())).role,
		P.ROLE.VIEWER);
	const fromBob = await downloaded(bob, bob.click('#meshbtn'));
	assert.equal(fromBob.name, `blobcast-default-${now}.glb`);
	assert.ok(fromBob.bytes.equals(glbNow), 'bob\'s glb is the CLI\'s');
	step(`bob, a viewer, saved ${fromBob.name}, the CLI's bytes`);

	/* A daemon that grants every feature but MESH (an earlier
	 * blobcastd). */
	const dave = await browser.newPage({ viewport: { width: 980,
		height: 560 } });
	dave.on('pageerror', (e) => {
		console.error(`page dave: ${e.message}`);
		failed = true;
	});
	await dave.routeWebSocket(/.*/, (ws) => H.standInDaemon(ws, {
		features: () => P.FEATURE.ALL & ~P.FEATURE.MESH }));
	await dave.goto(`http://127.0.0.1:${stack.web.port}/?ws=` +
		'ws://127.0.0.1:9/&session=s&name=dave');
	const off = await until(dave, 'the mesh control off', () => {
		const b = document.getElementById('meshbtn');
		return window.blobcast.state().connected && b.disabled &&
			document.getElementById('meshformat').disabled ? b.title : '';
	});
	assert.match(off, /does not make meshes .*blobcast mesh --session/);
	step(`a daemon without MESH: the control is off ("${off}")`);
} catch (e) {
	failed = true;
	H.report(e);
} finally {
	rmSync(work, { recursive: true, force: true });
	await H.finish(browser, failed, watchdog);
}
