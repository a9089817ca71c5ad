/*
 * The Scene panel of the page: an outliner of the session's tree and the
 * tools that change its structure.
 *
 *  - The outliner lists operators, unary nodes and primitives as an
 *    indented tree, each row the node's kind and id, after its name when
 *    it has one (the kind and id then muted), groups collapsible. It reads
 *    the page's scene mirror and follows every SCENE_STATE and
 *    EDIT_APPLIED: an edit that only sets fields or names (a drag, a
 *    slider, a rename) updates the rows it touched, a structural one
 *    redraws the list once per animation frame.
 *    Big scenes stay cheap: groups deeper than OPEN_DEPTH start closed, a
 *    group shows MAX_CHILDREN children before a "more" row, and the list
 *    stops at MAX_ROWS rows.
 *  - Selection is the page's: a click on a row selects the node as a pick
 *    in the picture does, and a pick opens the groups above the node and
 *    scrolls its row into view.
 *  - The Add menu lists every primitive kind (added under the selected
 *    operator, or the operator above the selected node, at the camera's
 *    target) and every unary kind (wrapping the selection); delete and
 *    duplicate act on the selection; a selected operator's kind, sharp or
 *    smooth, and radius are set in a small form. A row dragged onto an
 *    operator's row moves the node there (to its end); dropped between
 *    two rows (the upper or lower edge of a row: an insertion line shows
 *    where) it goes to that place among that row's siblings, under the
 *    same operator or another one; the lower edge of an open group's row
 *    is its first place. Alt+Up and Alt+Down move the selected node one
 *    place among its siblings. In a difference the first child is the
 *    shape the others are cut from: the rows' tooltips say so, and a
 *    reorder that changes the first child changes the shape. A menu entry
 *    dragged onto a row adds (or wraps) there.
 *  - Rename: a double-click on a row, F2, or the rename button opens an
 *    inline field on the selected node's row; Enter sends the name (one
 *    EDIT of one NAME operation; empty removes the name), Escape or a
 *    click elsewhere leaves it as it was, and the focus goes back to the
 *    tree. Only with a daemon that granted NAMES (PROTOCOL.md 4.1).
 *  - Every action is one EDIT built by model.js, which refuses what the
 *    daemon would refuse before anything is sent; the panel's message line
 *    says what happened, or why not and what to do, and shows the
 *    daemon's ERROR text when it refuses an edit anyway (an editor racing
 *    for the same ids, a node removed meanwhile).
 */
import * as P from './protocol.js';
import * as M from './model.js';
import { OPS, PRIMS, UNARY } from './prims.js';

/* Rows drawn at most: a 100 000-node scene would otherwise cost seconds
 * of DOM work per structural edit. */
const MAX_ROWS = 2000;
/* Children a group shows before a "more" row (each click shows as many
 * again). */
const MAX_CHILDREN = 200;
/* Groups with fewer nodes above them than this start open. */
const OPEN_DEPTH = 3;
/* Pointer travel (CSS pixels) that turns a press on a row into a drag. */
const DRAG_START = 5;
/* A new shape's size and a duplicate's offset, as fractions of the
 * camera's distance to its target: visible, not filling the view. */
const NEW_SIZE = 0.06;
const DUP_OFFSET = 0.08;
/* Colours of new shapes, in turn. */
const PALETTE = [[0.9, 0.45, 0.2], [0.3, 0.6, 0.9], [0.55, 0.8, 0.35],
	[0.85, 0.3, 0.6], [0.95, 0.8, 0.3]];

const $ = (id) => document.getElementById(id);

function el(tag, cls, text) {
	const e = document.createElement(tag);
	if (cls) {
		e.className = cls;
	}
	if (text !== undefined) {
		e.textContent = text;
	}
	return e;
}

/* The tree as nested [kind, id, ...children], for tests and the console. */
function shape(n) {
	return n.isOp ? [M.kindName(n), n.id, ...n.children.map(shape)]
		: [M.kindName(n), n.id];
}

/* A key typed in a text field is the field's. */
function typing(t) {
	return !!t && (t.isContentEditable || ['INPUT', 'TEXTAREA', 'SELECT']
		.includes(t.tagName));
}

export class Outliner {
	constructor(app) {
		this.app = app;
		this.list = $('outliner');
		this.open = new Map(); /* id -> open (the user's choice) */
		this.more = new Map(); /* id -> children shown, past MAX_CHILDREN */
		this.rows = new Map(); /* id -> its row, when drawn */
		this.sent = new Map(); /* my EDIT seq -> the action's result */
		this.sentCount = 0;
		this.drag = null;
		this.lastOps = [];
		this.redraw = 0;
		this.renaming = null; /* { id, input } while a name is typed */
		this.installMenu();
		this.installTools();
		this.installDrag();
		this.installKeys();
		this.installRename();
		this.reset();
	}

	/* ---- the page's hooks ---- */

	/* A new connection: nothing to show until the scene comes. */
	reset() {
		this.sent.clear();
		this.renaming = null;
		this.render();
		this.renderTools();
	}

	/* The mirror changed: m is the EDIT_APPLIED, or null for a new
	 * SCENE_STATE. */
	sceneChanged(m) {
		if (m && m.ops.every((op) => op.kind === P.EDIT.SET ||
			op.kind === P.EDIT.NAME)) {
			for (const op of m.ops) {
				this.label(op.node);
			}
		} else {
			this.schedule();
		}
		const me = this.app.info?.member_id;
		const r = m && m.author === me ? this.sent.get(m.author_seq) : null;
		if (r) {
			this.sent.delete(m.author_seq);
			this.tell(r.text);
			this.app.select(this.app.scene?.byId.has(r.select) ? r.select : 0);
		}
		this.renderTools();
	}

	/* The page's selection changed (a pick, a row, an action). */
	selected(id) {
		for (const row of this.list.querySelectorAll('.row.sel')) {
			row.classList.remove('sel');
			row.setAttribute('aria-selected', 'false');
		}
		const n = id ? this.app.scene?.byId.get(id) : null;
		if (n) {
			this.reveal(n);
		}
		this.renderTools();
	}

	/* An ERROR from the daemon: when it answers an edit of this panel,
	 * say which and why. Returns whether it did. */
	refused(m) {
		const r = this.sent.get(m.seq);
		if (!m.seq || !r) {
			return false;
		}
		this.sent.delete(m.seq);
		const race = m.code === P.ERR.EDUPID
			? ' (another member added a node with the same id at the same ' +
				'time): try again'
			: m.code === P.ERR.ENONODE ? ' (another member changed that ' +
				'part of the scene meanwhile): try again' : '';
		this.tell(`the daemon refused "${r.text}": ` +
			`${P.errName(m.code)}: ${m.text}${race}`, true);
		return true;
	}

	/* ---- state for tests and the console ---- */

	state() {
		return {
			tree: this.app.scene?.root ? shape(this.app.scene.root) : null,
			rows: [...this.list.querySelectorAll('.row')].map((r) => ({
				id: Number(r.dataset.id),
				level: Number(r.getAttribute('aria-level')),
				text: r.querySelector('.label').textContent,
				name: r.querySelector('.name')?.textContent ?? '',
				selected: r.classList.contains('sel') })),
			renaming: this.renaming?.id ?? 0,
			message: $('outlinermsg').textContent,
			refusal: $('outlinermsg').classList.contains('bad'),
			sent: this.sentCount,
			/* The operations of the last EDIT sent: [kind, node or
			 * parent, position]. */
			lastOps: this.lastOps,
		};
	}

	/* ---- drawing ---- */

	schedule() {
		if (!this.redraw) {
			this.redraw = requestAnimationFrame(() => {
				this.redraw = 0;
				this.render();
			});
		}
	}

	isOpen(n, depth) {
		return this.open.get(n.id) ?? depth < OPEN_DEPTH;
	}

	/* Draws the visible rows, pre-order, up to MAX_ROWS. */
	render() {
		cancelAnimationFrame(this.redraw);
		this.redraw = 0;
		this.rows.clear();
		/* A field being typed in moves to its node's new row (its blur
		 * while detached is not the user leaving it). */
		const typed = this.renaming;
		const focused = typed && document.activeElement === typed.input;
		this.redrawing = true;
		const frag = document.createDocumentFragment();
		const root = this.app.scene?.root;
		const todo = root ? [[root, 0]] : [];
		let drawn = 0;
		while (todo.length) {
			const [n, depth] = todo.pop();
			if (n.more !== undefined) {
				frag.append(this.moreRow(n, depth));
				continue;
			}
			if (drawn === MAX_ROWS) {
				frag.append(el('div', 'cap', `only the first ${MAX_ROWS} ` +
					'rows are shown: close a group to see further'));
				break;
			}
			frag.append(this.row(n, depth));
			drawn++;
			if (n.isOp && this.isOpen(n, depth)) {
				const shown = Math.min(n.children.length,
					this.more.get(n.id) ?? MAX_CHILDREN);
				if (shown < n.children.length) {
					todo.push([{ more: n.children.length - shown, parent: n },
						depth + 1]);
				}
				for (let i = shown - 1; i >= 0; i--) {
					todo.push([n.children[i], depth + 1]);
				}
			}
		}
		this.list.replaceChildren(frag);
		this.redrawing = false;
		if (!root) {
			this.list.append(el('p', 'dim', 'no scene yet'));
		}
		if (typed && !this.rows.has(typed.id)) {
			/* The node went away (another member deleted it). */
			this.renaming = null;
			this.tell(`node #${typed.id} was removed meanwhile: its name ` +
				'was not sent', true);
		} else if (focused) {
			typed.input.focus();
		}
	}

	row(n, depth) {
		const row = el('div', `row ${n.isOp ? (n.unary ? 'unary' : 'op')
			: 'prim'}`);
		row.dataset.id = String(n.id);
		row.setAttribute('role', 'treeitem');
		row.setAttribute('aria-level', String(depth + 1));
		row.style.paddingLeft = `${0.3 + depth * 0.9}em`;
		/* Where an insertion line on this row starts. */
		row.style.setProperty('--indent', `${0.3 + depth * 0.9}em`);
		const tip = this.tip(n);
		if (tip) {
			row.title = tip;
		}
		const twist = el('span', 'twist', n.isOp ? (this.isOpen(n, depth)
			? '▾' : '▸') : '');
		if (n.isOp) {
			row.setAttribute('aria-expanded', String(this.isOpen(n, depth)));
		}
		const sel = n.id === this.app.selected;
		row.classList.toggle('sel', sel);
		row.setAttribute('aria-selected', String(sel));
		row.append(twist);
		this.fill(row, n);
		this.rows.set(n.id, row);
		return row;
	}

	/* A row's text: the name (when the node has one) and the kind and
	 * id, or the field a name is typed in. */
	fill(row, n) {
		const typed = this.renaming?.id === n.id ? this.renaming.input
			: null;
		const focused = typed && document.activeElement === typed;
		const was = this.redrawing;
		this.redrawing = true;
		row.replaceChildren(row.firstChild);
		this.redrawing = was;
		row.classList.toggle('named', !!n.name);
		const label = el('span', 'label', this.text(n));
		if (typed) {
			row.append(typed, label);
			if (focused) {
				typed.focus();
			}
			return;
		}
		if (n.name) {
			row.append(el('span', 'name', n.name), ' ', label);
		} else {
			row.append(label);
		}
	}

	/* A row's tooltip: what order means in a difference, or "". */
	tip(n) {
		if (M.isDifference(n)) {
			return `${M.kindName(n)}: its first child is the shape the ` +
				'others are cut from, so the order of its children is part ' +
				'of the shape (drag a row between two others, or Alt+Up and ' +
				'Alt+Down, to change it)';
		}
		const top = M.removedTop(n);
		const p = top.parent;
		if (!M.isDifference(p) || top !== n) {
			return '';
		}
		return p.children[0] === n ? `the shape the other children of ` +
			`${M.nodeName(p)} are cut from; another child moved first ` +
			'changes the shape' : `cut from the first child of ` +
			`${M.nodeName(p)}; moved first it becomes the shape the others ` +
			'are cut from';
	}

	moreRow(m, depth) {
		const row = el('div', 'more', `… ${m.more} more in ` +
			`${M.nodeName(m.parent)}: show them`);
		row.dataset.more = String(m.parent.id);
		row.style.paddingLeft = `${0.3 + depth * 0.9}em`;
		return row;
	}

	text(n) {
		return `${M.kindName(n)} #${n.id}` + (M.isGroup(n) &&
			n.kind > M.SMOOTH ? ` · r ${+n.blend.toFixed(3)}` : '');
	}

	/* A row after a SET (an operator's kind or radius) or a NAME. */
	label(id) {
		const row = this.rows.get(id);
		const n = this.app.scene?.byId.get(id);
		if (row && n) {
			this.fill(row, n);
		}
	}

	/* Opens the groups above n, draws its row, selects and scrolls to
	 * it. */
	reveal(n) {
		let redraw = false;
		for (let c = n, p = n.parent; p; c = p, p = p.parent) {
			if (this.open.get(p.id) !== true) {
				this.open.set(p.id, true);
				redraw = true;
			}
			const at = p.children.indexOf(c);
			if (at >= (this.more.get(p.id) ?? MAX_CHILDREN)) {
				this.more.set(p.id, at + 1);
				redraw = true;
			}
		}
		if (redraw || !this.rows.has(n.id)) {
			this.render();
		}
		const row = this.rows.get(n.id);
		if (row) {
			row.classList.add('sel');
			row.setAttribute('aria-selected', 'true');
			row.scrollIntoView({ block: 'nearest' });
		}
	}

	/* ---- messages ---- */

	tell(text, bad = false) {
		const p = $('outlinermsg');
		p.textContent = text;
		p.classList.toggle('bad', bad);
		if (bad) {
			this.app.say(text);
		}
	}

	/* ---- actions ---- */

	editor() {
		return this.app.info?.role === P.ROLE.EDITOR && !!this.app.scene?.root;
	}

	/* Builds an action with model.js and sends it as one EDIT; a refusal
	 * is shown and nothing is sent. Returns whether it was sent. */
	act(build) {
		if (!this.editor()) {
			this.tell(this.app.info ? 'viewers cannot change the scene'
				: 'not connected: nothing sent', true);
			return false;
		}
		let r;
		try {
			r = build(this.app.scene, M.limitsFor(this.app.welcome));
		} catch (e) {
			if (e instanceof M.Refusal) {
				this.tell(e.message, true);
				return false;
			}
			throw e;
		}
		const seq = this.app.sendOps(r.ops);
		if (!seq) {
			this.tell('not connected: nothing sent', true);
			return false;
		}
		this.sentCount++;
		this.lastOps = r.ops.map((op) => [op.kind, op.node ?? op.parent,
			op.position ?? null]);
		this.sent.set(seq, r);
		this.tell(`${r.text}…`);
		return true;
	}

	/* ---- rename ---- */

	/* Whether the daemon keeps names (it granted NAMES). */
	names() {
		return ((this.app.welcome?.features ?? 0) & P.FEATURE.NAMES) !== 0;
	}

	/* Opens the name field on node id's row (selecting it). */
	startRename(id) {
		const n = id ? this.app.scene?.byId.get(id) : null;
		if (!n) {
			this.tell('select a node to rename first (a row, or a shape ' +
				'in the picture)', true);
			return;
		}
		if (!this.editor()) {
			this.tell(this.app.info ? 'viewers cannot rename nodes'
				: 'not connected: nothing sent', true);
			return;
		}
		if (!this.names()) {
			this.tell('this daemon keeps no node names (it did not grant ' +
				'NAMES): update blobcastd to name nodes', true);
			return;
		}
		this.stopRename(false);
		this.app.select(id);
		const input = el('input', 'rename');
		input.type = 'text';
		input.value = n.name ?? '';
		input.spellcheck = false;
		input.placeholder = 'name (empty: none)';
		input.setAttribute('aria-label', `name of ${M.kindName(n)} #${n.id}` +
			` (at most ${M.NAME_MAX} bytes; Enter sends, Escape cancels)`);
		input.addEventListener('keydown', (e) => {
			/* The field's keys are not the tree's (arrows, Delete). */
			e.stopPropagation();
			if (e.key === 'Enter') {
				e.preventDefault();
				this.commitRename();
			} else if (e.key === 'Escape') {
				e.preventDefault();
				this.stopRename(true);
			}
		});
		input.addEventListener('blur', () => {
			if (!this.redrawing && this.renaming?.input === input) {
				this.stopRename(false);
			}
		});
		this.renaming = { id, input };
		this.label(id);
		if (!this.rows.has(id)) {
			/* Past MAX_ROWS: no row to type on. */
			this.renaming = null;
			this.tell(`the row of ${M.nodeName(n)} is not shown: close a ` +
				'group above it, then rename', true);
			return;
		}
		input.focus();
		input.select();
	}

	/* Enter: sends the name; a refused one keeps the field open to be
	 * corrected. The same name as before just closes it. */
	commitRename() {
		const r = this.renaming;
		const n = r && this.app.scene?.byId.get(r.id);
		if (!n) {
			this.stopRename(true);
			return;
		}
		const name = r.input.value;
		if (name === (n.name ?? '')) {
			this.stopRename(true);
			return;
		}
		if (this.act((scene) => M.rename(scene, r.id, name))) {
			this.stopRename(true);
		}
	}

	/* Closes the name field; focus: give the keyboard back to the tree. */
	stopRename(focus) {
		const r = this.renaming;
		if (!r) {
			return;
		}
		this.renaming = null;
		this.label(r.id);
		if (focus) {
			this.list.focus();
		}
	}

	installRename() {
		this.list.addEventListener('dblclick', (e) => {
			const row = e.target.closest('.row');
			if (row && !e.target.closest('.twist, input')) {
				e.preventDefault();
				this.startRename(Number(row.dataset.id));
			}
		});
		document.addEventListener('keydown', (e) => {
			if (e.key !== 'F2' || e.ctrlKey || e.metaKey || e.altKey ||
				typing(e.target) || !this.app.selected) {
				return;
			}
			e.preventDefault();
			this.startRename(this.app.selected);
		});
		$('renamebtn').addEventListener('click', () =>
			this.startRename(this.app.selected));
	}

	/* Where the camera looks, how big a new shape is, how far right a
	 * duplicate goes. */
	placement() {
		const c = this.app.camera;
		const d = Math.hypot(...c.eye.map((v, i) => v - c.target[i]));
		const right = c.basis().r;
		return { at: c.target.slice(), size: NEW_SIZE * d,
			offset: right.map((v) => v * DUP_OFFSET * d) };
	}

	add(kind, parent) {
		this.act((scene, limits) => {
			const g = parent ?? M.groupFor(scene, this.app.selected)?.id ??
				null;
			const p = this.placement();
			return M.addPrimitive(scene, g, kind, { translate: p.at,
				size: p.size, limits, color: PALETTE[M.freshIds(scene)[0] %
					PALETTE.length] });
		});
	}

	wrap(kind, id) {
		const target = id ?? this.app.selected;
		if (!target) {
			this.tell('select a node to wrap first (a row, or a shape in ' +
				'the picture)', true);
			return;
		}
		this.act((scene, limits) => M.wrap(scene, target, kind, { limits }));
	}

	/* ---- the tools ---- */

	installMenu() {
		/* An entry per kind of prims.js's tables. */
		for (const [box, table, key] of [[$('addprims'), PRIMS, 'prim'],
			[$('addunary'), UNARY, 'unary']]) {
			for (const [kind, [name]] of Object.entries(table)) {
				const b = el('button', 'item', name);
				b.type = 'button';
				b.dataset[key] = kind;
				box.append(b);
			}
		}
		$('addbtn').addEventListener('click', () => this.menu(
			$('addmenu').hidden));
		/* Escape, or a press anywhere else, closes it. */
		document.addEventListener('keydown', (e) => {
			if (e.key === 'Escape') {
				this.menu(false);
			}
		});
		document.addEventListener('pointerdown', (e) => {
			if (!$('addmenu').hidden && !e.target.closest?.('#addmenu, ' +
				'#addbtn')) {
				this.menu(false);
			}
		});
		const base = $('opbase');
		for (let k = 1; k <= M.SMOOTH; k++) {
			const o = el('option', '', OPS[k]);
			o.value = String(k);
			base.append(o);
		}
	}

	/* Opens the menu beside the panel, over the picture, so that the
	 * rows stay where they are to drop its entries on. */
	menu(open) {
		const m = $('addmenu');
		if (open) {
			const b = $('addbtn').getBoundingClientRect();
			const panel = $('scenepanel').getBoundingClientRect();
			const top = Math.min(b.top, innerHeight - 360);
			m.style.top = `${Math.max(4, top)}px`;
			m.style.right = `${innerWidth - panel.left + 12}px`;
		}
		m.hidden = !open;
		$('addbtn').setAttribute('aria-expanded', String(open));
		this.renderTools();
	}

	installTools() {
		/* The Delete key, outside text fields, is the delete button. */
		document.addEventListener('keydown', (e) => {
			if (e.key !== 'Delete' || e.ctrlKey || e.metaKey || e.altKey ||
				typing(e.target) || $('delbtn').disabled) {
				return;
			}
			e.preventDefault();
			$('delbtn').click();
		});
		$('delbtn').addEventListener('click', () => {
			const id = this.app.selected;
			if (!id) {
				this.tell('select a node to delete first', true);
				return;
			}
			this.act((scene, limits) => M.remove(scene, id, { limits }));
		});
		$('dupbtn').addEventListener('click', () => {
			const id = this.app.selected;
			if (!id) {
				this.tell('select a node to duplicate first', true);
				return;
			}
			const { offset } = this.placement();
			this.act((scene, limits) => M.duplicate(scene, id, { offset,
				limits }));
		});
		$('opsmooth').addEventListener('change', () => {
			if ($('opsmooth').checked && !(Number($('opradius').value) > 0)) {
				$('opradius').value = '0.1';
			}
		});
		$('opedit').addEventListener('submit', (e) => {
			e.preventDefault();
			const id = this.app.selected;
			const smooth = $('opsmooth').checked;
			this.act((scene, limits) => M.setOperator(scene, id, {
				base: Number($('opbase').value), smooth,
				blend: smooth ? Number($('opradius').value) : 0 },
			{ limits }));
		});
	}

	/* Buttons, the menu's target line and the operator form follow the
	 * selection and the role. */
	renderTools() {
		const ok = this.editor();
		const n = this.app.selected ? this.app.scene?.byId.get(
			this.app.selected) : null;
		$('addbtn').disabled = !ok;
		$('dupbtn').disabled = !ok || !n;
		$('delbtn').disabled = !ok || !n;
		$('renamebtn').disabled = !ok || !n || !this.names();
		for (const b of document.querySelectorAll('#addmenu button')) {
			b.disabled = !ok || (!!b.dataset.unary && !n);
		}
		if (!$('addmenu').hidden && this.app.scene?.root) {
			const g = M.groupFor(this.app.scene, this.app.selected);
			$('addwhere').textContent = g ? `shapes go under ${M.nodeName(g)}`
				: 'shapes go beside the root, in a new union';
			$('wrapwhere').textContent = n ? `wrap ${M.nodeName(n)} in`
				: 'select a node to wrap it in';
		}
		const form = $('opedit');
		const group = M.isGroup(n);
		form.hidden = !group;
		if (group && !form.contains(document.activeElement)) {
			$('opname').textContent = M.nodeName(n);
			$('opbase').value = String((n.kind - 1) % M.SMOOTH + 1);
			$('opsmooth').checked = n.kind > M.SMOOTH;
			$('opradius').value = String(n.kind > M.SMOOTH
				? +n.blend.toFixed(4) : 0.1);
		}
		for (const c of form.elements) {
			c.disabled = !ok;
		}
	}

	/* ---- pointer: select, open and close, drag and drop ---- */

	installDrag() {
		const down = (e) => {
			if (e.button !== 0) {
				return;
			}
			const row = e.target.closest('.row');
			const item = e.target.closest('#addmenu button.item');
			if ((!row && !item) || e.target.closest('input')) {
				return;
			}
			this.drag = { x: e.clientX, y: e.clientY, moving: false,
				node: row ? Number(row.dataset.id) : 0,
				prim: item ? Number(item.dataset.prim ?? 0) : 0,
				unary: item ? Number(item.dataset.unary ?? 0) : 0,
				twist: !!e.target.closest('.twist'), item };
		};
		this.list.addEventListener('pointerdown', down);
		$('addmenu').addEventListener('pointerdown', down);
		document.addEventListener('pointermove', (e) => this.dragMove(e));
		document.addEventListener('pointerup', (e) => this.dragEnd(e));
		/* The browser took the pointer (a touch scroll): no drop. */
		document.addEventListener('pointercancel', () => {
			if (this.drag) {
				this.dragEnd(null);
			}
		});
		this.list.addEventListener('click', (e) => {
			const more = e.target.closest('.more');
			if (more) {
				const id = Number(more.dataset.more);
				this.more.set(id, (this.more.get(id) ?? MAX_CHILDREN) +
					MAX_CHILDREN);
				this.render();
			}
		});
		/* A click on a menu entry, or Enter on it. */
		$('addmenu').addEventListener('click', (e) => {
			const b = e.target.closest('button.item');
			if (!b || this.clickDone) {
				return;
			}
			if (b.dataset.prim) {
				this.add(Number(b.dataset.prim));
			} else {
				this.wrap(Number(b.dataset.unary));
			}
			this.menu(false);
		});
	}

	/* What dropping drag d at spot (dropSpot) would do: the action, or
	 * a Refusal (quick: the structural checks only, for hovering). */
	dropPlan(d, spot, quick = false) {
		const scene = this.app.scene;
		const limits = M.limitsFor(this.app.welcome);
		const id = Number(spot.row.dataset.id);
		const o = { limits, quick };
		if (d.node && spot.where !== 'into') {
			return () => {
				const n = scene.byId.get(id);
				if (!n) {
					throw new M.Refusal(`there is no node #${id} in the ` +
						'scene any more (another member changed it): pick ' +
						'again');
				}
				if (spot.where === 'first') {
					return M.place(scene, d.node, id, 0, o);
				}
				const p = n.parent;
				if (!M.isGroup(p)) {
					throw new M.Refusal(`${M.nodeName(n)} is no longer a ` +
						'child of an operator (another member changed it): ' +
						'pick again');
				}
				const at = p.children.indexOf(n);
				return M.place(scene, d.node, p.id, spot.where === 'after'
					? at + 1 : at, o);
			};
		}
		if (d.node) {
			return () => M.move(scene, d.node, id, o);
		}
		if (d.unary) {
			return () => M.wrap(scene, id, d.unary, o);
		}
		return () => M.addPrimitive(scene, id, d.prim, o);
	}

	/* Where drag d would drop at the pointer (e): null, or { row, where
	 * } with where 'into' (onto the row's operator), 'before' or 'after'
	 * (between the row and its sibling above or below: the upper or lower
	 * edge of a row whose node is a child of an operator), or 'first' (the
	 * lower edge of an open group's row: its first place). Only a row
	 * being moved goes between rows; a menu entry goes onto one. */
	dropSpot(d, e) {
		const hit = document.elementFromPoint(e.clientX, e.clientY);
		const row = hit?.closest?.('#outliner .row');
		const id = row ? Number(row.dataset.id) : 0;
		if (!row || (d.node && id === d.node)) {
			return null;
		}
		const n = this.app.scene?.byId.get(id);
		if (!d.node || !n) {
			return { row, where: 'into' };
		}
		const box = row.getBoundingClientRect();
		const f = (e.clientY - box.top) / box.height;
		const group = M.isGroup(n);
		const edge = group ? 0.25 : 0.5;
		const between = M.isGroup(n.parent);
		const open = group && row.getAttribute('aria-expanded') === 'true' &&
			n.children.length > 0;
		if (between && f < edge) {
			return { row, where: 'before' };
		}
		if (f >= 1 - edge && open) {
			return { row, where: 'first' };
		}
		if (between && f >= 1 - edge) {
			return { row, where: 'after' };
		}
		return { row, where: 'into' };
	}

	/* Marks spot's row as what a drop there would do: an insertion line
	 * above or below it, a frame, or (refused) a red frame and the reason
	 * as its tooltip. */
	markSpot(d, spot) {
		const row = spot.row;
		let why = '';
		try {
			this.dropPlan(d, spot, true)();
		} catch (err) {
			if (!(err instanceof M.Refusal)) {
				throw err;
			}
			why = err.message;
		}
		const into = spot.where === 'into';
		row.classList.add(why ? 'drop-bad' : into ? 'drop-ok' : 'drop-line',
			`drop-${spot.where}`);
		if (spot.where === 'first') {
			row.classList.add('drop-after');
		}
		row.title = why || this.rowTip(row);
	}

	/* The tooltip row has when nothing is dragged over it. */
	rowTip(row) {
		const n = this.app.scene?.byId.get(Number(row.dataset.id));
		return n ? this.tip(n) : '';
	}

	/* Takes the marks of markSpot away again. */
	unmarkSpot(spot) {
		if (!spot) {
			return;
		}
		spot.row.classList.remove('drop-ok', 'drop-bad', 'drop-line',
			'drop-before', 'drop-after', 'drop-into', 'drop-first');
		spot.row.title = this.rowTip(spot.row);
	}

	dragMove(e) {
		const d = this.drag;
		if (!d) {
			return;
		}
		if (!d.moving) {
			if (Math.hypot(e.clientX - d.x, e.clientY - d.y) < DRAG_START ||
				!this.editor()) {
				return;
			}
			d.moving = true;
			const src = d.node ? this.app.scene?.byId.get(d.node) : null;
			d.ghost = el('div', 'dragghost', src ? `move ${M.nodeName(src)}`
				: d.prim ? `add ${PRIMS[d.prim][0]}`
					: `wrap in ${UNARY[d.unary][0]}`);
			document.body.append(d.ghost);
			document.body.classList.add('dragging-node');
		}
		d.ghost.style.left = `${e.clientX + 12}px`;
		d.ghost.style.top = `${e.clientY + 8}px`;
		/* Near the list's top or bottom edge, scroll it. */
		const box = this.list.getBoundingClientRect();
		if (e.clientX >= box.left && e.clientX <= box.right) {
			const edge = Math.min(40, box.height / 4);
			if (e.clientY < box.top + edge) {
				this.list.scrollTop -= 12;
			} else if (e.clientY > box.bottom - edge) {
				this.list.scrollTop += 12;
			}
		}
		const spot = this.dropSpot(d, e);
		if (spot?.row !== d.over?.row || spot?.where !== d.over?.where) {
			this.unmarkSpot(d.over);
			d.over = spot;
			if (spot) {
				this.markSpot(d, spot);
			}
		}
	}

	/* The end of a press: e the pointerup, null when cancelled. */
	dragEnd(e) {
		const d = this.drag;
		if (!d) {
			return;
		}
		this.drag = null;
		d.ghost?.remove();
		document.body.classList.remove('dragging-node');
		this.unmarkSpot(d.over);
		if (!d.moving) {
			if (!e) {
				return;
			}
			if (d.node && d.twist) {
				this.toggle(d.node);
			} else if (d.node) {
				this.app.select(d.node);
			}
			return;
		}
		/* The click that follows the drop (in this task) is not one. */
		this.clickDone = true;
		setTimeout(() => {
			this.clickDone = false;
		}, 0);
		const spot = e && this.dropSpot(d, e);
		if (spot) {
			const plan = this.dropPlan(d, spot);
			this.act(() => plan());
			this.menu(false);
		}
	}

	/* The list takes the keyboard focus: up and down select the row
	 * above or below, right opens a group, left closes it (or selects
	 * the group above). */
	installKeys() {
		this.list.tabIndex = 0;
		/* Alt+Up and Alt+Down, outside text fields: the selected node one
		 * place up or down among its siblings. */
		document.addEventListener('keydown', (e) => {
			if (!e.altKey || e.ctrlKey || e.metaKey || e.shiftKey ||
				(e.key !== 'ArrowUp' && e.key !== 'ArrowDown') ||
				typing(e.target)) {
				return;
			}
			e.preventDefault();
			const id = this.app.selected;
			if (!id) {
				this.tell('select a node to move first (a row, or a shape ' +
					'in the picture)', true);
				return;
			}
			const by = e.key === 'ArrowUp' ? -1 : 1;
			this.act((scene, limits) => M.shift(scene, id, by, { limits }));
		});
		this.list.addEventListener('keydown', (e) => {
			if (e.altKey) {
				return;
			}
			const rows = [...this.list.querySelectorAll('.row')];
			const at = rows.findIndex((r) => r.classList.contains('sel'));
			const n = this.app.scene?.byId.get(this.app.selected);
			let id = 0;
			if (e.key === 'ArrowDown' || e.key === 'ArrowUp') {
				const to = at < 0 ? 0 : at + (e.key === 'ArrowDown' ? 1 : -1);
				id = Number(rows[Math.max(0, Math.min(rows.length - 1, to))]
					?.dataset.id ?? 0);
			} else if (e.key === 'ArrowRight' && n?.isOp &&
				this.open.get(n.id) !== true) {
				this.open.set(n.id, true);
				this.render();
			} else if (e.key === 'ArrowLeft' && n) {
				const open = rows[at]?.getAttribute('aria-expanded') === 'true';
				if (open) {
					this.open.set(n.id, false);
					this.render();
				} else {
					id = n.parent?.id ?? 0;
				}
			} else {
				return;
			}
			e.preventDefault();
			if (id) {
				this.app.select(id);
			}
		});
	}

	toggle(id) {
		const n = this.app.scene?.byId.get(id);
		const row = this.rows.get(id);
		if (!n || !row) {
			return;
		}
		this.open.set(id, row.getAttribute('aria-expanded') !== 'true');
		this.render();
	}
}
