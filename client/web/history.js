/*
 * The History panel (PROTOCOL.md 7.26): the session's recent changes,
 * newest first -- who, what, when, applied or undone, which are this
 * member's own, which one its Ctrl-Z (Ctrl-Shift-Z) would take now, and
 * which later change was built on one (its author's own undo skips it
 * until that is undone). The page asks with HISTORY_GET when the panel is
 * opened, on its refresh button, and while it stays open at most once a
 * second after edits; only from a daemon that granted HISTORY (an older
 * one undoes the session's newest change and keeps no listing).
 */
import * as P from './protocol.js';

const REFRESH_MS = 1000; /* at most one HISTORY_GET a second while open */

const $ = (id) => document.getElementById(id);

const pad2 = (n) => String(n).padStart(2, '0');

/* 14:03:27 in the page's local time; '' when the daemon does not know. */
function clock(d) {
	return d ? `${pad2(d.getHours())}:${pad2(d.getMinutes())}:` +
		`${pad2(d.getSeconds())}` : '';
}

export class HistoryPanel {
	constructor(app) {
		this.app = app;
		this.asked = new Set(); /* HISTORY_GET seqs not yet answered */
		this.rows = []; /* decodeHistory's rows of the last answer */
		this.timer = 0;
		this.box = $('historypanel');
		this.box.addEventListener('toggle', () => {
			if (this.box.open) {
				this.ask();
			}
		});
		$('historyrefresh').addEventListener('click', (e) => {
			e.preventDefault(); /* inside the summary: not a toggle */
			this.ask();
		});
	}

	granted() {
		return ((this.app.welcome?.features ?? 0) & P.FEATURE.HISTORY) !== 0;
	}

	ask() {
		if (!this.app.info) {
			return;
		}
		if (!this.granted()) {
			$('historyinfo').textContent = 'this daemon keeps no ' +
				'listing: its undo takes back the session\'s newest change';
			return;
		}
		const seq = this.app.conn.send(P.MSG.HISTORY_GET, {});
		if (seq) {
			this.asked.add(seq);
		}
	}

	/* After an edit (or undo, redo, load): ask again if the panel is open,
	 * at most once per REFRESH_MS. */
	changed() {
		if (!this.box.open || this.timer) {
			return;
		}
		this.timer = setTimeout(() => {
			this.timer = 0;
			this.ask();
		}, REFRESH_MS);
	}

	/* Takes HISTORY (and an ERROR answering HISTORY_GET); true when the
	 * message was ours. */
	saw(m) {
		if (!this.asked.has(m.seq) || (m.type !== P.MSG.HISTORY &&
			m.type !== P.MSG.ERROR)) {
			return false;
		}
		this.asked.delete(m.seq);
		if (m.type === P.MSG.ERROR) {
			$('historyinfo').textContent =
				`${P.errName(m.code)}: ${m.text}`;
			return true;
		}
		this.rows = P.decodeHistory(m);
		this.render();
		return true;
	}

	render() {
		const ol = $('historylist');
		ol.textContent = '';
		for (const r of this.rows) {
			const li = document.createElement('li');
			li.dataset.order = String(r.order);
			li.classList.toggle('undone', r.undone);
			li.classList.toggle('yours', r.yours);
			const head = document.createElement('span');
			head.className = 'what';
			head.textContent = `${r.order} · ${r.what}`;
			const who = document.createElement('span');
			who.className = 'who';
			who.textContent = `${r.author || 'anonymous'}` +
				(r.yours ? ' (you)' : '') +
				(r.time ? ` · ${clock(r.time)}` : '');
			li.append(head, who);
			const marks = [];
			if (r.undone) {
				marks.push('undone');
			}
			if (r.builtOn) {
				marks.push(`built on by ${r.builtOn}`);
			}
			if (r.next) {
				marks.push(r.undone ? '← your redo' : '← your undo');
			}
			if (marks.length) {
				const m = document.createElement('span');
				m.className = 'marks';
				m.textContent = marks.join(' · ');
				li.append(m);
			}
			ol.append(li);
		}
		$('historyinfo').textContent = this.rows.length
			? `${this.rows.length} change${this.rows.length === 1 ? '' : 's'}` +
				' kept (PROTOCOL.md 7.20 bounds them)'
			: 'no change kept yet';
	}

	/* For tests: the rows as plain values. */
	state() {
		return {
			open: this.box.open,
			rows: this.rows.map((r) => ({ ...r, order: String(r.order),
				builtOn: String(r.builtOn),
				time: r.time ? r.time.getTime() : 0 })),
			info: $('historyinfo').textContent,
		};
	}
}
