/*
 * The page's primitive table (client/web/prims.js) against the one the
 * server uses (blobtree/prim.c and the kind enum of blobtree.h): the same
 * kinds with the same numbers and names, and for each the same parameters
 * in the same order with the same component counts, offsets and sign
 * rules. The page sends field number 16 + k for parameter k, so a table
 * that drifted would edit the wrong parameter. Read from the C source,
 * since node cannot link the library.
 */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import { OPS, PRIMS, UNARY, layout, unaryLayout }
	from '../../client/web/prims.js';

const ROOT = join(dirname(fileURLToPath(import.meta.url)), '..', '..');
const prim = readFileSync(join(ROOT, 'blobtree', 'prim.c'), 'utf8');
const ops = readFileSync(join(ROOT, 'blobtree', 'ops.c'), 'utf8');
const header = readFileSync(join(ROOT, 'blobtree', 'include', 'blobcast',
	'blobtree.h'), 'utf8');

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
		assert.ok(got.reduce((a, d) => a + d.count, 0) <= 8);
	}
	assert.equal(layout(0), null);
	assert.equal(layout(33), null);
});

test('operator kinds: numbers and names as in blobtree', () => {
	const kinds = enumValues('bc_op');
	assert.equal(kinds.length - 1, OPS.length);
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
		assert.equal(Object.keys(table).length, 8);
		for (const [kind, [name, params]] of Object.entries(UNARY)) {
			const c = table[name];
			assert.ok(c, `${name} is not a unary kind in ops.c`);
			assert.equal(OPS[kind], name);
			assert.equal(params[0][0], c.key, `${name}: first key`);
			const lay = unaryLayout(Number(kind));
			assert.equal(lay.reduce((a, d) => a + d.count, 0), c.floats,
				`${name}: float count`);
		}
		assert.equal(unaryLayout(6), null);
	});
