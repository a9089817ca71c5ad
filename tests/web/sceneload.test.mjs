/*
 * client/web/sceneload.js, the page's scene file reader, against the CLI's
 * (blobtree's) reader:
 *  - scenes `blobcast gen` writes (every primitive kind, every operator,
 *    random transforms and colours, a camera), read by the page and
 *    written back with the page's writer, are the same text, and the
 *    bytes SCENE_LOAD would carry decode to the same tree; a hand-made
 *    file that leaves defaults out, gives no ids, names nodes and carries
 *    unary nodes gets the values and ids docs/scene-format.md gives
 *    (tests/web/review.mjs loads such files from the page and from the
 *    CLI through a daemon and compares the sessions byte for byte);
 *  - which files are refused: for each of some forty files, good and bad
 *    in every way of the format's structure that docs/scene-format.md
 *    lists, the page refuses exactly when `blobcast load` does (it
 *    refuses a bad file with exit status 2 before connecting; a good one
 *    then fails to connect, status 3). Shape rules (a negative radius, a
 *    value past 10^6, a quaternion far from unit length) are the tree
 *    builder's: the page leaves them to the daemon, which refuses the
 *    load with the same words (review.mjs shows one);
 *  - binary scene files: taken as they are, a damaged one refused;
 *  - a scene past one message in parts: MORE, MORE | CONT, CONT, pieces
 *    within the room, in order.
 * Needs BLOBCAST_CLI (the ctest row sets it).
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import { readSceneFile, sceneFromJson, sceneParts, SceneFileError }
	from '../../client/web/sceneload.js';
import { sceneToJson } from '../../client/web/scenejson.js';
import * as P from '../../client/web/protocol.js';
import { cli, runCli } from './scenetree.mjs';

const work = mkdtempSync(join(tmpdir(), 'blobcast-sceneload-'));
process.on('exit', () => rmSync(work, { recursive: true, force: true }));

/* Whether `blobcast load` takes the file (status 3: it read the file and
 * then found no daemon) or refuses it (status 2), and its words. */
function cliTakes(text, name) {
	const path = join(work, name);
	writeFileSync(path, text);
	const r = spawnSync(cli(), ['load', '--server', '127.0.0.1:1',
		'--timeout', '2000', '--session', 's', path], { encoding: 'utf8' });
	assert.ok(r.status === 2 || r.status === 3, `blobcast load of ${name}: ` +
		`status ${r.status}: ${r.stderr}`);
	return { takes: r.status === 3, why: r.stderr.trim() };
}

function pageTakes(text) {
	try {
		readSceneFile(new TextEncoder().encode(text));
		return { takes: true };
	} catch (e) {
		assert.ok(e instanceof SceneFileError, `not a SceneFileError: ${e}`);
		return { takes: false, why: e.message, code: e.code };
	}
}

/* Scenes blobtree's writer wrote: read by the page, they write back to the
 * same text with the page's writer, and the bytes SCENE_LOAD would carry
 * decode to the same tree. */
const GEN = [
	['catalogue', '--seed', '3'],
	['catalogue', '--blend', 'smooth', '--seed', '4'],
	['random', '--count', '60', '--seed', '7'],
	['random', '--count', '40', '--seed', '8', '--depth', '30'],
	['fig16', '--level', '2', '--blend', 'sharp'],
	['gears', '--teeth', '12'],
	['default'],
];

test('generated scenes read back to the writer\'s text', () => {
	for (const g of GEN) {
		const text = runCli(['gen', ...g]);
		const scene = sceneFromJson(text);
		assert.equal(sceneToJson(scene), text, `gen ${g.join(' ')}`);
		/* The bytes SCENE_LOAD carries decode to the same tree. */
		const { bytes } = readSceneFile(new TextEncoder().encode(text));
		assert.equal(sceneToJson(P.parseScene(bytes)), text);
	}
});

/* A file with every default left out, ids left to the reader (around the
 * ids the file names), names, unary nodes and no camera: the values
 * docs/scene-format.md gives them (review.mjs compares such a file loaded
 * from the page and from the CLI through a daemon, byte for byte). */
test('defaults, ids given by the reader, names', () => {
	const text = JSON.stringify({
		blobcast: 1,
		root: { type: 'smooth_union', blend: 0.2, name: 'top',
			children: [
				{ type: 'box', half_extents: [1, 0.5, 0.25] },
				{ type: 'sphere', id: 2, radius: 0.5,
					rotate: [0, 0, 0.38268343, 0.9238795] },
				{ type: 'twist', rate: 0.5, children: [
					{ type: 'mirror', id: 1, axes: 'zx', children: [
						{ type: 'cylinder', radius: 0.2,
							half_height: 1, name: 'pin' }] }] },
				{ type: 'repeat', spacing: [1, 0, 0], count: [3, 1, 1],
					children: [{ type: 'torus', major: 1, minor: 0.1,
						color: [0.5, 0.5, 1] }] }] },
	});
	const s = sceneFromJson(text);
	assert.deepEqual(s.camera, { eye: [0, 0, 6], target: [0, 0, 0],
		up: [0, 1, 0], fov_y_deg: 45 });
	/* Pre-order, skipping the ids the file names (1 and 2). */
	const ids = [];
	const todo = [s.root];
	while (todo.length) {
		const n = todo.pop();
		ids.push(n.id);
		for (let i = (n.children ?? []).length - 1; i >= 0; i--) {
			todo.push(n.children[i]);
		}
	}
	assert.deepEqual(ids, [3, 4, 2, 5, 1, 6, 7, 8]);
	assert.equal(s.root.name, 'top');
	assert.equal(s.root.range, 0, 'the default range is the builder\'s');
	assert.deepEqual(s.root.children[0].params, [1, 0.5, 0.25, 0]);
	assert.deepEqual(s.root.children[0].rotate, [0, 0, 0, 1]);
	assert.equal(s.root.children[0].color, null);
	assert.deepEqual(s.root.children[2].children[0].params, [5]);
	assert.deepEqual(s.root.children[3].params, [1, 0, 0, 3, 1, 1]);
	assert.equal(s.nodes, 8);
	assert.ok(cliTakes(text, 'defaults.json').takes);
});

const GOOD = {
	minimal: { blobcast: 1, root: { type: 'sphere', radius: 1 } },
	spaces: ' \n{"blobcast": 1, "root": {"type": "sphere", "radius": 1}}\n\n ',
	camera_part: { blobcast: 1, camera: { fov_y_deg: 30 },
		root: { type: 'sphere', radius: 1 } },
	big_id: { blobcast: 1, root: { type: 'sphere', id: 4294967295,
		radius: 1 } },
	name_64: { blobcast: 1, root: { type: 'sphere', radius: 1,
		name: 'é'.repeat(32) } },
	name_pair: '{"blobcast": 1, "root": {"type": "sphere", "radius": 1, ' +
		'"name": "\\ud83d\\ude00"}}',
	range: { blobcast: 1, root: { type: 'smooth_union', blend: 0.1,
		range: 0.2, children: [{ type: 'sphere', radius: 1 },
			{ type: 'sphere', radius: 1 }] } },
	small_float: { blobcast: 1, root: { type: 'sphere', radius: 1,
		translate: [1e-45, 1e6, -1e-40] } },
};
const BAD = {
	version2: { blobcast: 2, root: { type: 'sphere', radius: 1 } },
	version_real: '{"blobcast": 1.0, "root": {"type": "sphere", "radius": 1}}',
	no_root: { blobcast: 1 },
	no_version: { root: { type: 'sphere', radius: 1 } },
	top_key: { blobcast: 1, root: { type: 'sphere', radius: 1 }, x: 1 },
	unknown_type: { blobcast: 1, root: { type: 'spher', radius: 1 } },
	unknown_key: { blobcast: 1, root: { type: 'sphere', radius: 1,
		radius2: 1 } },
	missing_param: { blobcast: 1, root: { type: 'sphere' } },
	string_param: { blobcast: 1, root: { type: 'sphere', radius: '1' } },
	short_vector: { blobcast: 1, root: { type: 'box',
		half_extents: [1, 1] } },
	nonfinite: { blobcast: 1, root: { type: 'sphere', radius: 1,
		translate: [1e39, 0, 0] } },
	id_zero: { blobcast: 1, root: { type: 'sphere', id: 0, radius: 1 } },
	id_big: { blobcast: 1, root: { type: 'sphere', id: 4294967296,
		radius: 1 } },
	id_real: '{"blobcast": 1, "root": {"type": "sphere", "id": 2.0, ' +
		'"radius": 1}}',
	id_string: { blobcast: 1, root: { type: 'sphere', id: '2', radius: 1 } },
	dup_id: { blobcast: 1, root: { type: 'union', id: 1, children: [
		{ type: 'sphere', id: 1, radius: 1 },
		{ type: 'sphere', radius: 1 }] } },
	one_child: { blobcast: 1, root: { type: 'union', children: [
		{ type: 'sphere', radius: 1 }] } },
	blend_on_sharp: { blobcast: 1, root: { type: 'union', blend: 0.1,
		children: [{ type: 'sphere', radius: 1 },
			{ type: 'sphere', radius: 1 }] } },
	no_blend: { blobcast: 1, root: { type: 'smooth_union', children: [
		{ type: 'sphere', radius: 1 }, { type: 'sphere', radius: 1 }] } },
	range_zero: { blobcast: 1, root: { type: 'smooth_union', blend: 0.1,
		range: 0, children: [{ type: 'sphere', radius: 1 },
			{ type: 'sphere', radius: 1 }] } },
	unary_two: { blobcast: 1, root: { type: 'twist', rate: 1, children: [
		{ type: 'sphere', radius: 1 }, { type: 'sphere', radius: 1 }] } },
	unary_param: { blobcast: 1, root: { type: 'twist', children: [
		{ type: 'sphere', radius: 1 }] } },
	mirror_axes: { blobcast: 1, root: { type: 'mirror', axes: 'xx',
		children: [{ type: 'sphere', radius: 1 }] } },
	mirror_w: { blobcast: 1, root: { type: 'mirror', axes: 'w',
		children: [{ type: 'sphere', radius: 1 }] } },
	repeat_no_count: { blobcast: 1, root: { type: 'repeat',
		spacing: [1, 1, 1], children: [{ type: 'sphere', radius: 1 }] } },
	name_empty: { blobcast: 1, root: { type: 'sphere', radius: 1,
		name: '' } },
	name_long: { blobcast: 1, root: { type: 'sphere', radius: 1,
		name: 'n'.repeat(65) } },
	name_number: { blobcast: 1, root: { type: 'sphere', radius: 1,
		name: 5 } },
	name_surrogate: '{"blobcast": 1, "root": {"type": "sphere", ' +
		'"radius": 1, "name": "a\\ud800b"}}',
	name_nul: '{"blobcast": 1, "root": {"type": "sphere", "radius": 1, ' +
		'"name": "a\\u0000b"}}',
	camera_key: { blobcast: 1, camera: { eyes: [0, 0, 1] },
		root: { type: 'sphere', radius: 1 } },
	dup_key: '{"blobcast": 1, "root": {"type": "sphere", "radius": 1, ' +
		'"radius": 2}}',
	dup_top_key: '{"blobcast": 1, "blobcast": 1, "root": {"type": ' +
		'"sphere", "radius": 1}}',
	nan: '{"blobcast": 1, "root": {"type": "sphere", "radius": NaN}}',
	trailing: '{"blobcast": 1, "root": {"type": "sphere", "radius": 1}} x',
	bom: '\ufeff{"blobcast": 1, "root": {"type": "sphere", "radius": 1}}',
	not_object: '[1, 2]',
	children_object: { blobcast: 1, root: { type: 'union',
		children: { a: 1 } } },
	node_array: { blobcast: 1, root: [] },
	color_short: { blobcast: 1, root: { type: 'sphere', radius: 1,
		color: [1, 1] } },
};

test('the page refuses a file exactly when blobcast load does', () => {
	for (const [name, doc] of [...Object.entries(GOOD),
		...Object.entries(BAD)]) {
		const text = typeof doc === 'string' ? doc : JSON.stringify(doc);
		const want = cliTakes(text, `${name}.json`);
		const got = pageTakes(text);
		assert.equal(got.takes, want.takes, `${name}: the page ` +
			`${got.takes ? 'takes' : `refuses (${got.why})`}, blobcast load ` +
			`${want.takes ? 'takes it' : `refuses it: ${want.why}`}`);
		assert.equal(want.takes, name in GOOD, `${name}: the CLI`);
	}
});

test('deeper than a JSON file holds, refused', () => {
	let root = { type: 'sphere', radius: 1 };
	for (let i = 0; i < 1023; i++) {
		root = { type: 'scale', factor: 1, children: [root] };
	}
	const text = JSON.stringify({ blobcast: 1, root });
	const got = pageTakes(text);
	assert.equal(got.takes, false);
	assert.equal(got.code, 'EDEPTH');
	assert.equal(cliTakes(text, 'deep.json').takes, false);
});

test('binary scene files: as written, a damaged one refused', () => {
	const text = runCli(['gen', 'catalogue', '--seed', '5']);
	const scene = sceneFromJson(text);
	const file = P.encodeSceneFile(scene);
	const r = readSceneFile(file);
	assert.deepEqual([...r.bytes], [...file.subarray(12)]);
	assert.equal(r.nodes, scene.nodes);
	const bad = file.slice();
	bad[40] ^= 0x10;
	assert.throws(() => readSceneFile(bad), /CRC-32/);
	assert.throws(() => readSceneFile(file.subarray(0, 20)),
		/the header says/);
});

test('a scene past one message goes in parts', () => {
	const bytes = Uint8Array.from({ length: 1000 }, (_, i) => i & 0xff);
	assert.deepEqual(sceneParts(bytes, 1000).map((p) => p.flags), [0]);
	assert.deepEqual(sceneParts(bytes, 5000).map((p) => p.flags), [0]);
	for (const room of [1, 7, 333, 500, 999]) {
		const parts = sceneParts(bytes, room);
		assert.equal(parts.length, Math.ceil(1000 / room));
		assert.ok(parts.every((p) => p.scene.length >= 1 &&
			p.scene.length <= room), `room ${room}`);
		assert.deepEqual(Buffer.concat(parts.map((p) => p.scene)),
			Buffer.from(bytes), `room ${room}: the pieces, in order`);
		assert.equal(parts[0].flags, P.FLAG.MORE);
		assert.equal(parts[parts.length - 1].flags, P.FLAG.CONT);
		assert.ok(parts.slice(1, -1).every((p) => p.flags ===
			(P.FLAG.MORE | P.FLAG.CONT)));
	}
	assert.throws(() => sceneParts(bytes, 0), RangeError);
});
