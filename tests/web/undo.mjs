/*
 * Undo per person from the browser page: blobcastd, websockify and two
 * pages ("alice" and "bob") in one session in headless Debian chromium
 * (playwright-core).
 *  - alice moves one primitive, bob another; alice's Ctrl-Z takes back
 *    her move only (bob's stays, on both pages) and both pages say
 *    "alice undid alice's edit N"; bob's Ctrl-Z takes back his;
 *  - Ctrl-Shift-Z and Ctrl-Y redo alice's own change;
 *  - `blobcast undo --name alice` (alice from another client) takes back
 *    alice's move; `--name carol` has nothing of hers to undo (exit 1);
 *  - a change built on: bob moves the shape alice just moved; alice's
 *    Ctrl-Z is refused and the page shows the daemon's reason (bob's
 *    edit built on it); after bob undoes his, alice's goes;
 *  - "undo any" (Ctrl-Alt-Z), the session's newest change whoever made
 *    it: refused (EPERM) for alice until she presents, then it takes
 *    back bob's change;
 *  - Ctrl-Z with nothing of alice's left: the daemon's "nothing to undo";
 *  - the History panel lists the changes newest first (author, what,
 *    undone, alice's own marked) and, while open, follows a new edit;
 *  - Ctrl-Z typed in the token field is the field's own: nothing is sent.
 * Exit status: 0 passed, 1 failed, 77 skipped (the message names what is
 * missing). Usage: node tests/web/undo.mjs --blobcastd PATH --blobcast PATH
 */
import assert from 'node:assert/strict';

import * as H from './harness.mjs';

const DEADLINE_MS = 150000;

const { daemon, cli, chromium, step, watchdog, until } = await H.begin(
	'web undo', { cli: true, ms: DEADLINE_MS });

let browser = null;
let failed = false;

const run = (args) => H.runCli(cli, args, 15000);

const near = (a, b) => a.every((v, i) => Math.abs(v - b[i]) < 1e-5);

/* Waits until node id is at translate t and the notice reads text. */
async function expect(page, what, id, t, text) {
	const st = await until(page, what, ({ id, t, text }) => {
		const n = window.blobcast.node(id);
		const s = window.blobcast.state();
		return n && n.translate.every((v, i) => Math.abs(v - t[i]) < 1e-5) &&
			s.notice === text ? s : null;
	}, { id, t, text });
	const shown = await page.evaluate(() =>
		document.getElementById('message').textContent);
	assert.equal(shown, text, `${what}: the header shows the notice`);
	step(`${what}: "${text}"`);
	return st;
}

try {
	const stack = await H.startStack(daemon);
	const d = stack.d;
	step(`blobcastd :${d.port}, websockify :${stack.proxy.port}, page ` +
		`:${stack.web.port}`);
	browser = await chromium.launch({ executablePath: H.CHROMIUM,
		args: H.CHROMIUM_ARGS });
	const open = async (name) => {
		const page = await H.joinPage(browser, stack, { name,
			viewport: { width: 480, height: 320 } });
		await until(page, `${name}: the scene`, () =>
			window.blobcast.state().connected &&
			window.blobcast.primitives().length > 1);
		return page;
	};
	const alice = await open('alice');
	const bob = await open('bob');
	assert.equal(await alice.evaluate(() =>
		document.getElementById('undobtn').disabled), false,
	'the undo button is enabled for an editor');
	const srv = ['--server', `127.0.0.1:${d.port}`, '--session', 'default'];

	const [p, q] = await alice.evaluate(() => window.blobcast.primitives());
	const pMoved = [p.translate[0] + 0.25, p.translate[1], p.translate[2]];
	const qMoved = [q.translate[0], q.translate[1] + 0.25, q.translate[2]];
	const pBob = [p.translate[0], p.translate[1], p.translate[2] - 0.25];
	/* Moves node id to t from page and returns the edit's order once
	 * every page shows it there. */
	const move = async (page, id, t) => {
		await page.evaluate(({ id, t }) => window.blobcast.moveTo(id, t),
			{ id, t }).catch(() => {});
		const e = await until(page, `#${id} moved`, ({ id, t }) => {
			const n = window.blobcast.node(id);
			const s = window.blobcast.state();
			return n && n.translate.every((v, i) =>
				Math.abs(v - t[i]) < 1e-5) ? s.lastEdit : null;
		}, { id, t });
		await at(alice, id, t);
		await at(bob, id, t);
		return e.order;
	};
	const at = (page, id, t) => until(page, `#${id} at ${t}`,
		({ id, t }) => {
			const n = window.blobcast.node(id);
			return n && n.translate.every((v, i) =>
				Math.abs(v - t[i]) < 1e-5);
		}, { id, t });

	const a1 = await move(alice, p.id, pMoved);
	const b1 = await move(bob, q.id, qMoved);
	step(`alice moved ${p.kind} #${p.id} (edit ${a1}), bob ` +
		`${q.kind} #${q.id} (edit ${b1})`);

	await alice.keyboard.press('Control+z');
	await expect(alice, "alice's Ctrl-Z", p.id, p.translate,
		`alice undid alice's edit ${a1}`);
	await expect(bob, "alice's Ctrl-Z seen by bob", p.id, p.translate,
		`alice undid alice's edit ${a1}`);
	await at(alice, q.id, qMoved);
	await at(bob, q.id, qMoved);
	step("bob's move stayed on both pages");
	await bob.keyboard.press('Control+z');
	await expect(bob, "bob's Ctrl-Z", q.id, q.translate,
		`bob undid bob's edit ${b1}`);

	await alice.keyboard.press('Control+Shift+Z');
	await expect(alice, 'Ctrl-Shift-Z', p.id, pMoved,
		`alice redid alice's edit ${a1}`);
	await alice.keyboard.press('Control+z');
	await expect(alice, 'Ctrl-Z again', p.id, p.translate,
		`alice undid alice's edit ${a1}`);
	await alice.keyboard.press('Control+y');
	await expect(alice, 'Ctrl-Y', p.id, pMoved,
		`alice redid alice's edit ${a1}`);

	let r = await run(['undo', ...srv, '--name', 'alice']);
	assert.equal(r.code, 0, `blobcast undo --name alice: ${r.stderr}`);
	await expect(alice, 'blobcast undo --name alice', p.id, p.translate,
		`alice undid alice's edit ${a1}`);
	r = await run(['undo', ...srv, '--name', 'carol']);
	assert.equal(r.code, 1, `blobcast undo --name carol: ${r.stderr}`);
	assert.match(r.stderr, /nothing to undo/);
	step('`blobcast undo --name carol`: nothing of hers to undo (exit 1)');

	/* Built on: bob moves the shape alice just moved. */
	const a2 = await move(alice, p.id, pMoved);
	const b2 = await move(bob, p.id, pBob);
	await alice.keyboard.press('Control+z');
	const refused = await until(alice, "alice's refused undo", () => {
		const n = window.blobcast.state().notice;
		return /built on/.test(n) ? n : null;
	});
	assert.match(refused, new RegExp(`edit ${a2} .*built on by edit ` +
		`${b2} .*by bob`), refused);
	await at(alice, p.id, pBob);
	step(`alice's Ctrl-Z refused: "${refused}"`);
	await bob.keyboard.press('Control+z');
	await expect(bob, "bob's Ctrl-Z of his move on alice's", p.id, pMoved,
		`bob undid bob's edit ${b2}`);
	await alice.keyboard.press('Control+z');
	await expect(alice, "then alice's Ctrl-Z", p.id, p.translate,
		`alice undid alice's edit ${a2}`);

	/* "undo any": the session's newest change, owner or presenter. */
	const b3 = await move(bob, q.id, qMoved);
	await alice.keyboard.press('Control+Alt+z');
	await until(alice, 'EPERM for undo any', () =>
		/^EPERM: /.test(document.getElementById('message').textContent));
	await at(alice, q.id, qMoved);
	step('undo any refused for alice, who neither owns nor presents');
	await alice.click('#presentbtn');
	await until(alice, 'alice presents', () => window.blobcast.state()
		.presenter === window.blobcast.state().memberId);
	await alice.click('#undoanybtn');
	await expect(alice, 'undo any by the presenter', q.id, q.translate,
		`alice undid bob's edit ${b3}`);

	await alice.keyboard.press('Control+z');
	await expect(alice, 'Ctrl-Z with nothing left', p.id, p.translate,
		"nothing to undo: no change of yours is left");

	/* The History panel: who, what, applied or undone, whose. */
	await alice.click('#historypanel summary', { position: { x: 4, y: 6 } });
	const h = await until(alice, 'the history listed', () => {
		const st = window.blobcast.history();
		return st.open && st.rows.length ? st : null;
	});
	/* Kept: bob's undone b3 and alice's undone a2 (a new edit empties
	 * its author's redo steps, so the earlier ones are gone). */
	assert.equal(h.rows.length, 2, JSON.stringify(h.rows));
	const row = (o) => h.rows.find((r) => r.order === String(o));
	assert.equal(h.rows[0].order, String(b3), 'newest first');
	assert.deepEqual([row(b3).author, row(b3).undone, row(b3).yours,
		row(b3).what], ['bob', true, false, `SET node ${q.id} translate`]);
	assert.deepEqual([row(a2).author, row(a2).undone, row(a2).yours,
		row(a2).next], ['alice', true, true, true]);
	assert.ok(row(b3).time > 0, 'a time');
	assert.equal(await alice.locator('#historylist li').count(),
		h.rows.length, 'a row each');
	assert.match(await alice.textContent(
		`#historylist li[data-order="${a2}"]`),
	/alice \(you\).*undone · ← your redo/);
	step(`History: ${h.rows.length} changes, newest bob's ${b3} (undone)`);
	const b4 = await move(bob, q.id, qMoved);
	await until(alice, 'the open panel follows an edit', (o) => window
		.blobcast.history().rows[0]?.order === o, String(b4));
	step(`the open panel shows bob's next edit ${b4} by itself`);

	/* In a text field Ctrl-Z belongs to the field. */
	const page = alice;
	const order = (await page.evaluate(() => window.blobcast.state())).order;
	await page.evaluate(() => {
		document.getElementById('alert').hidden = false;
		document.getElementById('tokenform').hidden = false;
		document.getElementById('token').focus();
	});
	await page.keyboard.press('Control+Shift+Z');
	await page.keyboard.press('Control+Alt+z');
	await page.waitForTimeout(400);
	const after = await page.evaluate(() => window.blobcast.state());
	assert.equal(after.order, order, 'Ctrl-Shift-Z in a field sent no REDO');
	assert.ok(near((await page.evaluate((id) => window.blobcast.node(id),
		p.id)).translate, p.translate), 'the node stayed put');
	step('Ctrl-Shift-Z and Ctrl-Alt-Z in the token field sent nothing');
} catch (e) {
	failed = true;
	H.report(e);
} finally {
	await H.finish(browser, failed, watchdog);
}
