/*
 * The page's mirror of a scene (protocol.js's parseScene tree) written as
 * a JSON scene file, version 1 (docs/scene-format.md), the file that
 * `blobcast load` and blobcastd read. It is written as blobtree's own
 * writer (bc_scene_to_json) writes it, byte for byte: one primitive per
 * line, every id, floats with the fewest digits of "%.6g" or "%.9g" that
 * read back to the same bits, defaults left out by the same rules. So the
 * file equals `blobcast scene` of the same session, and loads back to the
 * same scene. Pure functions, no DOM; tests/web/scenejson.test.mjs checks
 * them.
 */
import { PRIMS, OPS, UNARY, layout, unaryLayout } from './prims.js';

/* A node at depth d is a JSON object at depth 2d: files nest at most this
 * many levels (BC_SCENE_JSON_MAX_DEPTH; deeper trees travel as binary). */
export const JSON_MAX_DEPTH = 1023;
/* Indentation shows the first levels only, as blobtree's writer does. */
const INDENT_LEVELS = 32;

/* Parameters a scene file may leave out, with the default the writer
 * leaves out (BC_PARAM_OPTIONAL in blobtree/prim.c; the unit test reads
 * it): kind -> { name: default }. */
export const OPTIONAL = Object.freeze({ 2: { round: 0 }, 23: { round: 0 } });

/* [digits, exponent] of |v| rounded to n significant digits, half to
 * even on the exact binary value, as C's printf rounds: |v| is about
 * d0.d1d2... x 10^exponent. */
function roundDigits(v, n) {
	/* toExponential(100) is exact for every float a scene can hold
	 * (down to about 1e-30; smaller magnitudes round once more). */
	const [m, e] = Math.abs(v).toExponential(100).split('e');
	const all = m.replace('.', '');
	const d = Array.from(all.slice(0, n), Number);
	let x = Number(e);
	const next = all.charCodeAt(n) - 48;
	const beyond = /[1-9]/.test(all.slice(n + 1));
	if (next > 5 || (next === 5 && (beyond || d[n - 1] % 2 === 1))) {
		let i = n - 1;
		while (i >= 0 && d[i] === 9) {
			d[i--] = 0;
		}
		if (i < 0) {
			d.unshift(1);
			d.pop();
			x++;
		} else {
			d[i]++;
		}
	}
	return [d, x];
}

/* C's "%.<n>g" of a finite v. */
export function formatG(v, n) {
	if (v === 0) {
		return Object.is(v, -0) ? '-0' : '0';
	}
	const [d, x] = roundDigits(v, n);
	while (d.length > 1 && d[d.length - 1] === 0) {
		d.pop();
	}
	const sign = v < 0 ? '-' : '';
	if (x < -4 || x >= n) {
		const frac = d.length > 1 ? `.${d.slice(1).join('')}` : '';
		return `${sign}${d[0]}${frac}e${x < 0 ? '-' : '+'}` +
			String(Math.abs(x)).padStart(2, '0');
	}
	if (x < 0) {
		return `${sign}0.${'0'.repeat(-x - 1)}${d.join('')}`;
	}
	const int = d.slice(0, x + 1).join('').padEnd(x + 1, '0');
	const frac = d.slice(x + 1).join('');
	return `${sign}${int}${frac ? `.${frac}` : ''}`;
}

/* A binary32 value as blobtree writes it: six significant digits when
 * they read back (strtod, then float) to the same bits, else nine, which
 * always do; -0 as "-0.0" (a bare -0 reads as the integer 0). */
export function formatFloat(f) {
	if (Object.is(f, -0)) {
		return '-0.0';
	}
	const six = formatG(f, 6);
	return Math.fround(Number(six)) === f ? six : formatG(f, 9);
}

const floats = (v) => (v.length === 1 ? formatFloat(v[0])
	: `[${v.map(formatFloat).join(', ')}]`);
const member = (key, v) => `, "${key}": ${floats(v)}`;
/* Bit equality: -0.0 is not the default 0.0. */
const sameBits = (a, b) => a.length === b.length &&
	a.every((v, i) => Object.is(v, b[i]));
const indent = (depth) => ' '.repeat(2 + 2 * Math.min(depth,
	INDENT_LEVELS));

/* A JSON string as blobtree writes a name: the quote and the backslash
 * after a backslash, control characters and DEL as \u00xx (lower-case
 * hex), everything else as it is (UTF-8 once in the file). */
export function jsonString(s) {
	return `"${s.replace(/["\\\u0000-\u001f\u007f]/g, (c) => (c === '"' ||
		c === '\\' ? `\\${c}` : `\\u${c.charCodeAt(0).toString(16)
			.padStart(4, '0')}`))}"`;
}

/* `, "name": "wheel"` for a named node (1..64 bytes, docs/scene-format.md),
 * nothing for the others. */
const nameMember = (n) => (n.name ? `, "name": ${jsonString(n.name)}` : '');

function fail(n, why) {
	throw new Error(`node ${n.id}: ${why}; the scene cannot be written ` +
		'as a JSON scene file');
}

/* A node whose parameters the page could not follow (protocol.js's
 * applyOps marks it stale) would be written wrong: refuse instead. */
function current(n) {
	if (n.stale) {
		fail(n, 'this page could not follow an edit of it (reload the ' +
			'page to fetch the scene again)');
	}
}

function primText(n) {
	current(n);
	const info = PRIMS[n.kind];
	const lay = layout(n.kind);
	if (!info || !lay) {
		fail(n, `primitive kind ${n.kind} is unknown to this page`);
	}
	if (lay.reduce((a, d) => a + d.count, 0) !== n.params.length) {
		fail(n, `${info[0]} has ${n.params.length} parameters, not the ` +
			'layout this page knows');
	}
	let s = `{"type": "${info[0]}", "id": ${n.id}${nameMember(n)}`;
	for (const d of lay) {
		const v = n.params.slice(d.offset, d.offset + d.count);
		const opt = OPTIONAL[n.kind]?.[d.name];
		if (opt !== undefined && sameBits(v, new Array(d.count).fill(opt))) {
			continue;
		}
		s += member(d.name, v);
	}
	if (!sameBits(n.translate, [0, 0, 0])) {
		s += member('translate', n.translate);
	}
	if (!sameBits(n.rotate, [0, 0, 0, 1])) {
		s += member('rotate', n.rotate);
	}
	if (n.color) {
		s += member('color', n.color);
	}
	return `${s}}`;
}

function opText(n) {
	current(n);
	const name = OPS[n.kind];
	if (!name) {
		fail(n, `operator kind ${n.kind} is unknown to this page`);
	}
	let s = `{"type": "${name}", "id": ${n.id}${nameMember(n)}`;
	if (n.unary) {
		const lay = unaryLayout(n.kind);
		if (!lay || lay.reduce((a, d) => a + d.count, 0) !==
			n.params.length) {
			fail(n, `${name} has ${n.params.length} parameters`);
		}
		if (UNARY[n.kind][0] === 'mirror') {
			const mask = n.params[0];
			s += `, "axes": "${['x', 'y', 'z'].filter((c, k) =>
				mask & (1 << k)).join('')}"`;
		} else {
			for (const d of lay) {
				s += member(d.name, n.params.slice(d.offset,
					d.offset + d.count));
			}
		}
	} else if (n.kind >= 4 && n.kind <= 6) {
		s += member('blend', [n.blend]);
		/* The daemon stores and sends the range it uses; 0 would mean
		 * "the default", which a file says by leaving it out. */
		if (n.range !== 0) {
			s += member('range', [n.range]);
		}
	}
	return `${s}, "children": [\n`;
}

/* The scene file of a tree ({ camera, root } from parseScene) as an
 * array of strings to be joined (a Blob takes them as they are; a big
 * scene is never one string). Throws an Error saying why when the tree
 * cannot be a scene file: deeper than JSON_MAX_DEPTH, holding a kind
 * this page does not know, or a node it could not keep up to date. Walks
 * without recursion. */
export function sceneJsonParts({ camera, root }) {
	if (!root) {
		throw new Error('the scene is empty; there is nothing to write');
	}
	const out = ['{\n  "blobcast": 1,\n'];
	if (camera) {
		out.push(`  "camera": {"eye": ${floats(camera.eye)}` +
			member('target', camera.target) + member('up', camera.up) +
			member('fov_y_deg', [camera.fov_y_deg]) + '},\n');
	}
	out.push('  "root": ');
	const left = []; /* children still to write, per open operator */
	const todo = [[root, 0]];
	while (todo.length) {
		const [n, depth] = todo.pop();
		if (depth >= JSON_MAX_DEPTH) {
			fail(n, `it lies ${depth + 1} levels deep, more than the ` +
				`${JSON_MAX_DEPTH} a JSON scene file holds (the daemon ` +
				'keeps such scenes in binary)');
		}
		if (depth) {
			out.push(indent(depth));
		}
		if (n.isOp) {
			out.push(opText(n));
			left.push(n.children.length);
			for (let i = n.children.length - 1; i >= 0; i--) {
				todo.push([n.children[i], depth + 1]);
			}
			continue;
		}
		out.push(primText(n));
		/* A finished node: separate it from its next sibling, or close
		 * every operator it was the last descendant of. */
		while (left.length) {
			if (--left[left.length - 1] > 0) {
				out.push(',\n');
				break;
			}
			left.pop();
			out.push(`\n${indent(left.length)}]}`);
		}
	}
	out.push('\n}\n');
	return out;
}

/* The same as one string. */
export function sceneToJson(scene) {
	return sceneJsonParts(scene).join('');
}
