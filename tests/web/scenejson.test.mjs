/*
 * client/web/scenejson.js, the page's JSON scene writer, and the pure
 * parts of client/web/sessions.js.
 *  - floats: C's "%.6g" and "%.9g" for values with known printf output
 *    (ties to even on the exact binary value, exponents, -0), and for
 *    random binary32 values: the text reads back to the same bits, with
 *    six digits whenever six suffice;
 *  - the optional parameters the writer leaves out are those blobtree/prim.c
 *    marks optional;
 *  - scenes `blobcast gen` writes (blobtree's own writer: every kind,
 *    every operator, random transforms and colours, a camera), read into
 *    the page's tree and written by the page: the same bytes;
 *  - a hand-made tree with unary nodes reads back (JSON.parse) to the
 *    same values; a tree deeper than a JSON file holds, or with a node
 *    the page could not keep up to date, is refused;
 *  - session names as the daemon checks them, and the list's lines.
 * Needs BLOBCAST_CLI for the `blobcast gen` scenes (the ctest row sets it).
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import { JSON_MAX_DEPTH, OPTIONAL, formatFloat, formatG, sceneToJson }
	from '../../client/web/scenejson.js';
import { PRIMS } from '../../client/web/prims.js';
import { ago, describe, describeMemory, nameProblem }
	from '../../client/web/sessions.js';
import * as P from '../../client/web/protocol.js';
import { runCli, treeFromJson } from './scenetree.mjs';

const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..', '..');

test('floats as C prints them', () => {
	const f = Math.fround;
	const cases = [
		[0.5, '0.5'], [1, '1'], [100000, '100000'], [1e6, '1e+06'],
		[1234567, '1234567'], [0.0001, '0.0001'], [0.00001, '1e-05'],
		[f(0.1), '0.1'], [-0, '-0.0'], [f(-2.5), '-2.5'],
		[f(3.4028235e38), '3.40282347e+38'], [f(1e-7), '1e-07'],
		[f(0.707106769), '0.707106769'], [f(0.0749999955), '0.0749999955'],
		[123456.5, '123456.5'], [f(1e-45), '1.4013e-45'],
		[999999.5, '999999.5'], [f(9999999), '9999999'],
	];
	for (const [v, want] of cases) {
		assert.equal(formatFloat(v), want, `${v}`);
	}
	/* printf rounds halves to even on the exact value; 0.125 has four
	 * digits, 2.5 at one digit is a tie. */
	assert.equal(formatG(0.125, 2), '0.12');
	assert.equal(formatG(0.375, 2), '0.38');
	assert.equal(formatG(2.5, 1), '2');
	assert.equal(formatG(3.5, 1), '4');
	assert.equal(formatG(9.5, 1), '1e+01');
	assert.equal(formatG(0.00012345, 3), '0.000123');
	assert.equal(formatG(-1234567, 6), '-1.23457e+06');
});

test('random floats read back to the same bits, shortest of 6 or 9', () => {
	const dv = new DataView(new ArrayBuffer(4));
	let s = 0x9e3779b9;
	for (let i = 0; i < 20000; i++) {
		s = (s ^ (s << 13)) >>> 0;
		s = (s ^ (s >>> 17)) >>> 0;
		s = (s ^ (s << 5)) >>> 0;
		dv.setUint32(0, s);
		const v = dv.getFloat32(0);
		if (!Number.isFinite(v)) {
			continue;
		}
		const t = formatFloat(v);
		assert.ok(Object.is(Math.fround(Number(t)), v), `${v}: ${t}`);
		const six = Math.fround(Number(v.toPrecision(6))) === v;
		const digits = t.replace(/^-/, '').replace(/e.*$/, '')
			.replace('.', '').replace(/^0+/, '').length;
		assert.ok(six ? digits <= 6 : digits <= 9, `${v}: ${t}`);
	}
});

test('optional parameters are those prim.c marks optional', () => {
	const src = readFileSync(join(ROOT, 'blobtree', 'prim.c'), 'utf8');
	const found = {};
	const table = /static const struct bc_param_desc p_(\w+)\[\] = \{([\s\S]*?)\};/g;
	const row = /\{"(\w+)", \d+, \d+, ([^,]+), ([-\d.]+)f\}/g;
	for (const m of src.matchAll(table)) {
		for (const r of m[2].matchAll(row)) {
			if (/\bOPT\b/.test(r[2])) {
				const kind = Object.keys(PRIMS).find((k) => PRIMS[k][0] ===
					m[1]);
				assert.ok(kind, `prim.c kind ${m[1]}`);
				found[kind] = { ...found[kind], [r[1]]: Number(r[3]) };
			}
		}
	}
	assert.ok(Object.keys(found).length > 0, 'prim.c read');
	assert.deepEqual(found, JSON.parse(JSON.stringify(OPTIONAL)));
});

test('scenes blobtree writes come out of the page byte for byte', () => {
	for (const args of [['catalogue', '--blend', 'smooth', '--seed', '5'],
		['random', '--count', '80', '--seed', '11'],
		['fig16', '--level', '2'], ['gears', '--teeth', '8']]) {
		const text = runCli(['gen', ...args]);
		const tree = treeFromJson(text);
		assert.equal(sceneToJson(tree), text, `gen ${args.join(' ')}`);
	}
});

test('unary nodes, defaults left out, -0 kept, and back', () => {
	const prim = (kind, params, extra = {}) => ({ isOp: false, kind,
		id: 0, params, translate: [0, 0, 0], rotate: [0, 0, 0, 1],
		color: null, ...extra });
	const unary = (kind, params, child) => ({ isOp: true, unary: true,
		kind, id: 0, params, children: [child] });
	const root = { isOp: true, kind: 4, id: 1, blend: 0.25, range: 0.3125,
		children: [
			unary(12, [5], prim(2, [1, 0.5, 0.25, 0])),
			unary(13, [1, 2, 0.5, 3, 1, 2], prim(1, [0.25],
				{ translate: [-0, 1, 0], color: [1, 0, 0.5] })),
			unary(9, [0.5, 0, 0.25], unary(14, [2], prim(23,
				[1, 0.5, 0.2, 0.125], { rotate: [0, 0, -0, 1] }))),
			prim(5, [1, 0.25]),
		] };
	let id = 1; /* in pre-order, as the file lists them */
	const todo = [root];
	while (todo.length) {
		const n = todo.pop();
		n.id = id++;
		todo.push(...(n.children ?? []).slice().reverse());
	}
	const text = sceneToJson({ camera: { eye: [0, 1, 6], target: [0, 0, 0],
		up: [0, 1, 0], fov_y_deg: 45 }, root });
	const has = (part, why) => assert.ok(text.includes(part),
		`${why ?? part} in:\n${text}`);
	has('"type": "mirror", "id": 2, "axes": "xz", "children"');
	has('"type": "repeat", "id": 4, "spacing": [1, 2, 0.5], ' +
		'"count": [3, 1, 2], "children"');
	has('{"type": "box", "id": 3, "half_extents": [1, 0.5, 0.25]}',
		'round 0, translate and rotate left out');
	has('"translate": [-0.0, 1, 0]');
	has('"rotate": [0, 0, -0.0, 1]');
	has('"round": 0.125');
	assert.ok(text.startsWith('{\n  "blobcast": 1,\n  "camera": ' +
		'{"eye": [0, 1, 6], "target": [0, 0, 0], "up": [0, 1, 0], ' +
		'"fov_y_deg": 45},\n  "root": {"type": "smooth_union", "id": 1, ' +
		'"blend": 0.25, "range": 0.3125, "children": [\n'), text);
	assert.deepEqual(treeFromJson(text).root.children.map((n) => n.kind),
		[12, 13, 9, 5]);
	const back = treeFromJson(text);
	assert.equal(sceneToJson(back), text, 'read back and written again');
});

test('names: "name" after "id", escaped as blobtree does, and back', () => {
	const sph = (id, name) => ({ isOp: false, kind: 1, id, params: [1],
		translate: [0, 0, 0], rotate: [0, 0, 0, 1], color: null,
		...(name === undefined ? {} : { name }) });
	const root = { isOp: true, kind: 1, id: 1, blend: 0, range: 0,
		name: 'body', children: [sph(2, 'wheel "front"\\1\n\u0001é🛞\u007f'),
			{ isOp: true, unary: true, kind: 7, id: 3, params: [0.1],
				name: 'shell', children: [sph(4)] }] };
	const text = sceneToJson({ camera: null, root });
	assert.ok(text.includes('"root": {"type": "union", "id": 1, "name": ' +
		'"body", "children": [\n'), text);
	assert.ok(text.includes('{"type": "sphere", "id": 2, "name": ' +
		'"wheel \\"front\\"\\\\1\\u000a\\u0001é🛞\\u007f", "radius": 1}'),
	text);
	assert.ok(text.includes('{"type": "offset", "id": 3, "name": ' +
		'"shell", "amount": 0.1, "children": [\n'), text);
	assert.ok(text.includes('{"type": "sphere", "id": 4, "radius": 1}'),
		'no name, no "name"');
	const back = treeFromJson(text);
	assert.equal(back.root.children[0].name,
		'wheel "front"\\1\n\u0001é🛞\u007f');
	assert.equal(sceneToJson(back), text, 'read back and written again');
});

test('a tree too deep, or out of date, is refused', () => {
	let n = { isOp: false, kind: 1, id: 1, params: [1],
		translate: [0, 0, 0], rotate: [0, 0, 0, 1], color: null };
	for (let d = 0; d < JSON_MAX_DEPTH; d++) {
		n = { isOp: true, unary: true, kind: 7, id: d + 2, params: [0.01],
			children: [n] };
	}
	assert.throws(() => sceneToJson({ camera: null, root: n }),
		/1024 levels deep, more than the 1023/);
	/* One level less is fine. */
	assert.ok(sceneToJson({ camera: null, root: n.children[0] })
		.length > 1000);
	assert.throws(() => sceneToJson({ camera: null, root: null }), /empty/);
	const stale = n.children[0].children[0];
	stale.stale = true;
	assert.throws(() => sceneToJson({ camera: null, root: stale }),
		/could not follow an edit/);
});

test('session names and list lines', () => {
	assert.equal(nameProblem('review-2_b.1'), '');
	assert.match(nameProblem(''), /type a name/);
	assert.match(nameProblem('.hidden'), /not starting with/);
	assert.match(nameProblem('a b'), /letters, digits/);
	assert.match(nameProblem('x'.repeat(65)), /at most 64 bytes/);
	assert.equal(ago(1000, 61000), '1 min ago');
	assert.equal(ago(0, 7200e3), '2 h ago');
	const now = 1_800_000_000_000;
	assert.equal(describe({ name: 'a', members: 1, prims: 18, order: 4n,
		last_edit_ms: BigInt(now - 5000), flags: P.SESSION_FLAG.ALL }, now),
	'1 member · 18 shapes · edit 4 · 5 s ago');
	assert.equal(describe({ name: 'b', members: 0, prims: 0, order: 0n,
		last_edit_ms: 0n, flags: 0 }, now),
	'0 members · on disk, not loaded yet');
	/* STATS's memory section, as the list's status line tells it. */
	assert.equal(describeMemory({ scene_nodes: 100001n,
		scene_nodes_cap: 149796n, session_nodes: 0n, sessions_loaded: 2 }),
	'scene memory 100,001 of 149,796 nodes (67 %)');
	assert.equal(describeMemory({ scene_nodes: 30n, scene_nodes_cap: 0n }),
		'scene memory 30 of 0 nodes (0 %)');
});
