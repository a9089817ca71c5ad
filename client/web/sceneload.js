/*
 * A scene file a person picks in the page, read into the scene encoding
 * that SCENE_LOAD carries (PROTOCOL.md 7.9, section 8), so that loading it
 * from the page does what `blobcast load` of the same file does:
 *  - a binary scene file ("BCS1", length, CRC-32, the encoding;
 *    docs/scene-format.md, "Binary scene file") is checked and sent as it
 *    is;
 *  - a JSON scene file is read by the rules of docs/scene-format.md as
 *    blobtree's reader applies them (blobtree/json.c): the same keys
 *    required, optional and refused, numbers taken to binary32 as jansson
 *    and the reader do (the correctly rounded double, then float), ids
 *    given to nodes without one the same way, a camera always (the file's,
 *    or bc_camera_default()'s), and the same limits on names and nesting;
 *    what the reader leaves to the tree's builder (shape rules, a
 *    quaternion's norm, the evaluation stack) the daemon checks when it
 *    decodes the scene, and says why it refuses.
 * JSON.parse reports neither duplicate keys nor whether a number was
 * written as an integer, both of which the format cares about ("id" and
 * "blobcast" take integers), so one pass over the text's tokens finds
 * them (keyScan); JSON.parse itself reads the values.
 * Pure functions, no DOM: tests/web/sceneload.test.mjs checks them
 * against the CLI's reader.
 */
import * as P from './protocol.js';
import { OPS, PRIMS, UNARY, layout, unaryLayout } from './prims.js';
import { JSON_MAX_DEPTH, OPTIONAL } from './scenejson.js';

/* BC_SCENE_JSON_MAX_BYTES: a longer text is refused from its size. */
export const JSON_MAX_BYTES = 384 * 1024 * 1024;
/* BC_TREE_NAME_MAX. */
const NAME_MAX = 64;
const ID_MAX = 0xffffffff;
/* bc_camera_default(). */
const DEFAULT_CAMERA = Object.freeze({ eye: [0, 0, 6], target: [0, 0, 0],
	up: [0, 1, 0], fov_y_deg: 45 });

const PRIM_KIND = new Map(Object.entries(PRIMS).map(([k, p]) =>
	[p[0], Number(k)]));
const OP_KIND = new Map(OPS.map((n, k) => [n, k]).filter(([n]) => n));

/* A file the page will not send: the message says where and why, as the
 * CLI's reader would ("root.children[1]: missing key "radius" (a sphere
 * needs it)"); code is the error name blobtree gives. */
export class SceneFileError extends Error {
	constructor(code, message) {
		super(message);
		this.code = code;
	}
}

const fail = (code, path, msg) => {
	throw new SceneFileError(code, path ? `${path}: ${msg}` : msg);
};

/* jansson's names for a JSON value's kind; raw is its token's text, which
 * tells an integer from a real number. */
function kindOf(v, raw) {
	if (v === null) {
		return 'null';
	}
	if (Array.isArray(v)) {
		return 'array';
	}
	switch (typeof v) {
	case 'object':
		return 'object';
	case 'string':
		return 'string';
	case 'boolean':
		return v ? 'true' : 'false';
	default:
		return raw !== undefined && /^-?\d+$/.test(raw) ? 'integer'
			: 'real number';
	}
}

/*
 * One pass over the tokens of a text JSON.parse has accepted: refuses an
 * object with a key twice (as jansson's JSON_REJECT_DUPLICATES), and
 * returns, for every object that has an "id" or "blobcast" key, the
 * text of that value (in the order JSON.parse meets the objects), so that
 * an integer can be told from a real number.
 */
function keyScan(text) {
	const raws = []; /* per object, in order of '{': { id, blobcast } */
	const stack = []; /* { obj: true, keys: Set, expectKey, raw } or {} */
	let line = 1, col = 0;
	for (let i = 0; i < text.length; i++) {
		const ch = text[i];
		col++;
		if (ch === '\n') {
			line++;
			col = 0;
			continue;
		}
		const top = stack[stack.length - 1];
		if (ch === '{') {
			const raw = {};
			raws.push(raw);
			stack.push({ obj: true, keys: new Set(), expectKey: true, raw,
				last: null });
		} else if (ch === '[') {
			stack.push({});
		} else if (ch === '}' || ch === ']') {
			stack.pop();
		} else if (ch === ':') {
			top.expectKey = false;
			if (top.last === 'id' || top.last === 'blobcast') {
				/* The value's token: up to the next , } or ]. */
				const m = /^\s*([^,}\]\s]+)/.exec(text.slice(i + 1,
					i + 80));
				top.raw[top.last] = m ? m[1] : '';
			}
		} else if (ch === ',') {
			if (top?.obj) {
				top.expectKey = true;
			}
		} else if (ch === '"') {
			let j = i + 1;
			while (text[j] !== '"') {
				j += text[j] === '\\' ? 2 : 1;
			}
			if (top?.obj && top.expectKey) {
				const key = JSON.parse(text.slice(i, j + 1));
				if (top.keys.has(key)) {
					fail('EPARSE', '', `line ${line} column ${col}: ` +
						`duplicate object key near '${text.slice(i, j + 1)
							.slice(0, 40)}'`);
				}
				top.keys.add(key);
				top.last = key;
			}
			col += j - i;
			i = j;
		}
	}
	return raws;
}

/* A number member as binary32 (get_float). */
function num(v, path, raw) {
	if (typeof v !== 'number') {
		fail('EPARSE', path, `expected a number, got ${kindOf(v, raw)}`);
	}
	const f = Math.fround(v);
	if (!Number.isFinite(f)) {
		fail('ENONFINITE', path, `${v} is not a finite 32-bit float`);
	}
	return f;
}

/* An array of exactly n numbers (get_floats); n 1 takes a plain number. */
function nums(v, path, n) {
	if (n === 1) {
		return [num(v, path)];
	}
	if (!Array.isArray(v)) {
		fail('EPARSE', path, `expected an array of ${n} numbers, got ` +
			kindOf(v));
	}
	if (v.length !== n) {
		fail('EPARSE', path, `expected an array of ${n} numbers, got ` +
			`${v.length}`);
	}
	return v.map((x, k) => num(x, `${path}[${k}]`));
}

/* Refuses keys outside allowed (check_keys); every node may be named. */
function checkKeys(obj, allowed, what, path) {
	for (const key of Object.keys(obj)) {
		if (allowed.includes(key) || key === 'name') {
			continue;
		}
		if (key === 'blend' || key === 'range') {
			fail('EPARSE', path, `"${key}" is only for smooth operators, ` +
				`not ${what}`);
		}
		fail('EPARSE', path, `unknown key "${key.slice(0, 40)}" for ${what}`);
	}
}

function missing(path, key, what) {
	fail('EPARSE', path, `missing key "${key}" (a ${what} needs it)`);
}

/* The node's "name", when it has one (set_name): 1..64 bytes of UTF-8. */
function nameOf(obj, path) {
	if (!('name' in obj)) {
		return undefined;
	}
	const v = obj.name;
	if (typeof v !== 'string') {
		fail('EPARSE', `${path}.name`, `expected a string, got ${kindOf(v)}`);
	}
	/* A lone surrogate (a "\ud800" escape) is no UTF-8: jansson refuses
	 * it where TextEncoder would make it U+FFFD. */
	if (/[\ud800-\udbff](?![\udc00-\udfff])|(?:^|[^\ud800-\udbff])[\udc00-\udfff]/
		.test(v)) {
		fail('EPARSE', `${path}.name`, 'not valid UTF-8 (a lone ' +
			'surrogate)');
	}
	const bytes = new TextEncoder().encode(v).length;
	if (bytes === 0) {
		fail('ERANGE', `${path}.name`, `a name is 1..${NAME_MAX} bytes; ` +
			'leave the key out for none');
	}
	if (bytes > NAME_MAX || v.includes('\u0000')) {
		fail('ERANGE', `${path}.name`, `a name is 1..${NAME_MAX} bytes ` +
			'of UTF-8 without NUL');
	}
	return v;
}

/* One node's own fields (not its children), shaped as parseScene makes
 * them; children holds the JSON children still to read. */
function readNode(obj, path, id) {
	if (obj === null || typeof obj !== 'object' || Array.isArray(obj)) {
		fail('EPARSE', path, `expected an object, got ${kindOf(obj)}`);
	}
	if (!('type' in obj)) {
		fail('EPARSE', path, 'missing key "type"');
	}
	const type = obj.type;
	if (typeof type !== 'string') {
		fail('EPARSE', `${path}.type`, `expected a string, got ` +
			kindOf(type));
	}
	const name = nameOf(obj, path);
	if (PRIM_KIND.has(type)) {
		const kind = PRIM_KIND.get(type);
		const lay = layout(kind);
		checkKeys(obj, ['type', 'id', 'translate', 'rotate', 'color',
			...lay.map((d) => d.name)], type, path);
		const params = [];
		for (const d of lay) {
			if (!(d.name in obj)) {
				const opt = OPTIONAL[kind]?.[d.name];
				if (opt === undefined) {
					missing(path, d.name, type);
				}
				params.push(...new Array(d.count).fill(opt));
				continue;
			}
			params.push(...nums(obj[d.name], `${path}.${d.name}`, d.count));
		}
		return { n: { isOp: false, kind, id, name, params,
			translate: 'translate' in obj ? nums(obj.translate,
				`${path}.translate`, 3) : [0, 0, 0],
			rotate: 'rotate' in obj ? nums(obj.rotate, `${path}.rotate`, 4)
				: [0, 0, 0, 1],
			color: 'color' in obj ? nums(obj.color, `${path}.color`, 3)
				: null }, kids: null };
	}
	const kind = OP_KIND.get(type);
	if (kind === undefined) {
		fail('EENUM', path, `unknown primitive type "${type.slice(0, 40)}"`);
	}
	const unary = kind >= 7;
	let n;
	if (unary) {
		const [uname, params] = UNARY[kind];
		const repeat = uname === 'repeat';
		const key = params[0][0];
		checkKeys(obj, ['type', 'id', 'children', key,
			...(repeat ? ['count'] : [])], uname, path);
		if (!(key in obj)) {
			missing(path, key, uname);
		}
		let values;
		if (uname === 'mirror') {
			const v = obj.axes;
			if (typeof v !== 'string') {
				fail('EPARSE', `${path}.axes`, 'expected a string such as ' +
					`"xz", got ${kindOf(v)}`);
			}
			let mask = 0;
			for (const c of v) {
				const bit = { x: 1, y: 2, z: 4 }[c];
				if (!bit || mask & bit) {
					mask = 0;
					break;
				}
				mask |= bit;
			}
			if (!mask) {
				fail('ERANGE', `${path}.axes`, 'expected 1 to 3 distinct ' +
					'letters of x, y, z');
			}
			values = [mask];
		} else {
			values = nums(obj[key], `${path}.${key}`, params[0][1]);
			if (repeat) {
				if (!('count' in obj)) {
					missing(path, 'count', 'repeat');
				}
				values.push(...nums(obj.count, `${path}.count`, 3));
			}
		}
		const lay = unaryLayout(kind);
		if (values.length !== lay.reduce((a, d) => a + d.count, 0)) {
			fail('EINVAL', path, `${uname}: parameter layout`);
		}
		n = { isOp: true, unary: true, kind, id, name, params: values };
	} else {
		const smooth = kind >= 4;
		checkKeys(obj, smooth ? ['type', 'id', 'children', 'blend', 'range']
			: ['type', 'id', 'children'], type, path);
		let blend = 0, range = 0;
		if (smooth) {
			if (!('blend' in obj)) {
				missing(path, 'blend', type);
			}
			blend = num(obj.blend, `${path}.blend`);
			if ('range' in obj) {
				range = num(obj.range, `${path}.range`);
				/* 0 asks the builder for the default: an explicit 0
				 * is a mistake. */
				if (!(range > 0)) {
					fail('ERANGE', `${path}.range`, `${range} must be ` +
						'positive');
				}
			}
		}
		n = { isOp: true, kind, id, name, blend, range };
	}
	if (!('children' in obj)) {
		missing(path, 'children', unary ? UNARY[kind][0] : type);
	}
	const kids = obj.children;
	if (!Array.isArray(kids)) {
		fail(unary ? 'EINVAL' : 'EPARSE', `${path}.children`, unary
			? `a ${UNARY[kind][0]} takes an array of exactly one child`
			: `expected an array, got ${kindOf(kids)}`);
	}
	if (unary && kids.length !== 1) {
		fail('EINVAL', `${path}.children`, `a ${UNARY[kind][0]} takes an ` +
			'array of exactly one child');
	}
	if (!unary && kids.length < 2) {
		fail('EINVAL', `${path}.children`, 'an operator needs two or more ' +
			`children, got ${kids.length}`);
	}
	n.children = new Array(kids.length);
	return { n, kids };
}

/* A node's id as the file gives it: 0 when it gives none. */
function idOf(obj, path, raw) {
	if (obj === null || typeof obj !== 'object' || !('id' in obj)) {
		return 0;
	}
	const v = obj.id;
	if (typeof v !== 'number' || !/^-?\d+$/.test(raw ?? '')) {
		fail('EPARSE', `${path}.id`, `expected an integer, got ` +
			kindOf(v, raw));
	}
	if (v < 1 || v > ID_MAX) {
		fail('ERANGE', `${path}.id`, `${raw} is outside 1..4294967295`);
	}
	return v;
}

function readCamera(obj) {
	if (obj === null || typeof obj !== 'object' || Array.isArray(obj)) {
		fail('EPARSE', 'camera', `expected an object, got ${kindOf(obj)}`);
	}
	for (const key of Object.keys(obj)) {
		if (!['eye', 'target', 'up', 'fov_y_deg'].includes(key)) {
			fail('EPARSE', 'camera', `unknown key "${key.slice(0, 40)}"`);
		}
	}
	const c = DEFAULT_CAMERA;
	return {
		eye: 'eye' in obj ? nums(obj.eye, 'camera.eye', 3) : c.eye.slice(),
		target: 'target' in obj ? nums(obj.target, 'camera.target', 3)
			: c.target.slice(),
		up: 'up' in obj ? nums(obj.up, 'camera.up', 3) : c.up.slice(),
		fov_y_deg: 'fov_y_deg' in obj ? num(obj.fov_y_deg,
			'camera.fov_y_deg') : c.fov_y_deg,
	};
}

/* { camera, root, nodes } of a JSON scene file's text, nodes shaped as
 * parseScene makes them (encodeScene takes them); the text's size limit
 * is readSceneFile's, on its bytes. Throws SceneFileError. */
export function sceneFromJson(text) {
	let doc;
	try {
		doc = JSON.parse(text);
	} catch (e) {
		fail('EPARSE', '', `not JSON: ${e.message}`);
	}
	const raws = keyScan(text);
	if (doc === null || typeof doc !== 'object' || Array.isArray(doc)) {
		fail('EPARSE', '', `expected an object, got ${kindOf(doc)}`);
	}
	for (const key of Object.keys(doc)) {
		if (!['blobcast', 'camera', 'root'].includes(key)) {
			fail('EPARSE', '', `unknown key "${key.slice(0, 40)}"`);
		}
	}
	/* raws follows the objects in text order, which JSON.parse's values
	 * keep: the document first, then a depth-first walk of its values. */
	let next = 0;
	const rawFor = new Map();
	const walk = [doc];
	while (walk.length) {
		const v = walk.pop();
		if (v === null || typeof v !== 'object') {
			continue;
		}
		if (!Array.isArray(v)) {
			rawFor.set(v, raws[next++]);
		}
		const vals = Array.isArray(v) ? v : Object.values(v);
		for (let i = vals.length - 1; i >= 0; i--) {
			walk.push(vals[i]);
		}
	}
	const top = rawFor.get(doc) ?? {};
	if (!('blobcast' in doc)) {
		fail('EPARSE', '', 'missing key "blobcast" (the format version, 1)');
	}
	if (kindOf(doc.blobcast, top.blobcast) !== 'integer') {
		fail('EPARSE', 'blobcast', `expected an integer, got ` +
			kindOf(doc.blobcast, top.blobcast));
	}
	if (doc.blobcast !== 1) {
		fail('ENOTSUP', 'blobcast', `version ${top.blobcast} is not ` +
			'supported (this page reads 1)');
	}
	if (!('root' in doc)) {
		fail('EPARSE', '', 'missing key "root"');
	}
	const camera = 'camera' in doc ? readCamera(doc.camera)
		: { ...DEFAULT_CAMERA, eye: DEFAULT_CAMERA.eye.slice(),
			target: DEFAULT_CAMERA.target.slice(),
			up: DEFAULT_CAMERA.up.slice() };
	/* The ids the file names, first (collect_ids), so that an id given to
	 * a node without one never takes an id named later in the file. */
	const named = new Set();
	const ids = new Map(); /* JSON node -> id */
	const all = [[doc.root, 'root']];
	while (all.length) {
		const [o, path] = all.pop();
		const id = idOf(o, path, rawFor.get(o)?.id);
		if (id) {
			if (named.has(id)) {
				fail('EDUPID', path, `tree: duplicate id ${id}`);
			}
			named.add(id);
		}
		ids.set(o, id);
		if (o && typeof o === 'object' && Array.isArray(o.children)) {
			o.children.forEach((c, i) => all.push([c,
				`${path}.children[${i}]`]));
		}
	}
	let fresh = 1;
	const freshId = () => {
		while (named.has(fresh)) {
			fresh++;
		}
		if (fresh > ID_MAX) {
			fail('ELIMIT', '', 'no id left to give');
		}
		return fresh++;
	};
	/* Pre-order, as the reader builds: a node's id before its children's. */
	let nodes = 0;
	const first = readNode(doc.root, 'root', ids.get(doc.root) || freshId());
	nodes++;
	const todo = [{ ...first, path: 'root', depth: 1, i: 0 }];
	while (todo.length) {
		const t = todo[todo.length - 1];
		if (!t.kids || t.i === t.kids.length) {
			todo.pop();
			continue;
		}
		const i = t.i++;
		const o = t.kids[i];
		const path = `${t.path}.children[${i}]`;
		if (t.depth + 1 > JSON_MAX_DEPTH) {
			fail('EDEPTH', path, `a JSON scene nests at most ` +
				`${JSON_MAX_DEPTH} levels (use the binary form)`);
		}
		const r = readNode(o, path, ids.get(o) || freshId());
		nodes++;
		r.n.parent = t.n;
		t.n.children[i] = r.n;
		todo.push({ ...r, path, depth: t.depth + 1, i: 0 });
	}
	return { camera, root: first.n, nodes };
}

/* The scene bytes of a binary scene file, checked (magic, length, CRC-32,
 * the encoding as scanScene checks it), and its node count. */
export function sceneFromBinary(bytes) {
	const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.length);
	if (bytes.length < 12) {
		fail('EPARSE', '', 'not a binary scene file: shorter than its ' +
			'12-byte header');
	}
	const len = dv.getUint32(4, true);
	if (len !== bytes.length - 12) {
		fail('EPARSE', '', `the header says ${len} scene bytes, the file ` +
			`holds ${bytes.length - 12}`);
	}
	const body = bytes.subarray(12);
	if (P.crc32(body) !== dv.getUint32(8, true)) {
		fail('EPARSE', '', 'the scene bytes do not match their CRC-32 ' +
			'(a damaged file)');
	}
	let info;
	try {
		info = P.scanScene(body);
	} catch (e) {
		fail(e.code ?? 'EPARSE', '', `the scene does not decode: ${e.message}`);
	}
	return { bytes: body, nodes: info.nodes };
}

/* What SCENE_LOAD carries for a file's bytes (JSON or binary, told by the
 * binary file's "BCS1"): { bytes, nodes }. Throws SceneFileError. */
export function readSceneFile(bytes) {
	if (bytes.length >= 4 && bytes[0] === 0x42 && bytes[1] === 0x43 &&
		bytes[2] === 0x53 && bytes[3] === 0x31) {
		return sceneFromBinary(bytes);
	}
	if (bytes.length > JSON_MAX_BYTES) {
		fail('ELIMIT', '', `the text is over ${JSON_MAX_BYTES} bytes`);
	}
	let text;
	try {
		/* A byte order mark stays in the text (and JSON.parse refuses
		 * it, as jansson does). */
		text = new TextDecoder('utf-8', { fatal: true, ignoreBOM: true })
			.decode(bytes);
	} catch {
		fail('EPARSE', '', 'neither a binary scene file nor UTF-8 text');
	}
	const scene = sceneFromJson(text);
	return { bytes: P.encodeScene(scene), nodes: scene.nodes };
}

/* The SCENE_LOAD messages that carry scene bytes when each may hold room
 * bytes of them (PROTOCOL.md 7.10.1): [{ scene, flags }], one whole
 * message (flags 0) when they fit, else parts: MORE, then MORE | CONT,
 * the last CONT, every piece at least one byte. */
export function sceneParts(bytes, room) {
	if (!(room >= 1)) {
		throw new RangeError(`no room for a scene piece (${room} bytes)`);
	}
	const n = Math.max(1, Math.ceil(bytes.length / room));
	const out = [];
	for (let k = 0; k < n; k++) {
		out.push({ scene: bytes.subarray(k * room, (k + 1) * room),
			flags: n === 1 ? 0 : (k > 0 ? P.FLAG.CONT : 0) |
				(k < n - 1 ? P.FLAG.MORE : 0) });
	}
	return out;
}
