#!/usr/bin/env node
/*
 * The page's mirror of a big scene, side by side: how long each given
 * protocol.js takes to parse a SCENE_STATE's scene bytes (parseScene, what
 * the page does on joining a session) and how much JavaScript heap the
 * mirror then holds. Each run is a fresh node process (a clean heap); the
 * builds take turns. Prints a Markdown table row per protocol.js: medians
 * of the milliseconds and of the heap (MiB, after a full collection, less
 * the heap before parsing).
 *
 *   node bench/bench_page_scene.mjs [--count N] [--file F.bin] [--reps R]
 *        PROTOCOL_JS...
 *
 * The scene: F, a binary scene file (`blobcast scene --out F --binary`),
 * else N (default 1 000 000) coloured spheres of radius 0.05 to 0.15,
 * unrotated, uniform in a cube, under one smooth union -- fig18's spheres
 * as blobcastd holds them. R defaults to 3. An earlier protocol.js:
 * `git show REV:client/web/protocol.js > /tmp/old-protocol.js`.
 */
import { spawnSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const MAGIC = 'BCS1';
const HEADER = 12;

/* The scene bytes of a binary scene file (its header checked for the
 * magic and length only: the parse checks the rest). */
function fileScene(path) {
	const f = readFileSync(path);
	if (f.length < HEADER || f.toString('latin1', 0, 4) !== MAGIC ||
		f.readUInt32LE(4) !== f.length - HEADER) {
		throw new Error(`${path} is not a binary scene file`);
	}
	return new Uint8Array(f.buffer, f.byteOffset + HEADER, f.length - HEADER);
}

/* N spheres as described above, from a fixed seed. */
function spheres(P, n) {
	let x = 0x2545f491;
	const rnd = () => {
		x ^= x << 13;
		x ^= x >>> 17;
		x ^= x << 5;
		return (x >>> 0) / 4294967296;
	};
	const children = new Array(n);
	for (let i = 0; i < n; i++) {
		children[i] = { isOp: false, kind: 1, id: i + 2,
			translate: [rnd() * 20 - 10, rnd() * 20 - 10, rnd() * 20 - 10],
			rotate: [0, 0, 0, 1], color: [rnd(), rnd(), rnd()],
			params: [0.05 + rnd() * 0.1] };
	}
	return P.encodeScene({ root: { isOp: true, kind: 4, id: 1,
		blend: 0.1, range: 0.2, children } });
}

/* --child PROTOCOL_JS (file | count): one parse; prints "ms heap_mib". */
async function child(proto, file, count) {
	const P = await import(pathToFileURL(resolve(proto)));
	const bytes = file ? fileScene(file) : spheres(P, count);
	globalThis.gc();
	const before = process.memoryUsage().heapUsed;
	const t0 = performance.now();
	const s = P.parseScene(bytes);
	const ms = performance.now() - t0;
	globalThis.gc();
	const heap = (process.memoryUsage().heapUsed - before) / 1048576;
	if (!s.root || s.byId.size === 0) {
		throw new Error('parseScene gave no tree');
	}
	console.log(`${ms.toFixed(0)} ${heap.toFixed(0)} ${s.byId.size}`);
}

const median = (v) => [...v].sort((a, b) => a - b)[Math.floor(v.length / 2)];

function main(argv) {
	let count = 1000000, file = null, reps = 3;
	const protos = [];
	for (let i = 0; i < argv.length; i++) {
		const a = argv[i];
		if (a === '--count') {
			count = Number(argv[++i]);
		} else if (a === '--file') {
			file = argv[++i];
		} else if (a === '--reps') {
			reps = Number(argv[++i]);
		} else if (a.startsWith('-')) {
			throw new Error(`unknown option ${a}`);
		} else {
			protos.push(a);
		}
	}
	if (!protos.length || !(count >= 1) || !(reps >= 1)) {
		console.error('usage: node bench/bench_page_scene.mjs [--count N] ' +
			'[--file F.bin] [--reps R] PROTOCOL_JS...');
		process.exit(2);
	}
	const runs = protos.map(() => []);
	for (let r = 0; r < reps; r++) {
		protos.forEach((p, k) => {
			const out = spawnSync(process.execPath, ['--expose-gc',
				'--max-old-space-size=8192', process.argv[1], '--child', p,
				file ?? '', String(count)], { encoding: 'utf8' });
			if (out.status !== 0) {
				throw new Error(`${p}: ${out.stderr.trim()}`);
			}
			runs[k].push(out.stdout.trim().split(' ').map(Number));
		});
	}
	console.log(`scene: ${file ?? `${count} spheres`}, ${reps} runs each`);
	console.log('| protocol.js | nodes | parseScene ms (median, all) | ' +
		'heap MiB (median) | heap bytes a node |');
	console.log('|---|---:|---:|---:|---:|');
	protos.forEach((p, k) => {
		const ms = runs[k].map((v) => v[0]);
		const heap = median(runs[k].map((v) => v[1]));
		const nodes = runs[k][0][2];
		console.log(`| ${p} | ${nodes} | ${median(ms)} (${ms.join(', ')}) ` +
			`| ${heap} | ${Math.round(heap * 1048576 / nodes)} |`);
	});
}

if (process.argv[2] === '--child') {
	await child(process.argv[3], process.argv[4] || null,
		Number(process.argv[5]));
} else {
	main(process.argv.slice(2));
}
