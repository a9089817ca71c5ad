/*
 * Test helpers: a JSON scene file (docs/scene-format.md) read into the
 * tree the page mirrors (the node shapes of protocol.js's parseScene),
 * with every number taken to binary32 as blobtree's reader does (strtod,
 * then float), and running the blobcast CLI. Written from the format's
 * description, not from the page's writer, so that the tests compare two
 * independent readings.
 */
import { execFileSync } from 'node:child_process';

import { OPS, PRIMS, UNARY, layout } from '../../client/web/prims.js';

const f32 = (v) => Math.fround(v);
const KIND = Object.fromEntries(Object.entries(PRIMS).map(([k, p]) =>
	[p[0], Number(k)]));
const OPKIND = Object.fromEntries(OPS.map((n, k) => [n, k]).filter(
	([n]) => n));
/* Optional parameters and their defaults (docs/scene-format.md). */
const OPTIONAL = { round: 0 };

function node(j) {
	if (j.type in KIND) {
		const kind = KIND[j.type];
		const params = [];
		for (const d of layout(kind)) {
			const v = j[d.name] ?? (d.name in OPTIONAL ? OPTIONAL[d.name]
				: undefined);
			if (v === undefined) {
				throw new Error(`${j.type} ${j.id}: no ${d.name}`);
			}
			params.push(...(d.count === 1 ? [v] : v).map(f32));
		}
		return { isOp: false, kind, id: j.id, params,
			translate: (j.translate ?? [0, 0, 0]).map(f32),
			rotate: (j.rotate ?? [0, 0, 0, 1]).map(f32),
			color: j.color ? j.color.map(f32) : null };
	}
	const kind = OPKIND[j.type];
	if (!kind) {
		throw new Error(`unknown type ${j.type}`);
	}
	if (kind >= 7) {
		const name = UNARY[kind][0];
		let params;
		if (name === 'mirror') {
			params = [[...j.axes].reduce((m, c) => m | (1 << 'xyz'
				.indexOf(c)), 0)];
		} else {
			params = UNARY[kind][1].flatMap(([p, n]) => (n === 1 ? [j[p]]
				: j[p])).map(f32);
		}
		return { isOp: true, unary: true, kind, id: j.id, params,
			children: [] };
	}
	return { isOp: true, kind, id: j.id, blend: f32(j.blend ?? 0),
		range: f32(j.range ?? (kind >= 4 ? 1.25 * j.blend : 0)),
		children: [] };
}

/* { camera, root } of a scene file's text; nodes get parent links. */
export function treeFromJson(text) {
	const doc = JSON.parse(text);
	const root = node(doc.root);
	const todo = [[doc.root, root]];
	while (todo.length) {
		const [j, n] = todo.pop();
		if (j.name !== undefined) {
			n.name = j.name;
		}
		for (const c of j.children ?? []) {
			const k = node(c);
			k.parent = n;
			n.children.push(k);
			todo.push([c, k]);
		}
	}
	const c = doc.camera;
	return { camera: c ? { eye: c.eye.map(f32), target: c.target.map(f32),
		up: c.up.map(f32), fov_y_deg: f32(c.fov_y_deg) } : null, root };
}

/* The CLI from $BLOBCAST_CLI (the ctest row sets it). */
export function cli() {
	const p = process.env.BLOBCAST_CLI;
	if (!p) {
		throw new Error('set BLOBCAST_CLI to the blobcast CLI (ctest ' +
			'does: build it with the blobcast_cli target)');
	}
	return p;
}

/* Runs the CLI; returns its stdout. */
export function runCli(args) {
	return execFileSync(cli(), args, { encoding: 'utf8',
		maxBuffer: 64 << 20 });
}
