/*
 * Node names from the browser page (PROTOCOL.md 4.1 NAMES, section 9
 * NAME): blobcastd, websockify and two pages ("alice" and "bob") in one
 * session in headless Debian chromium (playwright-core).
 *  - alice double-clicks a row of her outliner, types a name and presses
 *    Enter: one EDIT of one NAME operation; the focus is back on the
 *    tree, and both outliners show the name beside the kind and id, as
 *    does alice's Selection panel; the History panel shows the daemon's
 *    text (NAME node N "name");
 *  - alice's Ctrl-Z takes the name back on both pages;
 *  - F2 opens the field on the selection; Escape leaves the name as it
 *    was and sends nothing; a name of 65 bytes is refused in the page,
 *    with a message, before anything is sent (the field stays open);
 *  - a name with quotes and a character outside the BMP reaches bob, and
 *    the JSON scene alice downloads holds it: the same bytes as
 *    `blobcast scene` writes;
 *  - a scene whose names hold a tab, a newline, a backslash, U+0001 and
 *    DEL, loaded with `blobcast load`, reaches both pages (SCENE_STATE's
 *    names table), and alice's download escapes them as `blobcast scene`
 *    does.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/names.mjs --blobcastd PATH --blobcast PATH
 */
import assert from 'node:assert/strict';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

import * as H from './harness.mjs';
import * as P from '../../client/web/protocol.js';

const DEADLINE_MS = 90000;
/* A node of the built-in scene whose row is drawn from the start. */
const ID = 50;

const { daemon, cli, chromium, step, watchdog, until } = await H.begin(
	'web names', { cli: true, ms: DEADLINE_MS });

let browser = null;
let failed = false;

/* The row of node id in page's outliner, once it shows name. */
const rowNamed = (page, who, id, name) => until(page,
	`${who}: row #${id} named "${name}"`, ({ id, name }) => window.blobcast
		.outliner().rows.find((r) => r.id === id && r.name === name &&
			window.blobcast.node(id)?.name === name) ?? null, { id, name });

const state = (page) => page.evaluate(() => ({
	...window.blobcast.state(), outliner: window.blobcast.outliner() }));

/* The name field of the outliner, open and focused. */
const field = async (page, what) => {
	await until(page, what, () => document.activeElement?.matches(
		'#outliner input.rename'));
	return page.locator('#outliner input.rename');
};

try {
	const stack = await H.startStack(daemon);
	const port = stack.d.port;
	step(`blobcastd :${port}, websockify :${stack.proxy.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const open = async (name) => {
		const page = await H.joinPage(browser, stack, { name,
			viewport: { width: 600, height: 640 } });
		await until(page, `${name}: the scene and its outliner`, (id) =>
			window.blobcast.state().connected && window.blobcast.outliner()
				.rows.some((r) => r.id === id), ID, 45000);
		return page;
	};
	const alice = await open('alice');
	const bob = await open('bob');
	const st0 = await state(alice);
	assert.ok(st0.features & P.FEATURE.NAMES, 'the daemon granted NAMES');
	const kind = st0.outliner.rows.find((r) => r.id === ID).text;
	step(`both pages joined; the daemon granted NAMES; row #${ID} is ` +
		`"${kind}"`);

	/* A double-click on the row, a name, Enter. */
	await alice.locator(`#outliner .row[data-id="${ID}"] .label`).dblclick();
	const input = await field(alice, 'alice: the name field is open');
	await input.pressSequentially('wheel');
	await alice.keyboard.press('Enter');
	const row = await rowNamed(alice, 'alice', ID, 'wheel');
	assert.equal(row.text, kind, 'the kind and id stay beside the name');
	const sA = await state(alice);
	assert.equal(sA.outliner.renaming, 0, 'the field closed');
	assert.equal(sA.selected, ID);
	assert.equal(await alice.evaluate(() => document.activeElement.id),
		'outliner', 'the focus is back on the tree');
	assert.equal(await alice.textContent('#selname'), `wheel ${kind}`,
		'the Selection panel shows the name');
	await rowNamed(bob, 'bob', ID, 'wheel');
	const named = sA.order;
	step(`alice named #${ID} "wheel" (edit ${named}) from her outliner; ` +
		'bob\'s outliner shows it');

	/* The History panel: the daemon's words. */
	await alice.click('#historypanel summary', { position: { x: 4, y: 6 } });
	const h = await until(alice, 'the history listed', (o) => {
		const hs = window.blobcast.history();
		return hs.open && hs.rows[0]?.order === o ? hs : null;
	}, named);
	assert.equal(h.rows[0].what, `NAME node ${ID} "wheel"`);
	assert.equal(h.rows[0].author, 'alice');
	step(`History: ${h.rows[0].what}`);

	/* Ctrl-Z on the tree takes the name back on both pages. */
	await alice.keyboard.press('Control+z');
	await rowNamed(alice, 'alice', ID, '');
	await rowNamed(bob, 'bob', ID, '');
	assert.equal(await alice.textContent('#selname'), kind);
	step('alice\'s Ctrl-Z took the name back on both pages');

	/* F2, a name, Escape: nothing sent. */
	const before = await state(alice);
	await alice.focus('#outliner');
	await alice.keyboard.press('F2');
	await (await field(alice, 'F2 opens the field')).pressSequentially('no');
	await alice.keyboard.press('Escape');
	await until(alice, 'Escape closes the field', () =>
		window.blobcast.outliner().renaming === 0 &&
		document.activeElement.id === 'outliner');
	/* 65 bytes: refused here, the field kept for a shorter one. */
	await alice.keyboard.press('F2');
	await (await field(alice, 'F2 again')).fill('x'.repeat(65));
	await alice.keyboard.press('Enter');
	const refused = await until(alice, 'the 65-byte name refused', () => {
		const o = window.blobcast.outliner();
		return o.refusal ? o : null;
	});
	assert.match(refused.message, /65 bytes of UTF-8, more than the 64 a name may have: shorten it/);
	assert.equal(refused.renaming, ID, 'the field stays open');
	await alice.keyboard.press('Escape');
	await alice.waitForTimeout(300);
	const after = await state(alice);
	assert.equal(after.outliner.sent, before.outliner.sent, 'no EDIT built');
	assert.equal(after.order, before.order, 'no edit applied');
	assert.equal(after.outliner.rows.find((r) => r.id === ID).name, '');
	step('Escape and a 65-byte name sent nothing (the page said why)');

	/* A name that JSON must escape, outside the BMP too, in the file. */
	const fancy = 'front "wheel" 🛞';
	await alice.keyboard.press('F2');
	await (await field(alice, 'F2 once more')).fill(fancy);
	await alice.keyboard.press('Enter');
	await rowNamed(alice, 'alice', ID, fancy);
	await rowNamed(bob, 'bob', ID, fancy);
	const text = (await H.download(alice, '#jsonbtn')).bytes
		.toString('utf8');
	const found = [];
	const todo = [JSON.parse(text).root];
	while (todo.length) {
		const n = todo.pop();
		if (n.name !== undefined) {
			found.push([n.id, n.name]);
		}
		todo.push(...(n.children ?? []));
	}
	assert.deepEqual(found, [[ID, fancy]], 'the file names the node');
	const srv = ['--server', `127.0.0.1:${port}`, '--session', 'default'];
	const scene = async () => {
		const r = await H.runCli(cli, ['scene', ...srv]);
		assert.equal(r.code, 0, `blobcast scene: ${r.stderr}`);
		return r.stdout;
	};
	assert.equal(text, await scene(), 'the download is what `blobcast ' +
		'scene` writes');
	step(`"${fancy}" reached bob; the JSON download holds it, as ` +
		'`blobcast scene` writes it');

	/* Names JSON must escape, from a scene file through SCENE_STATE. */
	const odd = ['tab\there\nnext', 'back\\slash \u0001 \u007f ü'];
	const work = mkdtempSync(join(tmpdir(), 'blobcast-names-'));
	const file = join(work, 'odd.json');
	writeFileSync(file, JSON.stringify({ blobcast: 1, root: { type:
		'union', id: 1, name: odd[0], children: [
			{ type: 'sphere', id: 2, radius: 0.5, name: odd[1] },
			{ type: 'sphere', id: 3, radius: 0.5,
				translate: [1, 0, 0] }] } }));
	const r = await H.runCli(cli, ['load', ...srv, file]);
	rmSync(work, { recursive: true, force: true });
	assert.equal(r.code, 0, `blobcast load: ${r.stderr}`);
	await rowNamed(alice, 'alice', 1, odd[0]);
	await rowNamed(bob, 'bob', 2, odd[1]);
	const loaded = (await H.download(alice, '#jsonbtn')).bytes
		.toString('utf8');
	assert.ok(loaded.includes('"name": "tab\\u0009here\\u000anext"'),
		loaded);
	assert.equal(loaded, await scene(), 'escaped as `blobcast scene` ' +
		'escapes them');
	step('a loaded scene\'s names (tab, newline, backslash, U+0001, DEL) ' +
		'reached both pages; the download equals `blobcast scene`');
} catch (e) {
	failed = true;
	H.report(e);
} finally {
	await H.finish(browser, failed, watchdog);
}
