/*
 * client/web/bounds.js: the boxes the page frames a scene with.
 *  - by hand: a few kinds' boxes, a rotation, each unary and domain
 *    node's rule, the operators' (a smooth union grows by blend / 6, an
 *    intersection meets, a difference keeps its first child);
 *  - against blobtree's own surface: `blobcast mesh` (surface nets: every
 *    vertex on the surface within its cell) of every primitive kind,
 *    turned and moved, with variants of the kinds whose box has cases,
 *    and of each operator and unary node: every vertex lies inside the
 *    box the page computes (give or take one cell), the mesh being made
 *    over a region half as large again as that box, so that a surface
 *    reaching out of it would show. How loose each kind's box is gets
 *    printed (docs/web.md quotes it);
 *  - fitCamera: the box's corners project inside the view, one of them
 *    on its edge shrunk by the margin.
 * Needs BLOBCAST_CLI (the ctest row sets it).
 * Usage: BLOBCAST_CLI=build/client/blobcast node --test tests/web/bounds.test.mjs
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import { FIT_MARGIN, corners, fitCamera, localBox, primBox, quatRotate,
	treeBox } from '../../client/web/bounds.js';
import { PRIMS, layout } from '../../client/web/prims.js';
import { runCli, treeFromJson } from './scenetree.mjs';

const close = (a, b, eps = 1e-9) => assert.ok(Math.abs(a - b) <= eps,
	`${a} != ${b}`);
const closeBox = (got, want) => got.forEach((v, i) => v.forEach((x, k) =>
	close(x, want[i][k], 1e-6)));
const prim = (kind, params, extra = {}) => ({ isOp: false, kind, id: 1,
	params, translate: [0, 0, 0], rotate: [0, 0, 0, 1], color: null,
	...extra });
const op = (kind, children, extra = {}) => ({ isOp: true, kind, id: 9,
	blend: 0, range: 0, children, ...extra });
const unary = (kind, params, child) => ({ isOp: true, unary: true, kind,
	id: 8, params, children: [child] });

test('local boxes of some kinds, by hand', () => {
	closeBox(localBox(1, [2]), [[-2, -2, -2], [2, 2, 2]]);
	closeBox(localBox(3, [0, 0, 0, 1, 2, 3, 0.5]),
		[[-0.5, -0.5, -0.5], [1.5, 2.5, 3.5]]);
	closeBox(localBox(5, [1, 0.25]), [[-1.25, -0.25, -1.25],
		[1.25, 0.25, 1.25]]);
	closeBox(localBox(15, [1, 2]), [[-1, 0, -1], [1, 2, 1]]);
	/* capped torus 40 deg: x reaches R sin 40 + r, z from R cos 40 - r */
	const a = 40 * Math.PI / 180;
	closeBox(localBox(12, [1, 0.25, 40]), [[-Math.sin(a) - 0.25, -0.25,
		Math.cos(a) - 0.25], [Math.sin(a) + 0.25, 0.25, 1.25]]);
	/* parameters that do not fit the layout: a cube of their sum */
	closeBox(localBox(1, [1, 2]), [[-3, -3, -3], [3, 3, 3]]);
	closeBox(localBox(99, [0.5]), [[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]]);
});

test('every kind of the table has a finite box', () => {
	for (const k of Object.keys(PRIMS).map(Number)) {
		const n = layout(k).reduce((s, d) => s + d.count, 0);
		const [lo, hi] = localBox(k, new Array(n).fill(0.5));
		for (let i = 0; i < 3; i++) {
			assert.ok(Number.isFinite(lo[i]) && Number.isFinite(hi[i]) &&
				lo[i] < hi[i], `kind ${k}`);
		}
	}
});

test('rotation and translation move the box', () => {
	/* 90 degrees about z: x -> y */
	const q = [0, 0, Math.SQRT1_2, Math.SQRT1_2];
	const r = quatRotate(q, [1, 0, 0]);
	[0, 1, 0].forEach((v, i) => close(r[i], v, 1e-12));
	closeBox(primBox(prim(2, [3, 1, 0.5, 0], { rotate: q,
		translate: [10, 0, 0] })), [[9, -3, -0.5], [11, 3, 0.5]]);
	assert.equal(corners([[0, 0, 0], [1, 2, 3]]).length, 8);
});

test('operators: union, smooth union, intersection, difference', () => {
	const a = prim(1, [1], { translate: [-2, 0, 0] });
	const b = prim(1, [1], { translate: [2, 0, 0] });
	closeBox(treeBox(op(1, [a, b])), [[-3, -1, -1], [3, 1, 1]]);
	closeBox(treeBox(op(4, [a, b], { blend: 0.6, range: 0.75 })),
		[[-3.1, -1.1, -1.1], [3.1, 1.1, 1.1]]);
	const c = prim(1, [1], { translate: [-1.5, 0, 0] });
	closeBox(treeBox(op(2, [a, c])), [[-2.5, -1, -1], [-1, 1, 1]]);
	assert.equal(treeBox(op(5, [a, b], { blend: 0.1, range: 0.2 })), null,
		'disjoint children: nothing');
	closeBox(treeBox(op(3, [a, b])), [[-3, -1, -1], [-1, 1, 1]]);
	closeBox(treeBox(op(6, [b, a], { blend: 0.1, range: 0.2 })),
		[[1, -1, -1], [3, 1, 1]]);
	assert.equal(treeBox(null), null);
});

test('unary and domain nodes map their child\'s box', () => {
	const s = prim(2, [1, 2, 3, 0], { translate: [1, 0, 0] });
	const box = (kind, params) => treeBox(unary(kind, params, s));
	closeBox(box(7, [0.5]), [[-0.5, -2.5, -3.5], [2.5, 2.5, 3.5]]);
	closeBox(box(7, [-0.5]), [[0, -2, -3], [2, 2, 3]]);
	closeBox(box(8, [0.25]), [[-0.25, -2.25, -3.25], [2.25, 2.25, 3.25]]);
	closeBox(box(9, [1, 0, 2]), [[-1, -2, -5], [3, 2, 5]]);
	const rxz = Math.hypot(2, 3);
	closeBox(box(10, [1]), [[-rxz, -2, -rxz], [rxz, 2, rxz]]);
	const rxy = Math.hypot(2, 2);
	closeBox(box(11, [1]), [[-rxy, -rxy, -3], [rxy, rxy, 3]]);
	closeBox(box(12, [5]), [[-2, -2, -3], [2, 2, 3]]);
	closeBox(box(13, [2, 1, 1, 3, 1, 2]), [[-2, -2, -3.5],
		[4, 2, 3.5]]);
	closeBox(box(14, [2]), [[0, -4, -6], [4, 4, 6]]);
});

test('fitCamera frames the box just inside the view', () => {
	const box = [[-1, -2, -3], [5, 2, 1]];
	for (const aspect of [0.5, 1, 2.5]) {
		const cam = fitCamera({ eye: [7, 3, 40], target: [0, 0, 0],
			up: [0, 1, 0], fov_y_deg: 45 }, box, aspect);
		close(cam.target[0], 2);
		close(cam.target[2], -1);
		const f = cam.target.map((v, k) => v - cam.eye[k]);
		const d = Math.hypot(...f);
		const dir = f.map((v) => v / d);
		const old = [-7, -3, -40].map((v) => v / Math.hypot(7, 3, 40));
		dir.forEach((v, k) => close(v, old[k], 1e-12));
		/* Project with the page's conventions. */
		const r = [dir[1] * 0 - dir[2] * 1, dir[2] * 0 - dir[0] * 0,
			dir[0] * 1 - dir[1] * 0];
		const rl = Math.hypot(...r);
		const right = r.map((v) => v / rl);
		const up = [right[1] * dir[2] - right[2] * dir[1],
			right[2] * dir[0] - right[0] * dir[2],
			right[0] * dir[1] - right[1] * dir[0]];
		const t = Math.tan(45 * Math.PI / 360);
		let widest = 0;
		for (const c of corners(box)) {
			const p = c.map((v, k) => v - cam.eye[k]);
			const z = p.reduce((s, v, k) => s + v * dir[k], 0);
			const x = p.reduce((s, v, k) => s + v * right[k], 0) /
				(z * t * aspect);
			const y = p.reduce((s, v, k) => s + v * up[k], 0) / (z * t);
			assert.ok(z > 0 && Math.abs(x) < 1 && Math.abs(y) < 1,
				`aspect ${aspect}: corner ${c} at ${x}, ${y}`);
			widest = Math.max(widest, Math.abs(x), Math.abs(y));
		}
		/* Not needlessly far: some corner touches the view's edge
		 * shrunk by the margin. */
		close(widest, 1 / FIT_MARGIN, 1e-9);
	}
});

/* ---- against blobtree's surface ---- */

const work = mkdtempSync(join(tmpdir(), 'blobcast-bounds-'));
process.on('exit', () => rmSync(work, { recursive: true, force: true }));

/* The vertices of `blobcast mesh` of a scene, meshed over region (a box)
 * at resolution cells along its longest side: [{ p, color }], cell. */
function mesh(scene, region, resolution) {
	const file = join(work, 'scene.json');
	const out = join(work, 'mesh.obj');
	writeFileSync(file, JSON.stringify(scene));
	runCli(['mesh', file, '--out', out, '--quiet', '--resolution',
		String(resolution), '--bounds', [...region[0], ...region[1]]
			.join(',')]);
	const verts = [];
	for (const line of readFileSync(out, 'utf8').split('\n')) {
		if (line.startsWith('v ')) {
			const v = line.slice(2).trim().split(/\s+/).map(Number);
			verts.push({ p: v.slice(0, 3), color: v.slice(3, 6) });
		}
	}
	const long = Math.max(...region[1].map((v, k) => v - region[0][k]));
	return { verts, cell: long / resolution };
}

/* region: box grown to half as large again around its centre. */
const widen = ([lo, hi]) => [lo.map((v, k) => v - (hi[k] - v) / 4 - 0.1),
	hi.map((v, k) => v + (hi[k] - lo[k]) / 4 + 0.1)];

function inside(p, [lo, hi], tol) {
	return p.every((v, k) => v >= lo[k] - tol && v <= hi[k] + tol);
}

/* Every kind at its defaults, and variants for the cases of the rules. */
const VARIANTS = [
	['capped_torus', { major: 1, minor: 0.2, angle_deg: 40 }],
	['capped_torus', { major: 1, minor: 0.2, angle_deg: 150 }],
	['cone', { half_height: 0.8, radius_bottom: 0.2, radius_top: 0.9 }],
	['cut_sphere', { radius: 1, cut_height: -0.6 }],
	['cut_hollow_sphere', { radius: 1, cut_height: -0.5, thickness: 0.1 }],
	['revolve_circle', { radius: 0.6, offset: 0.2 }],
	['revolve_star', { radius: 0.5, points: 4, inner_ratio: 0.4,
		offset: 0.1 }],
	['link', { half_length: 0.8, major: 0.4, minor: 0.1 }],
	['round_cone', { a: [0.3, -0.6, 0.1], b: [-0.2, 0.5, 0.4],
		radius_a: 0.1, radius_b: 0.5 }],
	['capped_cone', { a: [0.6, 0, 0], b: [-0.3, 0.4, 0.2], ra: 0.2,
		rb: 0.5 }],
	['vesica_segment', { a: [0, -0.9, 0], b: [0.2, 0.9, 0.3], w: 0.4 }],
	['solid_angle', { radius: 1, angle_deg: 120 }],
	['tri_prism', { radius: 0.6, half_depth: 0.3 }],
];

test('every kind\'s box holds blobtree\'s surface of it', () => {
	const gen = treeFromJson(runCli(['gen', 'catalogue']));
	const defaults = gen.root.children.map((n) => [PRIMS[n.kind][0],
		Object.fromEntries(layout(n.kind).map((d) => [d.name,
			d.count === 1 ? n.params[d.offset] : n.params.slice(d.offset,
				d.offset + d.count)]))]);
	/* Each twice: as it stands (the local box is checked tightly)
	 * and turned; each primitive its own colour, on a grid. */
	const all = [...defaults, ...VARIANTS].flatMap((k) => [[...k, false],
		[...k, true]]);
	const side = Math.ceil(Math.sqrt(all.length));
	const children = all.map(([type, params, turned], i) => {
		const q = turned ? [Math.sin(i * 1.7), Math.cos(i * 2.3),
			Math.sin(i * 0.9), 1.3] : [0, 0, 0, 1];
		const ql = Math.hypot(...q);
		return { type, id: i + 2, ...params,
			translate: [3 * (i % side), 0.1 * i, 3 * Math.floor(i / side)],
			rotate: q.map((v) => v / ql), color: [(i + 1) / 128, 0.5, 0.5] };
	});
	const scene = { blobcast: 1, root: { type: 'union', id: 1, children } };
	const tree = treeFromJson(JSON.stringify(scene));
	const boxes = tree.root.children.map(primBox);
	const { verts, cell } = mesh(scene, widen(treeBox(tree.root)), 400);
	const tol = Math.sqrt(3) * cell;
	const seen = boxes.map(() => [[Infinity, Infinity, Infinity],
		[-Infinity, -Infinity, -Infinity]]);
	for (const v of verts) {
		const i = Math.round(v.color[0] * 128) - 1;
		assert.ok(i >= 0 && i < boxes.length, `a vertex of colour ${v.color}`);
		assert.ok(inside(v.p, boxes[i], tol), `${all[i][0]} (#${i}) ` +
			`reaches ${v.p} outside its box ${JSON.stringify(boxes[i])}`);
		for (let k = 0; k < 3; k++) {
			seen[i][0][k] = Math.min(seen[i][0][k], v.p[k]);
			seen[i][1][k] = Math.max(seen[i][1][k], v.p[k]);
		}
	}
	/* How loose: the box's diagonal over that of the surface's own
	 * box (both in world axes), per kind. */
	const slack = all.map(([type, , turned], i) => {
		const d = (b) => Math.hypot(...b[1].map((v, k) => v - b[0][k]));
		assert.ok(Number.isFinite(seen[i][0][0]), `${type}: no surface`);
		return [`${type}${turned ? ' turned' : ''}`,
			d(boxes[i]) / d(seen[i])];
	});
	slack.sort((a, b) => b[1] - a[1]);
	console.log(`# ${verts.length} vertices, cell ${cell.toFixed(4)}; box ` +
		'diagonal / surface diagonal, loosest first: ' + slack.slice(0, 8)
		.map(([t, r]) => `${t} ${r.toFixed(2)}`).join(', ') +
		`; median ${slack[slack.length >> 1][1].toFixed(2)}`);
});

/* Operator and unary cases (domain nodes act about the origin). */
const CASES = [
	['smooth union', { type: 'smooth_union', blend: 0.6, children: [
		{ type: 'sphere', radius: 0.5, translate: [-0.55, 0, 0] },
		{ type: 'sphere', radius: 0.5, translate: [0.55, 0.1, 0] }] }],
	['smooth intersection', { type: 'smooth_intersection', blend: 0.2,
		children: [{ type: 'box', half_extents: [0.8, 0.8, 0.8] },
			{ type: 'sphere', radius: 1, translate: [0.4, 0, 0] }] }],
	['smooth difference', { type: 'smooth_difference', blend: 0.2,
		children: [{ type: 'box', half_extents: [0.8, 0.5, 0.8] },
			{ type: 'sphere', radius: 0.6, translate: [0.8, 0.5, 0] }] }],
	['offset', { type: 'offset', amount: 0.2, children: [
		{ type: 'box', half_extents: [0.5, 0.3, 0.4] }] }],
	['onion', { type: 'onion', thickness: 0.1, children: [
		{ type: 'sphere', radius: 0.7, translate: [0.2, 0, 0] }] }],
	['elongate', { type: 'elongate', half_extents: [0.5, 0, 0.3],
		children: [{ type: 'sphere', radius: 0.4 }] }],
	['twist', { type: 'twist', rate: 1.5, children: [
		{ type: 'box', half_extents: [0.3, 1, 0.2],
			translate: [0.3, 0, 0] }] }],
	['bend', { type: 'bend', rate: 0.8, children: [
		{ type: 'box', half_extents: [1, 0.15, 0.2] }] }],
	['mirror', { type: 'mirror', axes: 'xz', children: [
		{ type: 'sphere', radius: 0.3, translate: [0.6, 0.2, 0.5] }] }],
	['repeat', { type: 'repeat', spacing: [1, 1, 0.8], count: [3, 1, 2],
		children: [{ type: 'sphere', radius: 0.3 }] }],
	['scale', { type: 'scale', factor: 1.7, children: [
		{ type: 'torus', major: 0.5, minor: 0.15,
			translate: [0.2, 0.1, 0] }] }],
];

test('operator and unary boxes hold blobtree\'s surface', () => {
	/* Two scenes (unions of half the cases each, one mesh call each),
	 * each case's primitives its own colour: a vertex is on its own
	 * case's surface, which overlapping cases may hide in part. */
	for (const part of [0, 1]) {
		const mine = CASES.filter((c, i) => i % 2 === part);
		let id = 1;
		const ids = (j, c) => ({ ...j, id: id++, children: j.children?.map(
			(k) => ids(k, c)), ...(j.children ? {} : { color: [(c + 1) /
				32, 0.5, 0.5] }) });
		const scene = { blobcast: 1, root: { type: 'union', id: id++,
			children: mine.map(([, root], c) => ids(root, c)) } };
		const text = JSON.stringify(scene);
		const tree = treeFromJson(text);
		const boxes = tree.root.children.map(treeBox);
		const { verts, cell } = mesh(scene, widen(treeBox(tree.root)), 160);
		const tol = Math.sqrt(3) * cell;
		const count = boxes.map(() => 0);
		for (const v of verts) {
			const c = Math.round(v.color[0] * 32) - 1;
			assert.ok(c >= 0 && c < boxes.length, `colour ${v.color}`);
			count[c]++;
			assert.ok(inside(v.p, boxes[c], tol), `${mine[c][0]}: ${v.p} ` +
				`is outside ${JSON.stringify(boxes[c])}`);
		}
		count.forEach((n, c) => assert.ok(n > 50, `${mine[c][0]}: ${n} ` +
			'vertices of its surface'));
	}
});
