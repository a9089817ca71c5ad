/*
 * The page's primitive table (client/web/prims.js) against the one the
 * server uses (blobtree/prim.c and the kind enum of blobtree.h): the same
 * kinds with the same numbers and names, and for each the same parameters
 * in the same order with the same component counts, offsets and sign
 * rules. The page sends field number 16 + k for parameter k, so a table
 * that drifted would edit the wrong parameter. Read from the C source,
 * since node cannot link the library.
 *
 * Also the page's codec (client/web/protocol.js) against the C headers:
 * its LIMITS against proto_limits.h and the kinds of proto_fields.h, its
 * FIELD numbers against proto_fields.h, and its decoder against that
 * header's table of SET fields (which numbers are fields and how many
 * values each takes); and the table of SET fields in PROTOCOL.md against
 * that of proto_fields.h.
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import { OPS, PRIMS, UNARY, layout, unaryLayout }
	from '../../client/web/prims.js';
import * as P from '../../client/web/protocol.js';

const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..', '..');
const prim = readFileSync(join(ROOT, 'blobtree', 'prim.c'), 'utf8');
const ops = readFileSync(join(ROOT, 'blobtree', 'ops.c'), 'utf8');
const header = readFileSync(join(ROOT, 'blobtree', 'include', 'blobcast',
	'blobtree.h'), 'utf8');

const include = (mod, file) => readFileSync(join(ROOT, mod, 'include',
	'blobcast', file), 'utf8');
const protoLimits = include('protocol', 'proto_limits.h');
const protoFields = include('protocol', 'proto_fields.h');
const baseLimits = include('base', 'limits.h');

/* The object-like #defines of some C headers, each evaluated to a number
 * (integer and float literals, earlier names, + - * << and parentheses). */
function cDefines(...texts) {
	const raw = {};
	for (const text of texts) {
		for (const m of text.matchAll(
			/^#define (\w+) ((?:[^/\n]|\/(?!\*))+)/gm)) {
			raw[m[1]] = m[2].trim();
		}
	}
	const value = {};
	const evaluate = (name, depth = 0) => {
		if (name in value) {
			return value[name];
		}
		assert.ok(depth < 16, `${name}: #defines nest too deep`);
		const expr = raw[name]
			.replace(/[A-Za-z_]\w*/g, (id) => (id in raw
				? `(${evaluate(id, depth + 1)})` : id))
			.replace(/\b(\d+(?:\.\d*)?(?:e[-+]?\d+)?)[uUfF]\b/g, '$1');
		if (!/^[\d\s.e()+\-*<]+$/.test(expr)) {
			value[name] = null; /* not a number (a macro, a string) */
		} else {
			value[name] = Function(`return (${expr});`)();
		}
		return value[name];
	};
	for (const name of Object.keys(raw)) {
		evaluate(name);
	}
	return value;
}

const C = cDefines(baseLimits, protoLimits, protoFields);

/* The rows of BC_PROTO_FIELDS: { name, key, min, max, numbers, flags }. */
function fieldRows() {
	const body = protoFields.match(
		/#define BC_PROTO_FIELDS\(X\)([\s\S]*?)\n\n/)[1];
	const num = (t) => {
		t = t.trim();
		return /^\d+$/.test(t) ? Number(t) : C[t];
	};
	return [...body.replace(/\\\n/g, ' ').matchAll(
		/X\((\w+),\s*(NULL|"\w+"),\s*([\w]+),\s*([\w]+),\s*([\w]+),([^)]*)\)/g)]
		.map((m) => ({ name: m[1], key: m[2] === 'NULL' ? null
			: m[2].slice(1, -1), min: num(m[3]), max: num(m[4]),
		numbers: num(m[5]), flags: m[6].split('|').map((f) => f.trim()) }));
}

test('page limits and kinds: the numbers of proto_limits.h and proto_fields.h',
	() => {
		const names = Object.keys(C).filter((n) => n.startsWith('BC_PROTO_') &&
			!n.startsWith('BC_PROTO_FIELD') && !n.startsWith('BC_PROTO_ON_') &&
			n !== 'BC_PROTO_IN_SCENE' && !/_H$/.test(n));
		assert.ok(names.length >= 20, 'the headers were read');
		for (const n of names) {
			const key = n.slice('BC_PROTO_'.length);
			assert.ok(key in P.LIMITS, `protocol.js LIMITS has no ${key}`);
			assert.equal(P.LIMITS[key], Math.fround(C[n]) === C[n] ? C[n]
				: Math.fround(C[n]), `LIMITS.${key}`);
		}
		for (const key of Object.keys(P.LIMITS)) {
			assert.ok(`BC_PROTO_${key}` in C,
				`LIMITS.${key} is in no C header`);
		}
	});

test('page field numbers: those of proto_fields.h', () => {
	const want = {};
	for (const m of protoFields.matchAll(/^#define BC_PROTO_FIELD_(\w+) (\d+)u/gm)) {
		want[m[1]] = Number(m[2]);
	}
	assert.deepEqual({ ...P.FIELD }, want);
	const rows = fieldRows();
	assert.deepEqual(rows.map((r) => r.name), Object.keys(want));
	/* What the C asserts also hold: rows in order, no shared number,
	 * one number for each field a SET may carry. */
	let next = 0;
	for (const r of rows) {
		assert.ok(want[r.name] >= next, `${r.name} overlaps the row before`);
		next = want[r.name] + r.numbers;
	}
	assert.equal(rows.reduce((a, r) => a + r.numbers, 0),
		P.LIMITS.MAX_SET_FIELDS);
});

test('PROTOCOL.md field table: numbers, counts and nodes as proto_fields.h',
	() => {
		const spec = readFileSync(join(ROOT, 'protocol', 'PROTOCOL.md'),
			'utf8');
		const body = spec.match(/\| field +\| name +\| count +\| applies to +\|.*\n\|[-:| ]+\|\n((?:\|.*\n)+)/)[1];
		/* [field, name, count, applies to, meaning] */
		const docs = body.trim().split('\n').map((l) =>
			l.split(/(?<!\\)\|/).slice(1, -1).map((c) => c.trim()));
		const rows = fieldRows();
		for (const r of rows) {
			const first = P.FIELD[r.name];
			const mine = docs.filter((d) => Number(d[0].split(/\s/)[0]) ===
				first);
			assert.ok(mine.length, `PROTOCOL.md has no field ${first}`);
			const count = r.min === r.max ? `${r.min}` : `${r.min}..${r.max}`;
			assert.ok(mine.some((d) => d[2] === count),
				`field ${first}: ${count} values`);
			const nodes = mine.map((d) => d[3]).join(', ');
			assert.equal(/primitives/.test(nodes),
				r.flags.includes('BC_PROTO_ON_PRIM'), `${first}: primitives`);
			assert.equal(/(^|, )operators/.test(nodes),
				r.flags.includes('BC_PROTO_ON_OP'), `${first}: operators`);
			assert.equal(/unary nodes/.test(nodes),
				r.flags.includes('BC_PROTO_ON_UNARY'), `${first}: unary nodes`);
			if (r.key) {
				assert.ok(mine.some((d) => d[1] === r.key ||
					d[1].endsWith(` ${r.key}`)), `field ${first}: ${r.key}`);
			}
		}
		for (const d of docs) {
			const n = Number(d[0].split(/\s/)[0]);
			assert.ok(rows.some((r) => n >= P.FIELD[r.name] &&
				n < P.FIELD[r.name] + r.numbers), `PROTOCOL.md field ${n}`);
		}
	});

/* One EDIT payload: a SET of node 1 with one field of count values (and
 * room for one value at least, so that a count of 0 is refused for its
 * field, not for the message's length). */
function setPayload(field, count) {
	const b = new DataView(new ArrayBuffer(2 + 1 + 4 + 1 + 2 +
		4 * Math.max(count, 1)));
	b.setUint16(0, 1, true);
	b.setUint8(2, P.EDIT.SET);
	b.setUint32(3, 1, true);
	b.setUint8(7, 1);
	b.setUint8(8, field);
	b.setUint8(9, count);
	for (let k = 0; k < count; k++) {
		b.setFloat32(10 + 4 * k, 0.5, true);
	}
	return new Uint8Array(b.buffer);
}

test('page decoder: SET fields and value counts as proto_fields.h\'s table',
	() => {
		const rows = fieldRows();
		for (let field = 0; field < 64; field++) {
			const r = rows.find((x) => field >= P.FIELD[x.name] &&
				field < P.FIELD[x.name] + x.numbers);
			for (let count = 0; count <= P.LIMITS.MAX_FIELD_VALUES + 1;
				count++) {
				let code = null;
				try {
					P.decodePayload(P.MSG.EDIT, 0, 1,
						setPayload(field, count));
				} catch (e) {
					code = e.code;
				}
				const want = !r ? 'EENUM'
					: count < r.min || count > r.max ? 'EPROTO_COUNT' : null;
				assert.equal(code, want, `field ${field}, ${count} values`);
			}
		}
		/* The page's parameter tables fit the parameter fields. */
		const par = rows.find((r) => r.name === 'PARAM0');
		for (const lay of [...Object.keys(PRIMS).map((k) => layout(Number(k))),
			...Object.keys(UNARY).map((k) => unaryLayout(Number(k)))]) {
			assert.ok(lay.length <= par.numbers);
			for (const d of lay) {
				assert.ok(d.count >= par.min && d.count <= par.max, d.name);
			}
		}
	});

/* enum NAME { A = 0, B, C, ... }: the values in order, from 0. */
function enumValues(name) {
	const body = header.match(new RegExp(`enum ${name} \\{([^}]*)\\}`))[1];
	return body.split(',').map((s) => s.replace(/\/\*.*?\*\//g, '')
		.replace(/=.*/, '').trim()).filter(Boolean);
}

test('primitive kinds: numbers and names as in blobtree', () => {
	const kinds = enumValues('bc_prim');
	assert.equal(kinds[0], 'BC_PRIM_INVALID');
	assert.equal(kinds[kinds.length - 1], 'BC_PRIM_COUNT');
	const table = {};
	for (const m of prim.matchAll(/\[(BC_PRIM_\w+)\]\s*=\s*DESC\("(\w+)",\s*(p_\w+)/g)) {
		table[m[1]] = { name: m[2], tab: m[3] };
	}
	assert.equal(Object.keys(PRIMS).length, kinds.length - 2);
	for (let k = 1; k < kinds.length - 1; k++) {
		const c = table[kinds[k]];
		assert.ok(c, `${kinds[k]} has no row in prim.c`);
		assert.equal(PRIMS[k]?.[0], c.name, `kind ${k}`);
		/* { "name", offset, count, FLAGS, default } rows of its table */
		const rows = prim.match(new RegExp(`${c.tab}\\[\\] = \\{([^;]*)\\};`))[1];
		const want = [...rows.matchAll(/\{"(\w+)",\s*(\d+),\s*(\d+),\s*([^,]+),/g)]
			.map((r) => ({ name: r[1], offset: Number(r[2]),
				count: Number(r[3]), flags: r[4].trim() }));
		const got = layout(k);
		assert.deepEqual(got.map(({ name, offset, count }) =>
			({ name, offset, count })), want.map(({ name, offset, count }) =>
			({ name, offset, count })), `${c.name}: parameters`);
		got.forEach((d, i) => {
			const f = want[i].flags;
			const rule = /POS/.test(f) ? 'pos' : /NONNEG/.test(f) ? 'nonneg'
				: null;
			if (rule) {
				assert.equal(d.rule, rule, `${c.name}.${d.name}`);
			} else {
				assert.ok(d.rule === 'free' || d.rule === 'deg',
					`${c.name}.${d.name}: unsigned in C, ${d.rule} here`);
			}
		});
		assert.ok(got.reduce((a, d) => a + d.count, 0) <=
			P.LIMITS.MAX_PRIM_PARAMS);
	}
	assert.equal(layout(0), null);
	assert.equal(Object.keys(PRIMS).length, P.LIMITS.PRIM_KIND_MAX);
	assert.equal(layout(P.LIMITS.PRIM_KIND_MAX + 1), null);
});

test('operator kinds: numbers and names as in blobtree', () => {
	const kinds = enumValues('bc_op');
	assert.equal(kinds.length - 1, OPS.length);
	assert.equal(OPS.length - 1, P.LIMITS.OP_KIND_MAX);
	kinds.slice(1, -1).forEach((k, i) =>
		assert.equal(`BC_OP_${OPS[i + 1].toUpperCase()}`, k));
});

test('unary node kinds: names, parameter keys and float counts as in blobtree',
	() => {
		const table = {};
		for (const m of ops.matchAll(
			/\[BC_OP_(\w+)\]\s*=\s*\{"(\w+)",\s*(\d+),\s*"(\w+)"\}/g)) {
			table[m[2]] = { floats: Number(m[3]), key: m[4] };
		}
		assert.equal(Object.keys(table).length,
			P.LIMITS.OP_KIND_MAX - P.LIMITS.OP_KIND_FIRST_UNARY + 1);
		for (const [kind, [name, params]] of Object.entries(UNARY)) {
			const c = table[name];
			assert.ok(c, `${name} is not a unary kind in ops.c`);
			assert.equal(OPS[kind], name);
			assert.equal(params[0][0], c.key, `${name}: first key`);
			const lay = unaryLayout(Number(kind));
			assert.equal(lay.reduce((a, d) => a + d.count, 0), c.floats,
				`${name}: float count`);
		}
		assert.equal(unaryLayout(P.LIMITS.OP_KIND_FIRST_UNARY - 1), null);
		for (const k of Object.keys(UNARY)) {
			assert.ok(Number(k) >= P.LIMITS.OP_KIND_FIRST_UNARY &&
				Number(k) <= P.LIMITS.OP_KIND_MAX, `unary kind ${k}`);
			assert.ok(unaryLayout(Number(k)).reduce((a, d) => a + d.count, 0) <=
				P.LIMITS.MAX_UNARY_PARAMS);
		}
	});
