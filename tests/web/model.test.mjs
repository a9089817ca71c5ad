/*
 * The page's tree edits (client/web/model.js) in node, without a browser:
 * each action is the operations of one EDIT that the page's own codec
 * encodes, and applied to the mirror (protocol.js applyOps, which follows
 * the daemon's semantics) they give the tree the action names; what the
 * daemon would refuse is refused before anything is sent, with a
 * sentence that says what to do: adding under a primitive or a unary
 * node, moving a node under itself or its descendant, deleting the root
 * or a unary chain up to it, a result over the node, nesting, stack or
 * domain limits. The defaults of new shapes match blobtree/prim.c. A
 * rename is one NAME (over 64 bytes of UTF-8, a NUL or a lone surrogate
 * refused); a duplicate's copy is "<name> copy" within 64 bytes; moves
 * and wraps keep names. A reorder (place, shift) is a REMOVE and an
 * INSERT at the place, or a REPLACE with the children swapped in a group
 * of two; the node's own place, a place that does not exist and a
 * reorder over the stack limit are refused; in a difference the message
 * says when the first child (the shape the others are cut from) changes.
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import * as M from '../../client/web/model.js';
import * as P from '../../client/web/protocol.js';
import { PRIMS, UNARY, layout, unaryLayout } from '../../client/web/prims.js';

const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..', '..');

/* Scene builders: a primitive, an operator (smooth ones with blend 0.1),
 * a unary node at its defaults. */
const prim = (id, kind = 1, translate = [0, 0, 0]) => ({ isOp: false, kind,
	id, translate, rotate: [0, 0, 0, 1], color: null,
	params: M.primParams(kind) });
const op = (id, kind, ...children) => ({ isOp: true, kind, id,
	blend: kind > 3 ? 0.1 : 0, range: kind > 3 ? 0.125 : 0, children });
const un = (id, kind, child) => ({ isOp: true, unary: true, kind, id,
	params: M.unaryDefaults(kind), children: [child] });
const scene = (root) => P.parseScene(P.encodeScene({ root }));

/* union #1 (sphere #2, smooth_union #3 (box #4, sphere #5),
 * twist #6 (sphere #7)) */
const sample = () => scene(op(1, 1, prim(2), op(3, 4, prim(4, 2), prim(5)),
	un(6, 10, prim(7))));

/* The tree as nested [kind, id, ...children]. */
function shape(n) {
	const name = M.kindName(n);
	return n.isOp ? [name, n.id, ...n.children.map(shape)] : [name, n.id];
}

/* Applies an action's operations to the scene as a member would,
 * after checking that the page's encoder takes them as one EDIT. */
function apply(s, r) {
	const bytes = P.encode({ type: P.MSG.EDIT, flags: 0, seq: 1, ops: r.ops });
	assert.ok(bytes.length > 16, 'the EDIT encodes');
	P.applyOps(s, r.ops, layout);
	return s;
}

function refused(fn, re) {
	assert.throws(fn, (e) => e instanceof M.Refusal && re.test(e.message),
		`refused with a message matching ${re}`);
}

test('defaults of new shapes are those of blobtree/prim.c', () => {
	const c = readFileSync(join(ROOT, 'blobtree', 'prim.c'), 'utf8');
	const tabs = {};
	for (const m of c.matchAll(
		/static const struct bc_param_desc (p_\w+)\[\] = \{([^;]*)\};/g)) {
		tabs[m[1]] = [...m[2].matchAll(
			/\{"\w+",\s*\d+,\s*\d+,\s*[^,]+,\s*([-\d.e]+)f\}/g)]
			.map((r) => Number(r[1]));
	}
	let kinds = 0;
	for (const m of c.matchAll(/\[BC_PRIM_\w+\]\s*=\s*DESC\("(\w+)",\s*(p_\w+)/g)) {
		const kind = Number(Object.keys(PRIMS).find((k) =>
			PRIMS[k][0] === m[1]));
		assert.ok(kind, `${m[1]} is in prims.js`);
		assert.deepEqual(M.PRIM_DEFAULTS[kind], tabs[m[2]], m[1]);
		assert.equal(M.primParams(kind).length, layout(kind).reduce((a, d) =>
			a + d.count, 0), `${m[1]}: a value per float`);
		kinds++;
	}
	assert.equal(kinds, Object.keys(PRIMS).length);
	assert.equal(Object.keys(M.PRIM_DEFAULTS).length, kinds);
	/* Sizes scale, counts and angles do not. */
	assert.deepEqual(M.primParams(27, 2), [1, 5, 1]);
	assert.deepEqual(M.primParams(12, 0.5), [0.5, 0.125, 90]);
	for (const k of Object.keys(UNARY)) {
		assert.equal(M.unaryDefaults(Number(k)).length, unaryLayout(k)
			.reduce((a, d) => a + d.count, 0), `${UNARY[k][0]} defaults`);
	}
});

test('add a primitive: one INSERT with a fresh id, at the end', () => {
	const s = sample();
	const r = M.addPrimitive(s, 3, 8, { translate: [1, 2, 3], size: 0.5,
		color: [1, 0, 0] });
	assert.equal(r.ops.length, 1);
	assert.equal(r.ops[0].kind, P.EDIT.INSERT);
	assert.equal(r.select, 8, 'the largest id + 1');
	apply(s, r);
	const n = s.byId.get(8);
	assert.equal(n.parent.id, 3);
	assert.equal(s.byId.get(3).children.at(-1), n);
	assert.deepEqual(n.translate, [1, 2, 3]);
	assert.deepEqual(n.params, [0.5, 0.5, 0.5]);
	assert.deepEqual(M.groupFor(s, 7).id, 1, 'twist #6 is not a group');
	assert.equal(M.groupFor(s, 4).id, 3);
	assert.match(r.text, /added ellipsoid #8 under smooth_union #3/);
});

test('add under a primitive or a unary node is refused', () => {
	const s = sample();
	refused(() => M.addPrimitive(s, 2, 1), /cannot add under sphere #2: a primitive has no children\. Select an operator/);
	refused(() => M.addPrimitive(s, 6, 1), /cannot add under twist #6: a unary node wraps exactly one child/);
	refused(() => M.addPrimitive(s, 99, 1), /no node #99/);
	refused(() => M.addPrimitive(s, 1, 33), /no primitive kind 33/);
});

test('add with no operator in the scene groups it with the root', () => {
	const s = scene(un(1, 7, prim(2)));
	assert.equal(M.groupFor(s, 2), null);
	const r = M.addPrimitive(s, null, 1);
	assert.equal(r.ops[0].kind, P.EDIT.REPLACE);
	apply(s, r);
	assert.deepEqual(shape(s.root), ['union', 4, ['offset', 1, ['sphere',
		2]], ['sphere', 3]]);
});

test('wrap: REPLACE by unary(node), the node keeps its ids', () => {
	const s = sample();
	const r = M.wrap(s, 3, 14);
	assert.equal(r.ops[0].kind, P.EDIT.REPLACE);
	apply(s, r);
	assert.deepEqual(shape(s.byId.get(1)).slice(0, 4)[3], ['scale', 8,
		['smooth_union', 3, ['box', 4], ['sphere', 5]]]);
	assert.deepEqual(s.byId.get(8).params, [1]);
	/* The root too. */
	apply(s, M.wrap(s, 1, 12));
	assert.equal(s.root.id, 9);
	assert.equal(s.root.children[0].id, 1);
});

test('delete: the root and a unary chain up to it are refused', () => {
	const s = sample();
	refused(() => M.remove(s, 1), /cannot delete union #1: it is the root, and a scene is never empty\. Delete the shapes inside it instead/);
	const t = scene(un(1, 7, un(2, 8, prim(3))));
	refused(() => M.remove(t, 3), /cannot delete sphere #3: the unary nodes above it reach the root \(offset #1\)/);
	refused(() => M.remove(t, 2), /reach the root/);
	/* A twisted sphere goes with its twist; an operator left with one
	 * child gives way to it. */
	apply(s, M.remove(s, 7));
	assert.equal(s.byId.has(6), false);
	const r = M.remove(s, 4);
	assert.equal(r.select, 3);
	apply(s, r);
	assert.deepEqual(shape(s.root), ['union', 1, ['sphere', 2], ['sphere',
		5]]);
});

test('duplicate: fresh ids, next to the original, moved by offset', () => {
	const s = sample();
	const r = M.duplicate(s, 7, { offset: [0.5, 0, 0] });
	apply(s, r);
	assert.deepEqual(shape(s.root).slice(4), [['twist', 6, ['sphere', 7]],
		['twist', 8, ['sphere', 9]]]);
	assert.deepEqual(s.byId.get(9).translate, [0.5, 0, 0]);
	assert.equal(r.select, 8);
	const d = M.duplicate(s, 3);
	apply(s, d);
	assert.deepEqual(shape(s.root)[4], ['smooth_union', 10, ['box', 11],
		['sphere', 12]]);
	/* The root: beside itself in a new union. */
	const t = scene(op(1, 1, prim(2), prim(3)));
	apply(t, M.duplicate(t, 1));
	assert.deepEqual(shape(t.root), ['union', 7, ['union', 1, ['sphere', 2],
		['sphere', 3]], ['union', 4, ['sphere', 5], ['sphere', 6]]]);
});

test('rename: one EDIT of one NAME; empty takes the name away', () => {
	const s = sample();
	const r = M.rename(s, 5, 'wheel');
	assert.deepEqual(r.ops, [{ kind: P.EDIT.NAME, node: 5, name: 'wheel' }]);
	assert.equal(r.select, 5);
	assert.match(r.text, /named sphere #5 “wheel”/);
	apply(s, r);
	assert.equal(s.byId.get(5).name, 'wheel');
	assert.equal(M.nodeName(s.byId.get(5)), 'sphere #5 “wheel”');
	/* 64 bytes (32 two-byte characters) is the most a name takes. */
	apply(s, M.rename(s, 3, 'ö'.repeat(32)));
	assert.equal(s.byId.get(3).name, 'ö'.repeat(32));
	refused(() => M.rename(s, 5, 'wheel'), /already named so/);
	const off = M.rename(s, 5, '');
	assert.deepEqual(off.ops, [{ kind: P.EDIT.NAME, node: 5, name: '' }]);
	assert.match(off.text, /took the name “wheel” away from sphere #5/);
	apply(s, off);
	assert.equal(s.byId.get(5).name, undefined);
	refused(() => M.rename(s, 5, ''), /has no name: nothing to remove/);
	refused(() => M.rename(s, 99, 'x'), /no node #99/);
});

test('rename: over 64 bytes of UTF-8, a NUL, a lone surrogate: refused', () => {
	const s = sample();
	/* 33 two-byte characters are 66 bytes though 33 UTF-16 units. */
	refused(() => M.rename(s, 2, 'ü'.repeat(33)),
		/66 bytes of UTF-8, more than the 64 a name may have: shorten it/);
	refused(() => M.rename(s, 2, 'x'.repeat(65)), /65 bytes/);
	refused(() => M.rename(s, 2, 'a\u0000b'), /NUL character.*remove it/);
	refused(() => M.rename(s, 2, 'a\ud800'), /lone surrogate/);
	assert.equal(M.nameProblem('🛞'.repeat(16)), null);
	assert.match(M.nameProblem('🛞'.repeat(16) + 'x'), /65 bytes/);
});

test('duplicate names the copy "<name> copy"; move and wrap keep names', () => {
	const s = sample();
	apply(s, M.rename(s, 7, 'spring'));
	apply(s, M.rename(s, 6, 'coil'));
	apply(s, M.duplicate(s, 7));
	/* twist #8 (sphere #9): the copy of the selected node is "... copy",
	 * the unary node over it keeps its name. */
	assert.equal(s.byId.get(9).name, 'spring copy');
	assert.equal(s.byId.get(8).name, 'coil');
	assert.equal(s.byId.get(7).name, 'spring');
	/* A long name is cut at a whole character to fit 64 bytes. */
	apply(s, M.rename(s, 2, 'a' + 'é'.repeat(31)));
	apply(s, M.duplicate(s, 2));
	const copy = s.byId.get(10);
	assert.equal(copy.name, 'a' + 'é'.repeat(29) + ' copy');
	assert.ok(M.nameBytes(copy.name) <= 64);
	assert.equal(M.copyName('é'.repeat(32)), 'é'.repeat(29) + ' copy');
	assert.equal(M.copyName('x'.repeat(59)), 'x'.repeat(59) + ' copy');
	/* A move (REMOVE, INSERT of the same ids) keeps the names. */
	apply(s, M.move(s, 7, 3));
	assert.equal(s.byId.get(7).name, 'spring');
	assert.equal(s.byId.get(6).name, 'coil');
	/* So does a wrap (REPLACE by a unary over the node). */
	apply(s, M.rename(s, 4, 'block'));
	apply(s, M.wrap(s, 4, 7));
	assert.equal(s.byId.get(4).name, 'block');
	assert.equal(P.scanScene(P.encodeScene(s)).names, 7);
});

test('operator kind and blend obey the sharp/smooth rules', () => {
	const s = sample();
	const fields = (r) => r.ops[0].fields.map((f) => [f.field, ...f.values]);
	/* union -> smooth intersection: kind and blend > 0 in one SET. */
	let r = M.setOperator(s, 1, { base: 2, smooth: true, blend: 0.2 });
	assert.deepEqual(fields(r), [[P.FIELD.OP_KIND, 5], [P.FIELD.BLEND, 0.2],
		[P.FIELD.RANGE, 0.25]]);
	apply(s, r);
	assert.equal(s.root.kind, 5);
	/* smooth -> sharp: kind, blend 0, range 0. */
	r = M.setOperator(s, 3, { base: 3, smooth: false });
	assert.deepEqual(fields(r), [[P.FIELD.OP_KIND, 3], [P.FIELD.BLEND, 0],
		[P.FIELD.RANGE, 0]]);
	apply(s, r);
	/* Encodable again: a sharp operator with blend and range 0. */
	P.scanScene(P.encodeScene({ root: s.root }));
	/* smooth -> smooth, the same radius: the kind alone. */
	r = M.setOperator(s, 1, { base: 1, smooth: true, blend: s.root.blend });
	assert.deepEqual(fields(r), [[P.FIELD.OP_KIND, 4]]);
	refused(() => M.setOperator(s, 1, { base: 2, smooth: true, blend:
		s.root.blend }), /already smooth_intersection with radius .*nothing to change/);
	refused(() => M.setOperator(s, 1, { base: 2, smooth: true, blend: 0 }),
		/needs a radius above 0/);
	refused(() => M.setOperator(s, 2, { base: 1, smooth: false }),
		/sphere #2 is not an operator/);
	refused(() => M.setOperator(s, 6, { base: 1, smooth: false }),
		/twist #6 is not an operator/);
});

test('move: REMOVE and INSERT of the same ids in one EDIT', () => {
	const s = sample();
	const r = M.move(s, 2, 3);
	assert.deepEqual(r.ops.map((o) => o.kind), [P.EDIT.REMOVE,
		P.EDIT.INSERT]);
	apply(s, r);
	assert.deepEqual(shape(s.root), ['union', 1, ['smooth_union', 3,
		['box', 4], ['sphere', 5], ['sphere', 2]], ['twist', 6, ['sphere',
		7]]]);
	/* A wrapped shape moves with its wrapper; its old group, left with
	 * one child, gives way to it. */
	apply(s, M.move(s, 7, 3));
	assert.deepEqual(shape(s.root), ['smooth_union', 3, ['box', 4],
		['sphere', 5], ['sphere', 2], ['twist', 6, ['sphere', 7]]]);
});

test('move under itself, its descendant, a primitive: refused', () => {
	const s = scene(op(1, 1, prim(2), op(3, 1, prim(4), op(5, 1, prim(6),
		prim(7)))));
	refused(() => M.move(s, 3, 5), /cannot move union #3 under union #5: that is inside it, and a node cannot contain itself\. Drop it on an operator outside it/);
	refused(() => M.move(s, 3, 3), /that is the node itself/);
	refused(() => M.move(s, 2, 4), /cannot move sphere #2 under sphere #4: a primitive has no children\. Drop it on an operator/);
	refused(() => M.move(s, 4, 3), /sphere #4 is already in union #3/);
	refused(() => M.move(s, 1, 3), /inside it/);
	const t = scene(op(1, 1, un(2, 7, prim(3)), prim(4)));
	refused(() => M.move(t, 4, 2), /a unary node wraps exactly one child/);
});

test('the node, depth, stack and domain limits', () => {
	const s = sample();
	refused(() => M.addPrimitive(s, 1, 1, { limits: { ...M.limitsFor(null),
		nodes: 8 } }), /would need 9 nodes, more than the 8 this daemon takes: delete some shapes first/);
	M.addPrimitive(s, 1, 1, { limits: { ...M.limitsFor(null), nodes: 9 } });
	/* quick (a drag's hover): the structural checks only. */
	M.addPrimitive(s, 1, 1, { limits: { ...M.limitsFor(null), nodes: 8 },
		quick: true });
	refused(() => M.addPrimitive(s, 2, 1, { quick: true }), /a primitive has no children/);
	assert.equal(M.limitsFor({ max_nodes: 1000 }).nodes, 1000);
	refused(() => M.move(s, 2, 3, { limits: { ...M.limitsFor(null),
		depth: 2 } }), /nest 3 levels deep, more than 2/);
	/* A right comb: each group's second child is the next group, so
	 * each level needs one more stack entry. */
	let right = prim(1000);
	for (let i = 0; i < M.EVAL_STACK - 1; i++) {
		right = op(2000 + i, 1, prim(3000 + i), right);
	}
	const comb = scene(op(1, 1, right, prim(2), op(3, 1, prim(4), prim(5))));
	assert.equal(M.measure(comb.root).stack, M.EVAL_STACK);
	/* A group as a later child of the innermost group needs one more
	 * entry there, and so at every level above; a shape does not. */
	const inner = 2000;
	refused(() => M.move(comb, 3, inner), /stack of 131 entries, more than 130/);
	M.move(comb, 4, inner);
	/* 32 twists over a shape take a 33rd badly. */
	let tw = prim(2);
	for (let i = 0; i < M.DOMAIN_CHAIN; i++) {
		tw = un(100 + i, 10, tw);
	}
	const deep = scene(op(1, 1, tw, prim(3)));
	assert.equal(M.measure(deep.root).domain, M.DOMAIN_CHAIN);
	refused(() => M.wrap(deep, 2, 11), /33 domain nodes/);
	M.wrap(deep, 2, 7);
});

test('fresh ids avoid every id in use, even near the top of u32', () => {
	const s = scene(op(0xfffffffe, 1, prim(1), prim(3)));
	assert.deepEqual(M.freshIds(s, 3), [2, 4, 5]);
	assert.deepEqual(M.freshIds(sample(), 2), [8, 9]);
});

/* union #1 (sphere #2, box #3, difference #4 (sphere #5, box #6, sphere
 * #7 named "hole"), twist #8 (sphere #9)) */
const siblings = () => {
	const s = op(1, 1, prim(2), prim(3, 2), op(4, 3, prim(5), prim(6, 2),
		prim(7)), un(8, 10, prim(9)));
	s.children[2].children[2].name = 'hole';
	return scene(s);
};

test('place: REMOVE and INSERT at a place among the siblings', () => {
	const s = siblings();
	/* Places count the children as they are: 0 before the first, 4
	 * after the last of union #1. Down past one sibling: 2 -> after #3. */
	const r = M.place(s, 2, 1, 2);
	assert.deepEqual(r.ops.map((o) => [o.kind, o.node ?? o.parent,
		o.position]), [[P.EDIT.REMOVE, 2, undefined], [P.EDIT.INSERT, 1, 1]]);
	assert.match(r.text, /^moved sphere #2 to place 2 of union #1$/);
	assert.equal(r.select, 2);
	apply(s, r);
	assert.deepEqual(shape(s.root).slice(2).map((c) => c[1]), [3, 2, 4, 8]);
	/* To the end, and back to the front. */
	apply(s, M.place(s, 3, 1, 4));
	assert.deepEqual(shape(s.root).slice(2).map((c) => c[1]), [2, 4, 8, 3]);
	apply(s, M.place(s, 3, 1, 0));
	assert.deepEqual(shape(s.root).slice(2).map((c) => c[1]), [3, 2, 4, 8]);
	/* A wrapped shape moves with its wrapper. */
	apply(s, M.place(s, 9, 1, 0));
	assert.deepEqual(shape(s.root).slice(2, 4), [['twist', 8, ['sphere', 9]],
		['box', 3]]);
	/* Into another group at a place; the name goes with the node. */
	apply(s, M.place(s, 7, 1, 1));
	assert.deepEqual(shape(s.root), ['union', 1, ['twist', 8, ['sphere', 9]],
		['sphere', 7], ['box', 3], ['sphere', 2], ['difference', 4,
			['sphere', 5], ['box', 6]]]);
	assert.equal(s.byId.get(7).name, 'hole');
});

test('place: the own place and places that do not exist are refused', () => {
	const s = siblings();
	refused(() => M.place(s, 3, 1, 1), /box #3 is already at that place in union #1: nothing to move/);
	refused(() => M.place(s, 3, 1, 2), /already at that place/);
	refused(() => M.place(s, 3, 1, 5), /no place 5 among the 4 children of union #1: pick a place from 0 to 4/);
	refused(() => M.place(s, 3, 1, -1), /no place -1/);
	refused(() => M.place(s, 4, 4, 0), /that is the node itself/);
	refused(() => M.place(s, 2, 3, 0), /a primitive has no children/);
	refused(() => M.place(s, 2, 8, 0), /a unary node wraps exactly one child/);
	refused(() => M.place(s, 1, 4, 0), /inside it/);
});

test('place in a difference: the first child changes the shape', () => {
	const s = siblings();
	const r = M.place(s, 7, 4, 0);
	assert.match(r.text, /^moved sphere #7 “hole” to place 1 of difference #4: sphere #7 “hole” is now the shape the others are cut from$/);
	apply(s, r);
	assert.deepEqual(shape(s.byId.get(4)).slice(2).map((c) => c[1]),
		[7, 5, 6]);
	/* The first moved away: the next one is now first. */
	assert.match(M.place(s, 7, 4, 3).text, /: sphere #5 is now the shape the others are cut from$/);
	/* Among the later children the shape stays: no note. */
	assert.match(M.place(s, 6, 4, 1).text, /^moved box #6 to place 2 of difference #4$/);
});

test('place in a group of two: a REPLACE with the children swapped', () => {
	const s = scene(op(1, 1, prim(2), op(3, 6, prim(4, 2), prim(5))));
	s.byId.get(3).name = 'cut';
	s.byId.get(5).name = 'tool';
	const r = M.place(s, 5, 3, 0);
	/* A REMOVE would leave #3 with one child and replace it by that. */
	assert.deepEqual(r.ops.map((o) => [o.kind, o.node]),
		[[P.EDIT.REPLACE, 3]]);
	apply(s, r);
	assert.deepEqual(shape(s.root), ['union', 1, ['sphere', 2],
		['smooth_difference', 3, ['sphere', 5], ['box', 4]]]);
	assert.equal(s.byId.get(3).name, 'cut');
	assert.equal(s.byId.get(5).name, 'tool');
	assert.equal(s.byId.get(3).blend, Math.fround(0.1),
		'the operator is kept as it was');
	/* Into a group of two from outside: REMOVE and INSERT. */
	assert.deepEqual(M.place(s, 2, 3, 1).ops.map((o) => o.kind),
		[P.EDIT.REMOVE, P.EDIT.INSERT]);
});

test('shift: Alt+Up and Alt+Down move one place among the siblings', () => {
	const s = siblings();
	apply(s, M.shift(s, 3, -1));
	assert.deepEqual(shape(s.root).slice(2).map((c) => c[1]), [3, 2, 4, 8]);
	apply(s, M.shift(s, 3, 1));
	assert.deepEqual(shape(s.root).slice(2).map((c) => c[1]), [2, 3, 4, 8]);
	/* The shape under a twist moves the twist. */
	apply(s, M.shift(s, 9, -1));
	assert.deepEqual(shape(s.root).slice(2).map((c) => c[1]), [2, 3, 8, 4]);
	refused(() => M.shift(s, 2, -1), /sphere #2 is already the first child of union #1: nothing to move up/);
	refused(() => M.shift(s, 4, 1), /difference #4 is already the last child of union #1: nothing to move down/);
	refused(() => M.shift(s, 1, 1), /union #1 is the root: it has no siblings/);
	/* A reorder can need more stack: a right comb (each group's second
	 * child the next group) moved after a shape. */
	let right = prim(1000);
	for (let i = 0; i < M.EVAL_STACK - 1; i++) {
		right = op(2000 + i, 1, prim(3000 + i), right);
	}
	const t = scene(op(1, 1, right, prim(2)));
	assert.equal(M.measure(t.root).stack, M.EVAL_STACK);
	refused(() => M.shift(t, 2, -1), /stack of 131 entries, more than 130/);
});
