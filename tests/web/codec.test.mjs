/*
 * The browser codec (client/web/protocol.js) against the language-neutral
 * test vectors of protocol/vectors/, the same files the C codec runs:
 *  - valid entries decode to exactly the listed fields, and both the
 *    decoded message and one built from the listed fields encode back to
 *    the very same bytes;
 *  - invalid entries fail with exactly the listed error code after exactly
 *    the listed number of good messages, whether the bytes arrive at once,
 *    one at a time, or in the uneven pieces websockify delivers;
 *  - scene.json entries go through the scene scanner, and valid scenes
 *    survive parse -> encode unchanged.
 * Then the properties the page relies on: reassembly across arbitrary
 * WebSocket frame boundaries, sticky errors, the reader's memory ceiling,
 * the encoder refusing what the decoder refuses, edits applied to a
 * parsed scene, and node names (the scenes' names table and NAME
 * operations, every check on hand-made bytes in the decoder's order).
 * Run with: node --test tests/web/
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import * as P from '../../client/web/protocol.js';

const HERE = dirname(fileURLToPath(import.meta.url));
const VECTORS = join(HERE, '..', '..', 'protocol', 'vectors');

const load = (f) => JSON.parse(readFileSync(join(VECTORS, f), 'utf8'));
const unhex = (h) => Uint8Array.from(Buffer.from(h, 'hex'));
const fileOf = (name) => name.toLowerCase() + '.json';

/* JSON fields -> the codec's shapes: u64 travel as decimal strings in the
 * vectors and are BigInt here; byte ranges travel as hex. */
const U64 = new Set(['order', 'stamp', 'uptime_ms', 'frames', 'bytes',
	'target_order', 'last_edit_ms', 'view_bytes', 'view_cap',
	'session_render_us', 'tls_not_after_ms', 'time_ms', 'built_on',
	'delivery_bps', 'frames_spoiled', 'scene_nodes', 'scene_nodes_cap',
	'session_nodes']);
const BYTES = new Set(['scene', 'subtree', 'data', 'file']);

function fromJson(v, key) {
	if (Array.isArray(v)) {
		return v.map((x) => fromJson(x, null));
	}
	if (v && typeof v === 'object') {
		const o = {};
		for (const [k, x] of Object.entries(v)) {
			o[k] = fromJson(x, k);
		}
		return o;
	}
	if (U64.has(key) && typeof v === 'string') {
		return BigInt(v);
	}
	if (BYTES.has(key) && typeof v === 'string') {
		return unhex(v);
	}
	return v;
}

function readerOpts(e) {
	const r = e.reader ?? {};
	return { side: r.side ?? 'any', maxPayload: r.max_payload ?? 0,
		awaitHello: r.await_hello === true };
}

/* Feeds bytes in pieces of the given sizes (cycled), draining after each;
 * returns { code: null | 'ENAME', count }. */
function runStream(opts, bytes, pieces) {
	const r = new P.Reader(opts);
	let count = 0;
	try {
		let off = 0, i = 0;
		while (off < bytes.length) {
			const k = Math.min(pieces[i++ % pieces.length],
				bytes.length - off);
			r.feed(bytes.subarray(off, off + k));
			off += k;
			while (r.next()) {
				count++;
			}
		}
		r.eof();
		return { code: null, count };
	} catch (e) {
		assert.ok(e instanceof P.ProtoError, `not a ProtoError: ${e}`);
		assert.equal(r.err, e, 'the error is sticky on the reader');
		assert.ok(e.message.length > 0);
		assert.throws(() => r.next(), (again) => again === e);
		return { code: e.code, count };
	}
}

const typeNames = Object.keys(P.MSG);
let totals = { valid: 0, invalid: 0 };

for (const name of typeNames) {
	test(`vectors: ${name}`, () => {
		const doc = load(fileOf(name));
		const type = P.MSG[name];
		assert.equal(doc.type, name);
		assert.equal(doc.type_id, type);
		assert.ok(doc.valid.length >= 1);
		assert.ok(doc.invalid.length >= 5);
		for (const e of doc.valid) {
			const bytes = unhex(e.hex);
			const want = { type, ...fromJson(e.fields, null) };
			const r = new P.Reader();
			r.feed(bytes);
			const got = r.next();
			assert.deepEqual(got, want, `${name}/${e.name}: fields`);
			assert.equal(r.next(), null);
			r.eof();
			assert.deepEqual(P.encode(got), bytes,
				`${name}/${e.name}: decoded -> bytes`);
			assert.deepEqual(P.encode(want), bytes,
				`${name}/${e.name}: fields -> bytes`);
			assert.deepEqual(runStream({}, bytes, [1]),
				{ code: null, count: 1 }, `${name}/${e.name}: bytewise`);
			const alone = P.decodePayload(type, want.flags, want.seq,
				bytes.subarray(P.HEADER_SIZE));
			assert.deepEqual(alone, want, `${name}/${e.name}: payload`);
			totals.valid++;
		}
		for (const e of doc.invalid) {
			checkInvalid(`${name}/${e.name}`, e);
		}
	});
}

function checkInvalid(label, e) {
	const bytes = unhex(e.hex);
	const want = { code: e.error ?? null, count: e.messages ?? 0 };
	for (const pieces of [[bytes.length || 1], [1], [7, 3, 16]]) {
		assert.deepEqual(runStream(readerOpts(e), bytes, pieces), want,
			`${label} (pieces ${pieces})`);
	}
	totals.invalid++;
}

test('vectors: framing', () => {
	const doc = load('framing.json');
	assert.ok(doc.invalid.length >= 20);
	for (const e of doc.invalid) {
		checkInvalid(`framing/${e.name}`, e);
	}
});

test('vectors: scene encoding', () => {
	const doc = load('scene.json');
	for (const e of doc.valid) {
		const bytes = unhex(e.hex);
		assert.deepEqual(P.scanScene(bytes), e.fields, e.name);
		/* parse -> encode gives the same bytes back */
		assert.deepEqual(P.encodeScene(P.parseScene(bytes)), bytes, e.name);
	}
	for (const e of doc.invalid) {
		const bytes = unhex(e.hex);
		assert.throws(() => P.scanScene(bytes),
			(err) => err instanceof P.ProtoError && err.code === e.error,
			`scene/${e.name}: want ${e.error}`);
		assert.throws(() => P.parseScene(bytes),
			(err) => err.code === e.error, `parse ${e.name}`);
	}
});

test('binary scene file: CRC-32 and header as blobtree writes them', () => {
	/* The CRC-32 check value of the catalogue (zlib, gzip, PNG). */
	assert.equal(P.crc32(new TextEncoder().encode('123456789')),
		0xcbf43926);
	assert.equal(P.crc32(new Uint8Array(0)), 0);
	for (const e of load('scene.json').valid) {
		const bytes = unhex(e.hex);
		const file = P.encodeSceneFile(P.parseScene(bytes));
		const dv = new DataView(file.buffer);
		assert.deepEqual([...file.subarray(0, 4)], [0x42, 0x43, 0x53, 0x31]);
		assert.equal(dv.getUint32(4, true), bytes.length, e.name);
		assert.equal(dv.getUint32(8, true), P.crc32(bytes), e.name);
		assert.deepEqual(file.subarray(12), bytes, e.name);
	}
});

test('vectors: no unknown files, every type covered', () => {
	const files = readdirSync(VECTORS).filter((f) => f.endsWith('.json'));
	const known = new Set([...typeNames.map(fileOf), 'framing.json',
		'scene.json']);
	for (const f of files) {
		assert.ok(known.has(f), `unknown vector file ${f}`);
	}
	assert.equal(files.length, typeNames.length + 2);
	assert.equal(typeNames.length, 38);
});

/* ---- Properties the page relies on -------------------------------------- */

/* Every valid message of every file, back to back: what a long session
 * looks like on the wire. */
function allValid() {
	const msgs = [];
	for (const name of typeNames) {
		for (const e of load(fileOf(name)).valid) {
			msgs.push({ bytes: unhex(e.hex), want: { type: P.MSG[name],
				...fromJson(e.fields, null) } });
		}
	}
	return msgs;
}

/* A small deterministic generator (xorshift32) so that failures repeat. */
function rng(seed) {
	let s = seed >>> 0 || 1;
	return () => {
		s ^= s << 13;
		s >>>= 0;
		s ^= s >>> 17;
		s ^= s << 5;
		s >>>= 0;
		return s;
	};
}

test('reassembly: any split of a stream gives the same messages', () => {
	const msgs = allValid();
	const total = msgs.reduce((n, m) => n + m.bytes.length, 0);
	const stream = new Uint8Array(total);
	let off = 0;
	for (const m of msgs) {
		stream.set(m.bytes, off);
		off += m.bytes.length;
	}
	assert.ok(msgs.length > 40);
	const next = rng(12345);
	for (let round = 0; round < 20; round++) {
		const r = new P.Reader();
		const got = [];
		let at = 0;
		while (at < stream.length) {
			/* Pieces from 1 byte to 8 KiB, the way websockify's frames
			 * cut the TCP stream. */
			const k = Math.min(1 + (next() % (round < 10 ? 64 : 8192)),
				stream.length - at);
			/* Feed a copy into a buffer the caller then scribbles on:
			 * decoded messages must not alias it. */
			const piece = stream.slice(at, at + k);
			r.feed(piece);
			piece.fill(0xee);
			at += k;
			for (let m; (m = r.next());) {
				got.push(m);
			}
		}
		r.eof();
		assert.equal(got.length, msgs.length);
		got.forEach((m, i) => assert.deepEqual(m, msgs[i].want));
		assert.equal(r.pending, 0);
	}
});

test('reader: feeding past one message plus the slack is ELIMIT', () => {
	const r = new P.Reader({ maxPayload: 65536 });
	const ceiling = P.HEADER_SIZE + 65536 + P.LIMITS.READ_SLACK;
	/* Valid PINGs, never drained. */
	const ping = P.encode({ type: P.MSG.PING, seq: 1, stamp: 7n });
	const chunk = new Uint8Array(Math.floor(ceiling / ping.length) *
		ping.length);
	for (let i = 0; i < chunk.length; i += ping.length) {
		chunk.set(ping, i);
	}
	r.feed(chunk);
	assert.throws(() => r.feed(new Uint8Array(ping.length)),
		(e) => e.code === 'ELIMIT');
	assert.throws(() => r.next(), (e) => e.code === 'ELIMIT');
});

test('reader: side rules and the pre-HELLO stage', () => {
	const frame = unhex(load('frame.json').valid[0].hex);
	const hello = unhex(load('hello.json').valid[0].hex);
	const client = new P.Reader({ side: 'client' });
	client.feed(frame);
	assert.equal(client.next().type, P.MSG.FRAME);
	const server = new P.Reader({ side: 'server', awaitHello: true });
	server.feed(hello);
	assert.equal(server.next().type, P.MSG.HELLO);
	server.helloDone();
	const cam = P.encode({ type: P.MSG.CAMERA, seq: 2, eye: [0, 0, 5],
		target: [0, 0, 0], up: [0, 1, 0], fov_y_deg: 40 });
	server.feed(cam);
	assert.equal(server.next().type, P.MSG.CAMERA);
	assert.throws(() => new P.Reader({ side: 'peer' }),
		(e) => e.code === 'EINVAL');
});

test('reader: a client lowers its payload limit to its frame limit', () => {
	const r = new P.Reader({ side: 'client', maxPayload: 65536 });
	const rects = [{ x: 0, y: 0, w: 1, h: 1, data: new Uint8Array(70000) }];
	const big = P.encode({ type: P.MSG.FRAME, flags: P.FLAG.STILL, seq: 0,
		frame_no: 1, order: 1n, camera_seq: 0, encoding: P.ENC.JPEG,
		width: 1, height: 1, image_width: 1, image_height: 1, rects });
	assert.throws(() => { r.feed(big.subarray(0, 12)); r.next(); },
		(e) => e.code === 'EPROTO_LENGTH');
	const ok = new P.Reader({ side: 'client' });
	ok.feed(big);
	assert.equal(ok.next().rects[0].data.length, 70000);
});

test('encoder refuses what the decoder refuses', () => {
	const cam = { type: P.MSG.CAMERA, seq: 1, eye: [0, 0, 5],
		target: [0, 0, 0], up: [0, 1, 0], fov_y_deg: 40 };
	const cases = [
		[{ ...cam, eye: [NaN, 0, 5] }, 'ENONFINITE'],
		[{ ...cam, eye: [2e6, 0, 5] }, 'ERANGE'],
		[{ ...cam, fov_y_deg: 180 }, 'ERANGE'],
		[{ ...cam, eye: [0, 5] }, 'EPROTO_COUNT'],
		[{ ...cam, flags: 2 }, 'EPROTO_FLAGS'],
		[{ ...cam, type: 39 }, 'EPROTO_TYPE'],
		[{ ...cam, type: 0 }, 'EPROTO_TYPE'],
		[{ ...cam, seq: -1 }, 'ERANGE'],
		[{ type: P.MSG.SESSION_JOIN, role: 3, name: 'x' }, 'EENUM'],
		[{ type: P.MSG.SESSION_JOIN, role: 1, name: '' }, 'EPROTO_LENGTH'],
		[{ type: P.MSG.SESSION_JOIN, role: 1, name: 'n'.repeat(65) },
			'EPROTO_LENGTH'],
		[{ type: P.MSG.SESSION_JOIN, role: 1, name: 'a\u0000b' },
			'ESTRING'],
		[{ type: P.MSG.EDIT, ops: [] }, 'EPROTO_COUNT'],
		[{ type: P.MSG.EDIT, ops: [{ kind: P.EDIT.SET, node: 0,
			fields: [{ field: 1, values: [0, 0, 0] }] }] }, 'ERANGE'],
		[{ type: P.MSG.EDIT, ops: [{ kind: P.EDIT.SET, node: 4,
			fields: [{ field: 16, values: [1, 2, 3, 4, 5] }] }] },
			'EPROTO_COUNT'],
		[{ type: P.MSG.EDIT, ops: [{ kind: P.EDIT.SET, node: 4,
			fields: [{ field: 1, values: [0, 0, 0] },
				{ field: 1, values: [0, 0, 0] }] }] }, 'EPARSE'],
		[{ type: P.MSG.EDIT, ops: [{ kind: 9, node: 4 }] }, 'EENUM'],
		[{ type: P.MSG.VIEW, width: 0, height: 1, encoding: 1,
			quality_interactive: 1, quality_still: 1, downscale: 1 },
			'ERANGE'],
		[{ type: P.MSG.PICK, x: 70000, y: 0 }, 'ERANGE'],
	];
	for (const [m, code] of cases) {
		assert.throws(() => P.encode(m), (e) => e instanceof P.ProtoError &&
			e.code === code, `${JSON.stringify(m, (k, v) =>
			typeof v === 'number' && !Number.isFinite(v) ? String(v) : v)}` +
			` -> ${code}`);
	}
	/* The same message without the fault encodes and decodes back. */
	const r = new P.Reader();
	r.feed(P.encode(cam));
	assert.deepEqual(r.next(), { ...cam, flags: 0 });
});

test('frame levels: helpers, every size, and the refusals', () => {
	assert.equal(P.FLAG.LEVEL_MASK, P.MAX_LEVEL << P.LEVEL_SHIFT);
	assert.equal(P.frameLevel(0x0014), 2);
	assert.equal(P.frameLevel(0xffff), 3);
	assert.equal(P.flagsWithLevel(P.FLAG.INCOMPLETE, 2), 0x0014);
	assert.equal(P.flagsWithLevel(0x001f, 0), 0x0007);
	assert.deepEqual([P.levelDim(1281, 1), P.levelDim(7, 2),
		P.levelDim(1, 3), P.levelDim(8191, 3)], [641, 2, 1, 1024]);
	const frame = (level, w, h, iw, ih, rects) => ({ type: P.MSG.FRAME,
		flags: P.flagsWithLevel(0, level), seq: 0, frame_no: 1, order: 2n,
		camera_seq: 3, encoding: P.ENC.RAW, width: w, height: h,
		image_width: iw, image_height: ih, rects: rects ?? [{ x: 0, y: 0,
			w: iw, h: ih, data: new Uint8Array(iw * ih * 4) }] });
	const refused = (m, code) => assert.throws(() => P.encode(m),
		(e) => e.code === code, `${m.width}x${m.height} level ` +
		`${P.frameLevel(m.flags)} as ${m.image_width}x${m.image_height}`);
	/* The one image size round-trips with its level; a pixel more or
	 * less either way is ERANGE. */
	for (let level = 1; level <= P.MAX_LEVEL; level++) {
		for (let w = 1; w < 20; w++) {
			for (let h = 1; h < 20; h++) {
				const iw = P.levelDim(w, level);
				const ih = P.levelDim(h, level);
				const r = new P.Reader({ side: 'client' });
				r.feed(P.encode(frame(level, w, h, iw, ih)));
				const m = r.next();
				assert.equal(P.frameLevel(m.flags), level);
				assert.deepEqual([m.image_width, m.image_height],
					[iw, ih]);
				for (const [dw, dh] of [[1, 0], [-1, 0], [0, 1], [0, -1]]) {
					if (iw + dw > 0 && ih + dh > 0) {
						refused(frame(level, w, h, iw + dw, ih + dh),
							'ERANGE');
					}
				}
			}
		}
	}
	const lv1 = frame(1, 20, 20, 10, 10);
	refused({ ...lv1, flags: lv1.flags | P.FLAG.STILL }, 'EPROTO_FLAGS');
	refused({ ...lv1, flags: lv1.flags | P.FLAG.SNAPSHOT }, 'EPROTO_FLAGS');
	const half = { x: 0, y: 0, w: 10, h: 5, data: new Uint8Array(200) };
	const two = [half, { ...half, y: 5 }];
	refused(frame(1, 20, 20, 10, 10, two), 'EPROTO_COUNT');
	/* The same rectangles are damage at level 0. */
	assert.ok(P.encode(frame(0, 10, 10, 10, 10, two)).length > 0);
	refused(frame(1, 20, 20, 10, 10, [{ ...half, h: 10, w: 9,
		data: new Uint8Array(360) }]), 'ERANGE');
	/* The level bits belong to FRAME only. */
	refused({ type: P.MSG.CAMERA, flags: 0x0008, eye: [0, 0, 5],
		target: [0, 0, 0], up: [0, 1, 0], fov_y_deg: 40 }, 'EPROTO_FLAGS');
	/* The reader refuses level with STILL on the header's byte 7. */
	const r = new P.Reader({ side: 'client' });
	r.feed(Uint8Array.of(0x42, 0x43, 0x53, 0x54, 1, 17, 0x09, 0));
	assert.throws(() => r.next(), (e) => e.code === 'EPROTO_FLAGS');
});

test('frame levels: what the page shows and how it scales', () => {
	const m = { flags: 0, width: 7, height: 5, image_width: 7,
		image_height: 5 };
	assert.equal(P.frameRefining(0), false);
	assert.equal(P.frameRefining(P.FLAG.STILL), false);
	assert.equal(P.frameRefining(P.FLAG.INCOMPLETE), true);
	assert.equal(P.frameRefining(P.flagsWithLevel(0, 1)), true);
	assert.deepEqual(P.frameScale(m), [1, 1]);
	/* Level 2 of a 7x5 view is 2x2, each pixel a 4x4 block from the
	 * top-left, not the image stretched to 3.5 x 2.5. */
	assert.deepEqual(P.frameScale({ ...m, flags: P.flagsWithLevel(0, 2),
		image_width: 2, image_height: 2 }), [4, 4]);
	/* A level-0 image smaller than the view is stretched over it. */
	assert.deepEqual(P.frameScale({ ...m, width: 1280, height: 720,
		image_width: 640, image_height: 240 }), [2, 3]);
});

test('error names and numbers match error.h', () => {
	assert.equal(P.ERR.ENOMEM, 2);
	/* Error 0 is NONE: OK is message type 6 (PROTOCOL.md 10). */
	assert.equal(P.ERR.NONE, 0);
	assert.equal(P.errName(0), 'NONE');
	assert.equal(P.ERR.OK, undefined);
	assert.equal(P.MSG.OK, 6);
	assert.equal(P.ERR.EPROTO_MAGIC, 12);
	assert.equal(P.ERR.ENOSESSION, 24);
	assert.equal(P.ERR.ECLOSED, 33);
	assert.equal(P.errName(-25), 'ENONODE');
	assert.equal(P.errName(99), 'UNKNOWN');
	assert.equal(P.errText(31), 'string not valid UTF-8 or contains NUL');
	assert.equal(new P.ProtoError('EDEPTH', 'x').errno, 21);
	assert.equal(P.typeName(17), 'FRAME');
	assert.equal(P.typeName(36), 'FRAME_ACK');
	assert.equal(P.typeName(38), 'MESH_DATA');
	assert.equal(P.typeName(39), null);
});

test('utf8Check: the strict rules of the C codec', () => {
	const enc = new TextEncoder();
	assert.equal(P.utf8Check(enc.encode('Zoë 🌐')), 9);
	assert.equal(P.utf8Check(Uint8Array.of(0x61, 0x00)), 1);
	assert.equal(P.utf8Check(Uint8Array.of(0xc0, 0xaf)), 0);
	assert.equal(P.utf8Check(Uint8Array.of(0xed, 0xa0, 0x80)), 0);
	assert.equal(P.utf8Check(Uint8Array.of(0xf4, 0x90, 0x80, 0x80)), 0);
	assert.equal(P.utf8Check(Uint8Array.of(0x61, 0x62, 0xe2, 0x82)), 2);
	assert.equal(P.utf8Check(Uint8Array.of(0xef, 0xbf, 0xbf)), 3);
});

/* ---- Scenes and edits ------------------------------------------------------ */

/* The vectors' three-node scene: a smooth union (id 1) of a sphere (2)
 * and a box (3). */
function smallScene() {
	return P.parseScene(unhex(load('scene.json').valid[1].hex));
}

test('parseScene: tree shape, camera, ids', () => {
	const s = smallScene();
	assert.deepEqual(s.camera, { eye: [0, 1, 6], target: [0, 0, 0],
		up: [0, 1, 0], fov_y_deg: 45 });
	assert.equal(s.root.isOp, true);
	assert.equal(s.root.kind, 4);
	assert.deepEqual(s.root.children.map((c) => c.id), [2, 3]);
	assert.equal(s.byId.get(2).parent, s.root);
	assert.deepEqual(s.byId.get(2).color, [1, 0.5, 0.25]);
	assert.equal(s.byId.get(3).color, null);
	assert.deepEqual([...s.byId.keys()].sort(), [1, 2, 3]);
	/* The deepest valid comb of the vectors keeps its nesting: depth
	 * counts the nodes on the path, the primitive at its end included. */
	const e = load('scene.json').valid.filter((v) => v.fields.depth)
		.reduce((a, b) => (b.fields.depth > a.fields.depth ? b : a));
	const deep = P.parseScene(unhex(e.hex));
	let d = 1;
	for (let n = deep.root; n.isOp; n = n.children[0]) {
		d++;
	}
	assert.ok(e.fields.depth > 1000);
	assert.ok(e.fields.depth <= P.LIMITS.SCENE_MAX_DEPTH);
	assert.equal(d, e.fields.depth);
});

test('applyOps: set, insert, remove, replace follow the server', () => {
	const s = smallScene();
	const layout = (kind) => (kind === 1 ? [{ offset: 0, count: 1 }]
		: kind === 2 ? [{ offset: 0, count: 3 }, { offset: 3, count: 1 }]
			: null);
	const sub = P.encodeScene({ root: { isOp: false, kind: 1, id: 9,
		translate: [1, 2, 3], rotate: [0, 0, 0, 1], color: null,
		params: [0.5] } });
	P.applyOps(s, [
		{ kind: P.EDIT.SET, node: 2, fields: [
			{ field: P.FIELD.TRANSLATE, values: [0.25, -1.5, 3] },
			{ field: P.FIELD.PARAM0, values: [0.75] }] },
		{ kind: P.EDIT.SET, node: 3, fields: [
			{ field: P.FIELD.PARAM0, values: [1, 2, 3] },
			{ field: P.FIELD.PARAM0 + 1, values: [0.2] }] },
		{ kind: P.EDIT.SET, node: 1, fields: [
			{ field: P.FIELD.BLEND, values: [0.3] },
			{ field: P.FIELD.OP_KIND, values: [5] }] },
		{ kind: P.EDIT.INSERT, parent: 1, position: 1, subtree: sub },
	], layout);
	assert.deepEqual(s.byId.get(2).translate, [0.25, -1.5, 3]);
	assert.deepEqual(s.byId.get(2).params, [0.75]);
	assert.equal(Math.fround(s.byId.get(3).params[3]), Math.fround(0.2));
	assert.deepEqual(s.byId.get(3).params.slice(0, 3), [1, 2, 3]);
	assert.equal(s.root.blend, 0.3);
	assert.equal(s.root.kind, 5);
	assert.deepEqual(s.root.children.map((c) => c.id), [2, 9, 3]);
	assert.equal(s.byId.get(9).parent, s.root);

	/* An unknown layout marks the node stale instead of guessing. */
	P.applyOps(s, [{ kind: P.EDIT.SET, node: 2, fields: [
		{ field: P.FIELD.PARAM0 + 5, values: [1] }] }], layout);
	assert.equal(s.byId.get(2).stale, true);

	P.applyOps(s, [{ kind: P.EDIT.REMOVE, node: 9 }]);
	assert.equal(s.byId.has(9), false);
	assert.deepEqual(s.root.children.map((c) => c.id), [2, 3]);

	/* Replace may reuse the old id. */
	const sub3 = P.encodeScene({ root: { isOp: false, kind: 1, id: 3,
		translate: [0, 0, 0], rotate: [0, 0, 0, 1], color: [1, 1, 1],
		params: [2] } });
	P.applyOps(s, [{ kind: P.EDIT.REPLACE, node: 3, subtree: sub3 }]);
	assert.deepEqual(s.byId.get(3).params, [2]);
	assert.equal(s.root.children[1], s.byId.get(3));
	assert.throws(() => P.applyOps(s, [{ kind: P.EDIT.REMOVE, node: 77 }]),
		(e) => e.code === 'ENONODE');
	/* The edited tree still encodes to a valid scene. */
	const info = P.scanScene(P.encodeScene(s));
	assert.deepEqual(info, { has_camera: true, nodes: 3, prims: 2, ops: 1,
		depth: 2 });
});

test('parseScene: shared identity rotations, exact bytes back', () => {
	/* Primitives without a rotation share one frozen [0, 0, 0, 1] (a
	 * million-sphere mirror kept a copy each); a -0 in it, or any other
	 * rotation, gets its own array, and every scene encodes back to its
	 * bytes. An edit of one shared rotation moves no other primitive. */
	const q = Math.SQRT1_2;
	const prim = (id, rotate) => ({ isOp: false, kind: 1, id,
		translate: [id, 0, 0], rotate, color: null, params: [0.5] });
	const bytes = P.encodeScene({ root: { isOp: true, kind: 1, id: 1,
		blend: 0, range: 0, children: [prim(2, [0, 0, 0, 1]),
			prim(3, [0, 0, 0, 1]), prim(4, [-0, 0, 0, 1]),
			prim(5, [0, q, 0, q])] } });
	const s = P.parseScene(bytes);
	const r = (id) => s.byId.get(id).rotate;
	assert.equal(r(2), r(3));
	assert.equal(Object.isFrozen(r(2)), true);
	assert.notEqual(r(4), r(2));
	assert.equal(Object.is(r(4)[0], -0), true);
	assert.deepEqual(r(5), [0, Math.fround(q), 0, Math.fround(q)]);
	assert.deepEqual(P.encodeScene(s), bytes);
	P.applyOps(s, [{ kind: P.EDIT.SET, node: 2, fields: [
		{ field: P.FIELD.ROTATE, values: [0, 0, q, q] }] }]);
	assert.deepEqual(r(2), [0, 0, q, q]);
	assert.deepEqual(r(3), [0, 0, 0, 1]);
	/* Floats come in arrays of their own length. */
	assert.equal(s.byId.get(2).translate.length, 3);
	assert.equal(s.byId.get(2).params.length, 1);
	assert.equal(s.root.children.length, 4);
});

test('applyOps: a REMOVE that leaves an operator one child collapses it', () => {
	/* union 1 {sphere 100, sphere 101, union 5 {sphere 6, sphere 7}}:
	 * removing 6 leaves union 5 one child, which takes its place, as
	 * blobtree's bc_tree_remove does (the server's scene). */
	const sph = (id) => ({ isOp: false, kind: 1, id, translate: [0, 0, 0],
		rotate: [0, 0, 0, 1], color: null, params: [0.5] });
	const un = (id, children) => ({ isOp: true, kind: 1, id, blend: 0,
		range: 0, children });
	const s = P.parseScene(P.encodeScene({ root: un(1, [sph(100), sph(101),
		un(5, [sph(6), sph(7)])]) }));
	P.applyOps(s, [{ kind: P.EDIT.REMOVE, node: 6 }]);
	assert.equal(s.byId.has(5), false);
	assert.equal(s.byId.has(6), false);
	assert.deepEqual(s.root.children.map((c) => c.id), [100, 101, 7]);
	assert.equal(s.byId.get(7).parent, s.root);
	/* Down to the root: removing 100 then 101 leaves 7 the root. */
	P.applyOps(s, [{ kind: P.EDIT.REMOVE, node: 100 },
		{ kind: P.EDIT.REMOVE, node: 101 }]);
	assert.equal(s.root, s.byId.get(7));
	assert.equal(s.root.parent, null);
	assert.equal(s.byId.has(1), false);
	assert.deepEqual(P.scanScene(P.encodeScene(s)), { has_camera: false,
		nodes: 1, prims: 1, ops: 0, depth: 1 });
});

/* ---- Names (PROTOCOL.md 4.1, 8, 9) ---------------------------------------- */

/* Little-endian pieces for hand-made bytes. */
const u8b = (v) => Uint8Array.of(v);
const u16b = (v) => Uint8Array.of(v & 0xff, v >> 8);
const u32b = (v) => { const b = new Uint8Array(4);
	new DataView(b.buffer).setUint32(0, v, true); return b; };
const cat = (...parts) => Uint8Array.from(parts.flatMap((p) => [...p]));
const utf8 = (t) => new TextEncoder().encode(t);
/* A sphere of radius 1 with id id: tag, id, translate, rotate, no colour,
 * one parameter. */
const sphereB = (id) => cat(u8b(1), u32b(id), new Uint8Array(12),
	new Uint8Array(new Float32Array([0, 0, 0, 1]).buffer), u8b(0), u8b(1),
	new Uint8Array(new Float32Array([1]).buffer));
const unionB = (id, n) => cat(u8b(0x81), u32b(id), new Uint8Array(8),
	u32b(n));
/* union 1 { sphere 2, sphere 3 } with flags and what follows the tree. */
const named = (flags, ...table) => cat(u8b(flags), u32b(3), unionB(1, 2),
	sphereB(2), sphereB(3), ...table);
const entry = (id, name) => { const b = typeof name === 'string'
	? utf8(name) : name; return cat(u32b(id), u16b(b.length), b); };

test('FEATURE.NAMES: bit 6, in ALL, and the page announces it', () => {
	assert.equal(P.FEATURE.NAMES, 0x40);
	assert.equal(P.FEATURE.ALL, 0x7ff);
	assert.equal(P.EDIT.NAME, 5);
	assert.deepEqual(P.SCENE_FLAG, { CAMERA: 1, NAMES: 2, ALL: 3 });
	const src = readFileSync(join(HERE, '..', '..', 'client', 'web',
		'app.js'), 'utf8');
	assert.match(src, /features: P\.FEATURE\.ALL/);
	/* A WELCOME granting NAMES decodes; bit 11 is still undefined. */
	const welcome = { type: P.MSG.WELCOME, version: 1, connection_id: 1,
		max_payload: 1 << 20, max_frame_bytes: 1 << 20, max_nodes: 100,
		max_dim: 4096, max_members: 8, max_edit_ops: 100, server_id: 'x',
		features: P.FEATURE.NAMES | P.FEATURE.HISTORY };
	const r = new P.Reader({ side: 'client' });
	r.feed(P.encode(welcome));
	assert.equal(r.next().features, 0x60);
	assert.throws(() => P.encode({ ...welcome, features: 0x800 }),
		(e) => e.code === 'EPROTO_FLAGS');
});

test('scene names: the table decodes, attaches and encodes back', () => {
	const bytes = named(2, u32b(2), entry(1, 'body'), entry(3,
		'wheel 🛞'));
	assert.deepEqual(P.scanScene(bytes), { has_camera: false, nodes: 3,
		prims: 2, ops: 1, depth: 2, names: 2 });
	const s = P.parseScene(bytes);
	assert.equal(s.root.name, 'body');
	assert.equal(s.byId.get(2).name, undefined);
	assert.equal(s.byId.get(3).name, 'wheel 🛞');
	assert.deepEqual(P.encodeScene(s), bytes);
	/* Without names: flags 0, no table, the tree's bytes as they are. */
	delete s.root.name;
	delete s.byId.get(3).name;
	assert.deepEqual(P.encodeScene(s), named(0));
	assert.equal(P.scanScene(named(0)).names, undefined);
	/* With a camera (bit 0) too; the longest name, 64 bytes of
	 * two-byte characters; every node named. */
	const cam = new Uint8Array(new Float32Array([0, 1, 6, 0, 0, 0, 0, 1,
		0, 45]).buffer);
	const long = 'é'.repeat(32);
	const both = cat(u8b(3), cam, u32b(3), unionB(1, 2), sphereB(2),
		sphereB(3), u32b(3), entry(1, 'a'), entry(2, long), entry(3, 'c'));
	const t = P.parseScene(both);
	assert.equal(t.byId.get(2).name, long);
	assert.equal(P.scanScene(both).has_camera, true);
	assert.deepEqual(P.encodeScene(t), both);
	/* The encoder sorts by id, whatever the tree's order. */
	const u = P.parseScene(named(0));
	u.byId.get(3).name = 'z';
	u.byId.get(2).name = 'y';
	assert.deepEqual(P.encodeScene(u), named(2, u32b(2), entry(2, 'y'),
		entry(3, 'z')));
});

test('scene names: every check, in the decoder\'s order', () => {
	const bad = (label, bytes, code, parseCode = code) => {
		assert.throws(() => P.scanScene(bytes), (e) => e instanceof
			P.ProtoError && e.code === code, `scan: ${label}: want ${code}`);
		assert.throws(() => P.parseScene(bytes), (e) => e.code ===
			parseCode, `parse: ${label}: want ${parseCode}`);
	};
	bad('flags bit 2', named(4), 'EPROTO_FLAGS');
	bad('flags bit 7 with bit 1', named(0x82, u32b(1), entry(1, 'a')),
		'EPROTO_FLAGS');
	/* Check 5 comes before the table. */
	bad('an operator missing a child, then a bad table',
		cat(u8b(2), u32b(2), unionB(1, 2), sphereB(2), u32b(0)),
		'EPROTO_COUNT');
	bad('bit 1 without a table', named(2), 'EPROTO_TRUNCATED');
	bad('name_count cut short', named(2, u16b(1)), 'EPROTO_TRUNCATED');
	bad('name_count 0', named(2, u32b(0)), 'EPROTO_COUNT');
	bad('name_count above node_count', named(2, u32b(4), entry(1, 'a'),
		entry(2, 'b'), entry(3, 'c'), entry(4, 'd')), 'EPROTO_COUNT');
	bad('name_count above bytes left / 7', named(2, u32b(2),
		entry(1, 'abcdef')), 'EPROTO_COUNT');
	/* The second entry has its id and no length. */
	bad('entry cut inside its length', named(2, u32b(2),
		entry(1, 'abcdefgh'), u32b(2), u8b(1)), 'EPROTO_TRUNCATED');
	/* Id and length are read before the id is judged. */
	bad('id 0 without its length', named(2, u32b(2),
		entry(1, 'abcdefgh'), u32b(0)), 'EPROTO_TRUNCATED');
	bad('id 0', named(2, u32b(1), entry(0, 'a')), 'ERANGE');
	bad('the same id twice', named(2, u32b(2), entry(2, 'a'),
		entry(2, 'b')), 'EDUPID');
	bad('ids going down', named(2, u32b(2), entry(3, 'a'),
		entry(2, 'b')), 'ERANGE');
	/* The id is judged before the name's length. */
	bad('a repeated id with an empty name', named(2, u32b(2),
		entry(1, 'abc'), entry(1, '')), 'EDUPID');
	bad('an empty name', named(2, u32b(1), entry(1, ''), u8b(0)),
		'EPROTO_LENGTH');
	bad('a 65-byte name', named(2, u32b(1), entry(1, 'x'.repeat(65))),
		'EPROTO_LENGTH');
	bad('name bytes cut short', named(2, u32b(1), u32b(1), u16b(10),
		utf8('abcde')), 'EPROTO_TRUNCATED');
	bad('an overlong UTF-8 form', named(2, u32b(1), entry(1,
		Uint8Array.of(0x61, 0xc0, 0xaf))), 'ESTRING');
	bad('a NUL byte', named(2, u32b(1), entry(1, Uint8Array.of(0x61, 0,
		0x62))), 'ESTRING');
	bad('a surrogate', named(2, u32b(1), entry(1, Uint8Array.of(0xed,
		0xa0, 0x80))), 'ESTRING');
	bad('a byte after the table', cat(named(2, u32b(1), entry(1, 'a')),
		u8b(0)), 'EPROTO_TRAILING');
	/* The table is checked before trailing bytes. */
	bad('a bad id, then trailing bytes', cat(named(2, u32b(1),
		entry(0, 'a')), u8b(0)), 'ERANGE');
	/* Meaning (check 8), parseScene's: a name for a node the scene
	 * lacks, or for a node of id 0 (numbered by the server). */
	const ghost = named(2, u32b(1), entry(9, 'ghost'));
	assert.equal(P.scanScene(ghost).names, 1);
	assert.throws(() => P.parseScene(ghost), (e) => e.code === 'ENONODE');
	const zero = cat(u8b(2), u32b(1), sphereB(0), u32b(1), entry(5, 'a'));
	assert.equal(P.scanScene(zero).names, 1);
	assert.throws(() => P.parseScene(zero), (e) => e.code === 'ENONODE');
});

test('encodeScene refuses the names the decoder refuses', () => {
	const refused = (label, edit, code) => {
		const s = P.parseScene(named(0));
		edit(s);
		assert.throws(() => P.encodeScene(s), (e) => e.code === code,
			`${label}: want ${code}`);
	};
	refused('65 bytes', (s) => { s.root.name = 'ü'.repeat(32) + 'x'; },
		'EPROTO_LENGTH');
	refused('a NUL', (s) => { s.root.name = 'a\u0000b'; }, 'ESTRING');
	refused('a node of id 0', (s) => { s.byId.get(2).id = 0;
		s.byId.get(2).name = 'a'; }, 'ENONODE');
	refused('two nodes of one id', (s) => { s.byId.get(3).id = 2;
		s.byId.get(2).name = 'a'; s.byId.get(3).name = 'b'; }, 'EDUPID');
	/* An empty name is no name. */
	const s = P.parseScene(named(0));
	s.root.name = '';
	assert.deepEqual(P.encodeScene(s), named(0));
});

test('NAME operations: encode, decode, and every check', () => {
	const edit = (ops) => ({ type: P.MSG.EDIT, flags: 0, seq: 4, ops });
	const ops = [{ kind: P.EDIT.NAME, node: 4, name: 'wheel' },
		{ kind: P.EDIT.NAME, node: 7, name: '' },
		{ kind: P.EDIT.NAME, node: 8, name: 'ä'.repeat(32) }];
	const bytes = P.encode(edit(ops));
	assert.deepEqual(bytes.subarray(16), cat(u16b(3), u8b(5), u32b(4),
		entry(0, 'wheel').subarray(4), u8b(5), u32b(7), u16b(0), u8b(5),
		u32b(8), u16b(64), utf8('ä'.repeat(32))));
	const r = new P.Reader({ side: 'server' });
	r.feed(bytes);
	assert.deepEqual(r.next(), edit(ops));
	/* In an EDIT_APPLIED too. */
	const applied = { type: P.MSG.EDIT_APPLIED, flags: 0, seq: 0,
		order: 9n, author: 2, author_seq: 4, ops: ops.slice(0, 1) };
	const c = new P.Reader({ side: 'client' });
	c.feed(P.encode(applied));
	assert.deepEqual(c.next(), applied);
	const dec = (payload) => P.decodePayload(P.MSG.EDIT, 0, 1, payload);
	const bad = (label, payload, code) => assert.throws(() =>
		dec(payload), (e) => e.code === code, `${label}: want ${code}`);
	bad('node 0', cat(u16b(1), u8b(5), u32b(0), u16b(1), utf8('a')),
		'ERANGE');
	bad('no name length', cat(u16b(1), u8b(5), u32b(4)),
		'EPROTO_TRUNCATED');
	bad('65 bytes', cat(u16b(1), u8b(5), u32b(4), u16b(65),
		utf8('x'.repeat(65))), 'EPROTO_LENGTH');
	bad('name cut short', cat(u16b(1), u8b(5), u32b(4), u16b(5),
		utf8('ab')), 'EPROTO_TRUNCATED');
	bad('a NUL', cat(u16b(1), u8b(5), u32b(4), u16b(2), u8b(0x61),
		u8b(0)), 'ESTRING');
	bad('kind 6', cat(u16b(1), u8b(6), u32b(4)), 'EENUM');
	bad('a byte after it', cat(u16b(1), u8b(5), u32b(4), u16b(0), u8b(0)),
		'EPROTO_TRAILING');
	/* The encoder refuses what the decoder refuses. */
	for (const [name, code] of [['x'.repeat(65), 'EPROTO_LENGTH'],
		['a\u0000', 'ESTRING']]) {
		assert.throws(() => P.encode(edit([{ kind: P.EDIT.NAME, node: 1,
			name }])), (e) => e.code === code, code);
	}
	assert.throws(() => P.encode(edit([{ kind: P.EDIT.NAME, node: 0,
		name: 'a' }])), (e) => e.code === 'ERANGE');
});

test('applyOps: names follow NAME, REMOVE, INSERT and REPLACE', () => {
	const s = P.parseScene(named(2, u32b(1), entry(3, 'wheel')));
	P.applyOps(s, [{ kind: P.EDIT.NAME, node: 2, name: 'body' },
		{ kind: P.EDIT.NAME, node: 3, name: '' }]);
	assert.equal(s.byId.get(2).name, 'body');
	assert.equal('name' in s.byId.get(3), false);
	assert.throws(() => P.applyOps(s, [{ kind: P.EDIT.NAME, node: 77,
		name: 'x' }]), (e) => e.code === 'ENONODE');
	/* An INSERT's subtree brings its names. */
	const sub = cat(u8b(2), u32b(1), sphereB(9), u32b(1), entry(9,
		'nine'));
	assert.deepEqual(P.applyOps(s, [{ kind: P.EDIT.INSERT, parent: 1,
		position: 2, subtree: sub }]), [1]);
	assert.equal(s.byId.get(9).name, 'nine');
	/* A REPLACE's node takes its name away; the subtree's are the new
	 * nodes'. */
	P.applyOps(s, [{ kind: P.EDIT.REPLACE, node: 2, subtree: cat(u8b(0),
		u32b(1), sphereB(2)) }]);
	assert.equal(s.byId.get(2).name, undefined);
	P.applyOps(s, [{ kind: P.EDIT.REPLACE, node: 9, subtree: cat(u8b(2),
		u32b(1), sphereB(10), u32b(1), entry(10, 'ten')) }]);
	assert.equal(s.byId.get(10).name, 'ten');
	assert.deepEqual(P.encodeScene(s), cat(u8b(2), u32b(4), unionB(1, 3),
		sphereB(2), sphereB(3), sphereB(10), u32b(1), entry(10, 'ten')));
	/* A REMOVE takes the names of what it removes. */
	P.applyOps(s, [{ kind: P.EDIT.REMOVE, node: 10 }]);
	assert.equal(P.scanScene(P.encodeScene(s)).names, undefined);
});

test('encodeUndo, encodeHistoryGet, decodeHistory: what the page sends and shows', () => {
	const mine = P.encodeUndo({ mine: true, seq: 7 });
	const m = P.decodePayload(P.MSG.UNDO, 0, 7, mine.subarray(16));
	assert.equal(m.scope, P.UNDO_SCOPE.MINE);
	assert.equal(mine[5], P.MSG.UNDO);
	const redo = P.encodeUndo({ redo: true, session: true });
	assert.equal(redo[5], P.MSG.REDO);
	assert.equal(redo[16], P.UNDO_SCOPE.SESSION);
	/* No scope: the first text's empty UNDO. */
	assert.equal(P.encodeUndo().length, 16);
	assert.throws(() => P.encodeUndo({ mine: true, session: true }),
		(e) => e.code === 'EINVAL');
	assert.equal(P.encodeHistoryGet({ seq: 3 })[5], P.MSG.HISTORY_GET);
	const h = load('history.json').valid[0];
	const bytes = unhex(h.hex);
	const rows = P.decodeHistory(P.decodePayload(P.MSG.HISTORY, 0, 1,
		bytes.subarray(16)));
	assert.equal(rows.length, 3);
	assert.deepEqual(rows[0], { order: 41n,
		time: new Date(1764547200000), author: 'alice',
		what: 'SET node 12 translate', undone: false, yours: true,
		next: true, builtOn: 0n });
	assert.equal(rows[1].builtOn, 42n);
	assert.equal(rows[2].undone, true);
	assert.equal(rows[2].time, null);
});

test('totals', () => {
	/* Runs last (node:test keeps file order): every entry of every
	 * message file and of framing.json went through. */
	let valid = 0, invalid = load('framing.json').invalid.length;
	for (const name of typeNames) {
		const doc = load(fileOf(name));
		valid += doc.valid.length;
		invalid += doc.invalid.length;
	}
	assert.equal(totals.valid, valid);
	assert.equal(totals.invalid, invalid);
	console.log(`# ${totals.valid} valid and ${totals.invalid} invalid ` +
		'message vectors');
});

test('encoding 4 and FRAME_ACK: H.264 frames, the still encoding, acks', () => {
	assert.equal(P.ENC.H264, 4);
	assert.equal(P.ENCODINGS_ALL, 0x0f);
	assert.equal(P.ENCODINGS_IMAGES, 0x07);
	assert.equal(P.FLAG.KEY, 0x80);
	assert.equal(P.FEATURE.ACKS, 0x80);
	assert.equal(P.ACK_WINDOW, 2);
	/* VIEW: the ninth byte only when a still encoding is asked. */
	const view = { type: P.MSG.VIEW, seq: 4, width: 1281, height: 721,
		encoding: 4, quality_interactive: 60, quality_still: 90,
		downscale: 4 };
	assert.equal(P.encode(view).length, 16 + 8);
	const v9 = P.encode({ ...view, still_encoding: 2 });
	assert.equal(v9.length, 16 + 9);
	const r = new P.Reader({ side: 'server' });
	r.feed(v9);
	assert.equal(r.next().still_encoding, 2);
	assert.throws(() => P.encode({ ...view, still_encoding: 4 }),
		(e) => e.code === 'EENUM');
	/* FRAME_ACK round trip; frame 0 is refused. */
	const ack = P.encodeFrameAck({ seq: 9, frame_no: 77 });
	const ra = new P.Reader({ side: 'server' });
	ra.feed(ack);
	const m = ra.next();
	assert.equal(m.type, P.MSG.FRAME_ACK);
	assert.equal(m.frame_no, 77);
	assert.throws(() => P.encodeFrameAck({ frame_no: 0 }),
		(e) => e.code === 'ERANGE');
	/* A FRAME of encoding 4 is one rectangle of the view's size at
	 * every level; KEY belongs to it alone. */
	const fr = { type: P.MSG.FRAME, seq: 0, flags: P.FLAG.KEY,
		frame_no: 3, order: 1n, camera_seq: 0, encoding: 4, width: 5,
		height: 3, image_width: 5, image_height: 3,
		rects: [{ x: 0, y: 0, w: 5, h: 3,
			data: new Uint8Array([0, 0, 1, 0x65]) }] };
	const rc = new P.Reader({ side: 'client' });
	rc.feed(P.encode(fr));
	assert.equal(rc.next().encoding, 4);
	assert.throws(() => P.encode({ ...fr, encoding: 1 }),
		(e) => e.code === 'EPROTO_FLAGS');
	assert.throws(() => P.encode({ ...fr, flags: 0, image_width: 3 }),
		(e) => e.code === 'ERANGE');
});

test('FEATURE.PARTS: a SCENE_STATE in parts is handed on whole', () => {
	assert.equal(P.FEATURE.PARTS, 0x100);
	assert.ok(P.FEATURE.ALL & P.FEATURE.PARTS);
	assert.equal(P.FLAG.MORE, 1);
	assert.equal(P.FLAG.CONT, 2);
	const vec = JSON.parse(readFileSync(join(HERE, '..', '..', 'protocol',
		'vectors', 'scene.json'), 'utf8'));
	const scene = Uint8Array.from(Buffer.from(vec.valid[1].hex, 'hex'));
	const state = (flags, piece, extra = {}) => ({ type: P.MSG.SCENE_STATE,
		seq: 0, flags, order: 7n, author: 3, author_seq: 11, scene: piece,
		...extra });
	/* Cut in three through the reader, as a server sends it: every
	 * piece ends inside the encoding, the last part gives it back. */
	const cuts = [0, 5, 9, scene.length];
	const r = new P.Reader({ side: 'client' });
	for (let i = 0; i + 1 < cuts.length; i++) {
		const flags = (i > 0 ? P.FLAG.CONT : 0) |
			(i + 2 < cuts.length ? P.FLAG.MORE : 0);
		r.feed(P.encode(state(flags, scene.subarray(cuts[i],
			cuts[i + 1]))));
	}
	const parts = new P.SceneParts();
	const out = [];
	for (let m; (m = r.next());) {
		const whole = parts.add(m);
		if (whole) {
			out.push(whole);
		}
	}
	assert.equal(out.length, 1);
	assert.equal(out[0].flags, 0);
	assert.equal(out[0].order, 7n);
	assert.equal(out[0].author_seq, 11);
	assert.deepEqual([...out[0].scene], [...scene]);
	assert.deepEqual(P.parseScene(out[0].scene), P.parseScene(scene));
	/* A whole SCENE_STATE and other messages pass as they are. */
	const ping = { type: P.MSG.PING, seq: 1, flags: 0, stamp: 1n };
	assert.equal(parts.add(ping), ping);
	/* Out of order: each is the server's fault (EPROTO_FLAGS). */
	const bad = (ms) => {
		const p = new P.SceneParts();
		assert.throws(() => ms.forEach((m) => p.add(m)),
			(e) => e.code === 'EPROTO_FLAGS');
	};
	const a = scene.subarray(0, 5), b = scene.subarray(5);
	bad([state(P.FLAG.CONT, b)]);
	bad([state(P.FLAG.MORE, a), ping]);
	bad([state(P.FLAG.MORE, a), state(P.FLAG.MORE, a)]);
	bad([state(P.FLAG.MORE, a), state(P.FLAG.CONT, b, { order: 8n })]);
	bad([state(P.FLAG.MORE, a), state(0, scene)]);
	/* Past the limit: EPROTO_LENGTH. */
	const small = new P.SceneParts(6);
	assert.throws(() => [state(P.FLAG.MORE, a), state(P.FLAG.CONT, b)]
		.forEach((m) => small.add(m)), (e) => e.code === 'EPROTO_LENGTH');
});
