/*
 * Tree edits of the page as pure functions over its scene mirror (the
 * tree protocol.js's parseScene builds and applyOps keeps up to date):
 * adding a primitive, wrapping a node in a unary node, deleting,
 * duplicating, changing an operator's kind and blend, moving a node to
 * another operator or to another place among its siblings, and naming a
 * node. Each action becomes the operations of ONE EDIT
 * (PROTOCOL.md section 9), so every member sees it at once and it undoes
 * as one step.
 *
 * Each action first refuses what the daemon would refuse, with a sentence
 * that says what to do instead (a Refusal): adding under a primitive or a
 * unary node, moving a node under itself or its own descendant (or to
 * the place it is at, which would change nothing), deleting the root or a
 * chain of unary nodes up to it, a name over 64 bytes of UTF-8 or holding
 * a NUL character, and any result over the limits of nodes, nesting,
 * evaluation stack or domain nodes (those are checked on a copy of the
 * mirror with the operations applied, so what is measured is exactly what
 * the daemon would build). New nodes get ids the
 * mirror does not use (PROTOCOL.md 7.12: every inserted node carries one);
 * an editor racing for the same id is refused by the daemon (EDUPID) and
 * the page says so.
 *
 * No DOM here: tests/web/model.test.mjs runs it in node.
 */
import { EDIT, FIELD, LIMITS, applyOps, encodeScene } from './protocol.js';
import { OPS, PRIMS, UNARY, layout } from './prims.js';

/* Stack entries any evaluation may use (blobtree.h BC_EVAL_STACK: the GPU
 * evaluates the tree with a fixed per-invocation stack); a tree needing
 * more is refused with EDEPTH. */
export const EVAL_STACK = 130;
/* Domain nodes on one path (blobtree.h BC_DOMAIN_MAX_CHAIN: evaluators map
 * a point through them with a fixed array); more is refused with EDEPTH. */
export const DOMAIN_CHAIN = 32;
/* Operator kinds 1..3 are sharp; kind + 3 is the smooth one. */
export const SMOOTH = 3;
/* The daemon's default range of a smooth operator, in units of its blend
 * (PROTOCOL.md section 8: range 0 stands for 1.25 blend). The page sends
 * the value itself so that its mirror holds what the daemon stores. */
export const RANGE_PER_BLEND = 1.25;

/* Each primitive kind's defaults, one per named parameter of PRIMS (every
 * component of a [3] parameter takes it): blobtree's bc_prim_data_init,
 * which tests/web/model.test.mjs compares with blobtree/prim.c. Sizes are
 * about one unit; a new shape is scaled to the camera's distance. */
export const PRIM_DEFAULTS = Object.freeze({
	1: [1], 2: [1, 0], 3: [-0.5, 0.5, 0.5], 4: [0.5, 1], 5: [1, 0.25],
	6: [1, 1, 0], 7: [-0.5, 0.5, 0.5, 0.25], 8: [1], 9: [1, 0.5], 10: [1],
	11: [1, 0.1], 12: [1, 0.25, 90], 13: [0.5, 0.5, 0.15], 14: [1, 30],
	15: [1, 1], 16: [0.5, 0.5], 17: [1, 0.5], 18: [1, 0.5, 0.1],
	19: [1, 0.8, 1], 20: [0.5, 0.1, 1], 21: [-0.5, 0.5, 0.5],
	22: [-0.5, 0.5, 0.5, 0.25], 23: [1, 0.5, 0.2, 0], 24: [-0.5, 0.5, 0.3],
	25: [0.5, 0.5], 26: [0.5, 0.25, 0.5], 27: [0.5, 5, 0.5],
	28: [0.5, 5, 0.5, 0.25], 29: [0.25, 0.75], 30: [0.25, 0.5, 0.75],
	31: [0.3, 6, 0.75], 32: [0.35, 5, 0.5, 0.75],
});

/* Parameters that are not lengths: a new shape's size scales the others. */
const UNITLESS = new Set(['sides', 'points', 'inner_ratio']);

/* A refused action: its message says what went wrong and what to do. */
export class Refusal extends Error {
	constructor(text) {
		super(text);
		this.name = 'Refusal';
	}
}

/* "union", "sphere", "twist": a node's kind as docs/scene-format.md names
 * it. */
export function kindName(n) {
	return n.isOp ? OPS[n.kind] ?? `op ${n.kind}`
		: PRIMS[n.kind]?.[0] ?? `kind ${n.kind}`;
}

/* "sphere #12", or "sphere #12 “wheel”" for a named node. */
export function nodeName(n) {
	return `${kindName(n)} #${n.id}` + (n.name ? ` “${n.name}”` : '');
}

/* The longest node name, in bytes of UTF-8 (PROTOCOL.md section 8). */
export const NAME_MAX = LIMITS.MAX_NAME;
/* What a duplicate's name ends with (model.js duplicate). */
const COPY_SUFFIX = ' copy';
const utf8 = new TextEncoder();

/* Bytes of s in UTF-8. */
export function nameBytes(s) {
	return utf8.encode(s).length;
}

/* Why name cannot be a node's name (a sentence saying what to do), or
 * null when it can; "" is no name. */
export function nameProblem(name) {
	if (typeof name !== 'string') {
		return 'a name is text';
	}
	if (name.includes('\u0000')) {
		return 'a name cannot hold the NUL character (U+0000): remove it';
	}
	if (!name.isWellFormed()) {
		return 'the name holds a lone surrogate (half of a character ' +
			'that needs two UTF-16 units): retype it';
	}
	const n = nameBytes(name);
	if (n > NAME_MAX) {
		return `the name is ${n} bytes of UTF-8, more than the ` +
			`${NAME_MAX} a name may have: shorten it`;
	}
	return null;
}

/* The longest start of s that fits max bytes of UTF-8, whole characters
 * only. */
function clip(s, max) {
	let out = '', used = 0;
	for (const ch of s) {
		const k = nameBytes(ch);
		if (used + k > max) {
			break;
		}
		out += ch;
		used += k;
	}
	return out;
}

/* A duplicate's name: "<name> copy", the name shortened (by whole
 * characters) so that the whole stays within NAME_MAX bytes. */
export function copyName(name) {
	return clip(name, NAME_MAX - nameBytes(COPY_SUFFIX)) + COPY_SUFFIX;
}

/* An operator that takes any number of children (not a unary node). */
export function isGroup(n) {
	return !!n && n.isOp && !n.unary;
}

/* The limits an action must stay within: the protocol's, or the lower
 * node limit a daemon announced in WELCOME. */
export function limitsFor(welcome) {
	return { nodes: Math.min(LIMITS.SCENE_MAX_NODES,
		welcome?.max_nodes || Infinity), depth: LIMITS.SCENE_MAX_DEPTH,
	stack: EVAL_STACK, domain: DOMAIN_CHAIN };
}

/* The parameters a unary kind starts from. protocol.js holds that table
 * (blobtree's bc_unary_init) for its SET of OP_KIND: ask it rather than
 * keep a second copy. */
export function unaryDefaults(kind) {
	const n = { isOp: true, unary: true, kind: 0, id: 1, params: [],
		children: [] };
	applyOps({ byId: new Map([[1, n]]) }, [{ kind: EDIT.SET, node: 1,
		fields: [{ field: FIELD.OP_KIND, values: [kind] }] }]);
	return n.params.slice();
}

/* A primitive kind's parameters at its defaults, lengths times size. */
export function primParams(kind, size = 1) {
	const out = [];
	layout(kind).forEach((d, k) => {
		const v = PRIM_DEFAULTS[kind][k];
		const s = UNITLESS.has(d.name) || d.rule === 'deg' ? 1 : size;
		for (let i = 0; i < d.count; i++) {
			out.push(v * s);
		}
	});
	return out;
}

/* n ids the scene does not use: after its largest, or the lowest free
 * ones when the largest is near the top of u32. */
export function freshIds(scene, n = 1) {
	let max = 0;
	for (const id of scene.byId.keys()) {
		max = Math.max(max, id);
	}
	const out = [];
	if (max + n <= 0xffffffff) {
		for (let i = 1; i <= n; i++) {
			out.push(max + i);
		}
		return out;
	}
	for (let id = 1; out.length < n; id++) {
		if (!scene.byId.has(id)) {
			out.push(id);
		}
	}
	return out;
}

function get(scene, id) {
	const n = scene.byId.get(id);
	if (!n) {
		throw new Refusal(`there is no node #${id} in the scene any more ` +
			'(another member changed it): pick again');
	}
	return n;
}

/* What a REMOVE of n takes away: n with the chain of unary nodes above
 * it (PROTOCOL.md section 9). */
export function removedTop(n) {
	while (n.parent && n.parent.unary) {
		n = n.parent;
	}
	return n;
}

/* The operator a new shape goes under when id is selected: id itself if
 * it is one, else the nearest operator above it; null when there is none
 * (a scene of one shape, or unary nodes over it). */
export function groupFor(scene, id) {
	for (let n = scene.byId.get(id) ?? scene.root; n; n = n.parent) {
		if (isGroup(n)) {
			return n;
		}
	}
	return null;
}

/* Whether n is anc or below it. */
export function within(n, anc) {
	for (; n; n = n.parent) {
		if (n === anc) {
			return true;
		}
	}
	return false;
}

/* A copy of the subtree at n (parent links inside it, none above). With
 * ids, each node of the copy takes the next of them. */
function copyTree(n, ids = null) {
	let k = 0;
	const root = { ...n, parent: null };
	const todo = [[n, root]];
	while (todo.length) {
		const [src, dst] = todo.pop();
		for (const key of ['translate', 'rotate', 'color', 'params']) {
			if (src[key]) {
				dst[key] = src[key].slice();
			}
		}
		if (ids) {
			dst.id = ids[k++];
		}
		if (src.isOp) {
			dst.children = src.children.map((c) => ({ ...c, parent: dst }));
			/* Pre-order: the first child is copied first. */
			for (let i = src.children.length - 1; i >= 0; i--) {
				todo.push([src.children[i], dst.children[i]]);
			}
		}
	}
	return root;
}

/* Nodes in the subtree at n. */
export function count(n) {
	let c = 0;
	const todo = [n];
	while (todo.length) {
		const k = todo.pop();
		c++;
		if (k.isOp) {
			todo.push(...k.children);
		}
	}
	return c;
}

/* Measures a tree as the daemon does when it builds one: { nodes, prims,
 * depth (nodes on the longest path, the root counting 1), stack (the
 * evaluation stack it needs: a child after the first of an operator is
 * evaluated above the ones before it, so it needs one entry more),
 * domain (domain nodes on one path) }. One iterative depth-first walk
 * that keeps only the open operators: trees may be deep and big. */
export function measure(root) {
	const out = { nodes: 0, prims: 0, depth: 0, stack: 0, domain: 0 };
	const path = [], at = [], need = [];
	let dom = 0;
	for (let n = root; ;) {
		out.nodes++;
		out.depth = Math.max(out.depth, path.length + 1);
		if (n.isOp) {
			/* Every unary kind but offset and onion maps the domain. */
			if (n.unary && n.kind > 8) {
				out.domain = Math.max(out.domain, ++dom);
			}
			path.push(n);
			at.push(0);
			need.push(0);
			n = n.children[0];
			continue;
		}
		out.prims++;
		/* A primitive needs one entry; finish the operators it
		 * completes and go on with the next child. */
		let done = 1;
		for (;;) {
			const top = path.length - 1;
			if (top < 0) {
				out.stack = done;
				return out;
			}
			const p = path[top], i = at[top];
			need[top] = i === 0 ? done : Math.max(need[top], done + 1);
			if (i + 1 < p.children.length) {
				at[top] = i + 1;
				n = p.children[i + 1];
				break;
			}
			done = need[top];
			path.pop();
			at.pop();
			need.pop();
			if (p.unary && p.kind > 8) {
				dom--;
			}
		}
	}
}

/* The mirror's structure with ops applied, on a copy: the tree the daemon
 * would build, for measuring. The copy keeps what applyOps and measure
 * read of each node (primitives: kind and id; operators also blend,
 * range and a unary node's parameters), which is what the operations
 * built here touch; it is cheap enough for a 100 000-node scene. */
export function preview(scene, ops) {
	const byId = new Map();
	const lean = (n, parent) => {
		const c = n.isOp ? { isOp: true, unary: n.unary, kind: n.kind,
			id: n.id, blend: n.blend, range: n.range, params: n.params &&
				n.params.slice(), parent, children: n.children.slice() }
			: { isOp: false, kind: n.kind, id: n.id, parent };
		byId.set(c.id, c);
		return c;
	};
	const root = lean(scene.root, null);
	const todo = [root];
	while (todo.length) {
		const c = todo.pop();
		if (c.isOp) {
			for (let i = 0; i < c.children.length; i++) {
				c.children[i] = lean(c.children[i], c);
				todo.push(c.children[i]);
			}
		}
	}
	const out = { root, byId };
	applyOps(out, ops, layout);
	return out;
}

/* Refuses ops whose result would be over a limit; returns the result. */
function checkLimits(scene, ops, limits) {
	const after = preview(scene, ops);
	const m = measure(after.root);
	/* The daemon counts a tree of p primitives as at least 2p - 1 nodes
	 * (the binary operators its groups fold into). */
	const nodes = Math.max(m.nodes, 2 * m.prims - 1);
	if (nodes > limits.nodes) {
		throw new Refusal(`the scene would need ${nodes} nodes, more ` +
			`than the ${limits.nodes} this daemon takes: delete some ` +
			'shapes first');
	}
	if (m.depth > limits.depth) {
		throw new Refusal(`the tree would nest ${m.depth} levels deep, ` +
			`more than ${limits.depth}: put it under an operator nearer ` +
			'the root');
	}
	if (m.stack > limits.stack) {
		throw new Refusal(`evaluating the tree would need a stack of ` +
			`${m.stack} entries, more than ${limits.stack} (groups nested ` +
			'in later children of groups): put it under an operator ' +
			'nearer the root');
	}
	if (m.domain > limits.domain) {
		throw new Refusal(`a path would pass ${m.domain} domain nodes ` +
			'(elongate, twist, bend, mirror, repeat, scale), more than ' +
			`${limits.domain}: remove one of them first`);
	}
	return after;
}

/* The limits of an action's options o: o.limits, by default the
 * protocol's; none with o.quick (the structural checks only: the hover
 * feedback of a drag, which must stay fast on big scenes). */
function limitsOf(o) {
	return o.quick ? null : o.limits ?? limitsFor(null);
}

/* The result of an action: the EDIT's operations, the node to select
 * once it is applied, and a sentence saying what it did. */
function result(scene, ops, limits, select, text) {
	if (limits) {
		checkLimits(scene, ops, limits);
	}
	return { ops, select, text };
}

/* A group (union) of the root and another subtree in the root's place:
 * how a shape is added or duplicated next to a root that is not an
 * operator, or next to the root itself. */
function besideRoot(scene, extra, id, limits, text) {
	const top = scene.root;
	const union = { isOp: true, kind: 1, id, blend: 0, range: 0,
		children: [top, extra] };
	return result(scene, [{ kind: EDIT.REPLACE, node: top.id,
		subtree: encodeScene({ root: union }) }], limits, extra.id,
	`${text}, grouped with ${nodeName(top)} in a new union #${id}`);
}

/* Adds a primitive of kind under the operator parent (null: beside the
 * root in a new union). o: { translate, size (its lengths' scale),
 * color, limits }. */
export function addPrimitive(scene, parent, kind, o = {}) {
	if (!PRIMS[kind]) {
		throw new Refusal(`there is no primitive kind ${kind}`);
	}
	const limits = limitsOf(o);
	const [id, unionId] = freshIds(scene, 2);
	const node = { isOp: false, kind, id, translate: (o.translate ??
		[0, 0, 0]).slice(), rotate: [0, 0, 0, 1], color: o.color ?? null,
	params: primParams(kind, o.size ?? 1) };
	const what = `added ${nodeName(node)}`;
	if (parent === null) {
		return besideRoot(scene, node, unionId, limits, what);
	}
	const p = get(scene, parent);
	if (!p.isOp) {
		throw new Refusal(`cannot add under ${nodeName(p)}: a primitive ` +
			'has no children. Select an operator (union, intersection, ' +
			'difference) or a shape in one, and add again');
	}
	if (p.unary) {
		throw new Refusal(`cannot add under ${nodeName(p)}: a unary node ` +
			'wraps exactly one child. Select an operator (union, ' +
			'intersection, difference) and add again');
	}
	return result(scene, [{ kind: EDIT.INSERT, parent: p.id,
		position: p.children.length, subtree: encodeScene({ root: node }) }],
	limits, id, `${what} under ${nodeName(p)}`);
}

/* Wraps node id in a new unary node of kind (REPLACE of the node by
 * unary(node), the node's ids kept). */
export function wrap(scene, id, kind, o = {}) {
	if (!UNARY[kind]) {
		throw new Refusal(`there is no unary node kind ${kind}`);
	}
	const n = get(scene, id);
	const [uid] = freshIds(scene, 1);
	const u = { isOp: true, unary: true, kind, id: uid,
		params: unaryDefaults(kind), children: [n] };
	return result(scene, [{ kind: EDIT.REPLACE, node: n.id,
		subtree: encodeScene({ root: u }) }], limitsOf(o),
	uid, `wrapped ${nodeName(n)} in ${nodeName(u)}`);
}

/* Deletes node id (with the unary nodes wrapping it). */
export function remove(scene, id, o = {}) {
	const n = get(scene, id);
	const top = removedTop(n);
	if (!top.parent) {
		throw new Refusal(top === n
			? `cannot delete ${nodeName(n)}: it is the root, and a scene ` +
				'is never empty. Delete the shapes inside it instead'
			: `cannot delete ${nodeName(n)}: the unary nodes above it ` +
				`reach the root (${nodeName(top)}), and a scene is never ` +
				'empty. Replace the scene, or add a shape beside it first');
	}
	return result(scene, [{ kind: EDIT.REMOVE, node: n.id }],
		limitsOf(o), top.parent.id, `deleted ${nodeName(n)}` +
		(top === n ? '' : ` with ${nodeName(top)} around it`));
}

/* Duplicates node id (with the unary nodes wrapping it) next to it, every
 * node of the copy with a fresh id; o.offset moves the copy's primitives
 * so that it can be seen. The copy of a named node id is named "<name>
 * copy" (copyName); the other nodes of the copy keep their names. */
export function duplicate(scene, id, o = {}) {
	const n = get(scene, id);
	const top = removedTop(n);
	const limits = limitsOf(o);
	const ids = freshIds(scene, count(top) + 1);
	const copy = copyTree(top, ids);
	let twin = copy;
	for (let k = n; k !== top; k = k.parent) {
		twin = twin.children[0];
	}
	if (twin.name) {
		twin.name = copyName(twin.name);
	}
	const off = o.offset ?? [0, 0, 0];
	const todo = [copy];
	while (todo.length) {
		const k = todo.pop();
		if (k.isOp) {
			todo.push(...k.children);
		} else {
			k.translate = k.translate.map((v, i) => Math.max(-LIMITS.MAX_ABS,
				Math.min(LIMITS.MAX_ABS, v + off[i])));
		}
	}
	const what = `duplicated ${nodeName(top)} as ${nodeName(copy)}`;
	if (!top.parent) {
		return besideRoot(scene, copy, ids[ids.length - 1], limits, what);
	}
	const p = top.parent;
	return result(scene, [{ kind: EDIT.INSERT, parent: p.id,
		position: p.children.indexOf(top) + 1,
		subtree: encodeScene({ root: copy }) }], limits, copy.id, what);
}

/* Changes operator id to base kind (1 union, 2 intersection, 3
 * difference), smooth with radius blend or sharp, in one SET that obeys
 * PROTOCOL.md section 9: sharp to smooth gives the kind and a blend > 0,
 * smooth to sharp the kind, blend 0 and range 0. A new blend brings the
 * range back to its default, RANGE_PER_BLEND times the blend. */
export function setOperator(scene, id, { base, smooth, blend }, o = {}) {
	const n = get(scene, id);
	if (!isGroup(n)) {
		throw new Refusal(`${nodeName(n)} is not an operator: select a ` +
			'union, intersection or difference to change it');
	}
	if (!(base >= 1 && base <= SMOOTH)) {
		throw new Refusal('choose union, intersection or difference');
	}
	const kind = base + (smooth ? SMOOTH : 0);
	const wasSmooth = n.kind > SMOOTH;
	const fields = [];
	if (kind !== n.kind) {
		fields.push({ field: FIELD.OP_KIND, values: [kind] });
	}
	if (smooth) {
		if (!(blend > 0 && blend <= LIMITS.MAX_ABS)) {
			throw new Refusal('a smooth operator needs a radius above 0 ' +
				`(and at most ${LIMITS.MAX_ABS}): type one`);
		}
		if (!wasSmooth || Math.fround(blend) !== Math.fround(n.blend)) {
			fields.push({ field: FIELD.BLEND, values: [blend] },
				{ field: FIELD.RANGE, values: [RANGE_PER_BLEND * blend] });
		}
	} else if (wasSmooth) {
		fields.push({ field: FIELD.BLEND, values: [0] },
			{ field: FIELD.RANGE, values: [0] });
	}
	if (!fields.length) {
		throw new Refusal(`${nodeName(n)} is already ${OPS[kind]}` +
			(smooth ? ` with radius ${n.blend}` : '') + ': nothing to change');
	}
	return result(scene, [{ kind: EDIT.SET, node: n.id, fields }],
		limitsOf(o), n.id, `${nodeName(n)} is now ` +
		`${OPS[kind]}${smooth ? ` (radius ${blend})` : ''}`);
}

/* Node id, operator target and the subtree a move of id takes away (id
 * with the unary nodes wrapping it), after the checks every move makes:
 * the target is an operator that takes children, outside the subtree,
 * and the subtree is not the root. */
function movable(scene, id, target) {
	const n = get(scene, id);
	const t = get(scene, target);
	const top = removedTop(n);
	if (!isGroup(t)) {
		throw new Refusal(`cannot move ${nodeName(n)} under ` +
			`${nodeName(t)}: ${t.isOp ? 'a unary node wraps exactly one ' +
				'child' : 'a primitive has no children'}. Drop it on an ` +
			'operator (union, intersection, difference)');
	}
	if (within(t, top)) {
		throw new Refusal(`cannot move ${nodeName(n)} under ` +
			`${nodeName(t)}: ${t === top ? 'that is the node itself'
				: 'that is inside it'}, and a node cannot contain itself. ` +
			'Drop it on an operator outside it');
	}
	if (!top.parent) {
		throw new Refusal(`cannot move ${nodeName(n)}: it is the root ` +
			'(with the unary nodes over it); move the shapes inside it ' +
			'instead');
	}
	return { n, t, top };
}

/* Whether operator n is a difference (sharp or smooth): its first child
 * is the shape the others are cut from, so its children's order is part
 * of the shape. */
export function isDifference(n) {
	return isGroup(n) && (n.kind - 1) % SMOOTH + 1 === 3;
}

/* Moves node id (with the unary nodes wrapping it) to the end of
 * operator target's children: a REMOVE and an INSERT of the same subtree
 * with the same ids, in one EDIT (the daemon applies a batch's
 * operations in order, so the ids are free again when the INSERT comes).
 * An operator left with one child is replaced by it, as for any REMOVE. */
export function move(scene, id, target, o = {}) {
	const { n, t, top } = movable(scene, id, target);
	if (top.parent === t) {
		throw new Refusal(`${nodeName(n)} is already in ${nodeName(t)}: ` +
			'drop it on another operator, or between two rows to change ' +
			'its place');
	}
	const ops = [{ kind: EDIT.REMOVE, node: top.id },
		{ kind: EDIT.INSERT, parent: t.id, position: t.children.length,
			subtree: encodeScene({ root: top }) }];
	return result(scene, ops, limitsOf(o), n.id,
		`moved ${nodeName(n)} into ${nodeName(t)}`);
}

/* Moves node id (with the unary nodes wrapping it) to place `at` among
 * operator target's children, at counted in the children as they are
 * now: 0 before the first, target.children.length after the last. Under
 * another operator, or under the same one with three children or more,
 * it is a REMOVE and an INSERT (at the place the REMOVE leaves) of the
 * same subtree in one EDIT, one undo step. Under the same operator with
 * two children a REMOVE would replace the operator by its other child
 * (PROTOCOL.md section 9), so the swap is a REPLACE of the operator by
 * itself with its two children the other way round, every id and name
 * kept. The node's own place (just before or after itself) is refused:
 * nothing would change. In a difference the first child is the shape the
 * others are cut from: a move that changes the first child changes the
 * shape, and the message says so. */
export function place(scene, id, target, at, o = {}) {
	const { n, t, top } = movable(scene, id, target);
	const len = t.children.length;
	if (!Number.isInteger(at) || at < 0 || at > len) {
		throw new Refusal(`there is no place ${at} among the ${len} ` +
			`children of ${nodeName(t)}: pick a place from 0 to ${len}`);
	}
	const from = top.parent === t ? t.children.indexOf(top) : -1;
	if (from >= 0 && (at === from || at === from + 1)) {
		throw new Refusal(`${nodeName(n)} is already at that place in ` +
			`${nodeName(t)}: nothing to move`);
	}
	const pos = from >= 0 && at > from ? at - 1 : at;
	let ops;
	if (from >= 0 && len === 2) {
		const swapped = { ...t, children: [t.children[1], t.children[0]] };
		ops = [{ kind: EDIT.REPLACE, node: t.id,
			subtree: encodeScene({ root: swapped }) }];
	} else {
		ops = [{ kind: EDIT.REMOVE, node: top.id },
			{ kind: EDIT.INSERT, parent: t.id, position: pos,
				subtree: encodeScene({ root: top }) }];
	}
	let text = `moved ${nodeName(n)} to place ${pos + 1} of ` +
		`${nodeName(t)}`;
	if (isDifference(t) && (pos === 0 || from === 0)) {
		const first = pos === 0 ? top : t.children[from === 0 ? 1 : 0];
		text += `: ${nodeName(first)} is now the shape the others are cut ` +
			'from';
	}
	return result(scene, ops, limitsOf(o), n.id, text);
}

/* Moves node id (with the unary nodes wrapping it) one place up (by -1)
 * or down (by 1) among its siblings: Alt+Up and Alt+Down in the
 * outliner. */
export function shift(scene, id, by, o = {}) {
	const n = get(scene, id);
	const top = removedTop(n);
	const p = top.parent;
	if (!p) {
		throw new Refusal(`${nodeName(n)} is the root` + (top === n ? ''
			: ' (with the unary nodes over it)') + ': it has no siblings ' +
			'to change places with');
	}
	const from = p.children.indexOf(top);
	const to = from + by;
	if (to < 0 || to >= p.children.length) {
		throw new Refusal(`${nodeName(top)} is already the ` +
			`${by < 0 ? 'first' : 'last'} child of ${nodeName(p)}: ` +
			`nothing to move ${by < 0 ? 'up' : 'down'}`);
	}
	return place(scene, id, p.id, by < 0 ? to : to + 1, o);
}

/* Names node id (PROTOCOL.md section 9, NAME): one EDIT of one NAME
 * operation, one undo step. An empty name takes the node's name away. */
export function rename(scene, id, name) {
	const n = get(scene, id);
	const why = nameProblem(name);
	if (why) {
		throw new Refusal(`cannot name ${nodeName(n)}: ${why}`);
	}
	if (name === (n.name ?? '')) {
		throw new Refusal(name ? `${nodeName(n)} is already named so: ` +
			'nothing to change' : `${nodeName(n)} has no name: nothing ` +
			'to remove');
	}
	const plain = `${kindName(n)} #${n.id}`;
	return result(scene, [{ kind: EDIT.NAME, node: n.id, name }], null,
		n.id, name ? `named ${plain} “${name}”` : `took the name ` +
		`“${n.name}” away from ${plain}`);
}
