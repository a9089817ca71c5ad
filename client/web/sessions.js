/*
 * The page's session list: the daemon's sessions (SESSION_LIST, answered
 * by SESSIONS; PROTOCOL.md 7.21), each with a join and a delete button
 * (SESSION_DELETE, 7.19), and a form that creates one (SESSION_CREATE,
 * 7.6) and joins it.
 *
 * The list is asked for on the page's own connection (SESSION_LIST is
 * allowed in a session). Creating and deleting go over a short
 * connection of their own (HELLO with the page's token, the request, its
 * answer, close): the page stays in its session meanwhile and a refused
 * request leaves it untouched; so does listing while the page has no
 * connection (stopped by a refused token). The daemon decides who may do what
 * (a viewer-only token may neither create nor delete: EPERM); the panel
 * shows its answer as it came. Joining is the page's own reconnect, to
 * the chosen session (join() from the caller).
 */
import * as P from './protocol.js';

/* How long one request may wait for its answer. */
const ANSWER_MS = 10000;

/* Why a name is not a session name (the daemon's rule, PROTOCOL.md 7.6),
 * or '' when it is one. */
export function nameProblem(name) {
	if (!name) {
		return 'type a name for the new session';
	}
	if (new TextEncoder().encode(name).length > P.LIMITS.MAX_NAME) {
		return `a session name has at most ${P.LIMITS.MAX_NAME} bytes`;
	}
	if (!/^[A-Za-z0-9_.-]+$/.test(name) || name[0] === '.') {
		return 'session names use letters, digits, "-", "_" and ".", ' +
			'not starting with "."';
	}
	return '';
}

/* "3 min ago" for a time in the past (ms since the epoch), from now. */
export function ago(ms, now) {
	const s = Math.max(0, Math.round((now - ms) / 1000));
	if (s < 60) {
		return `${s} s ago`;
	}
	if (s < 3600) {
		return `${Math.floor(s / 60)} min ago`;
	}
	if (s < 86400) {
		return `${Math.floor(s / 3600)} h ago`;
	}
	return `${Math.floor(s / 86400)} d ago`;
}

/* One line about a SESSIONS entry: members, and, when the daemon knows
 * them (flag KNOWN), primitives, last edit order and when. */
export function describe(e, now) {
	const who = `${e.members} member${e.members === 1 ? '' : 's'}`;
	if (!(e.flags & P.SESSION_FLAG.KNOWN)) {
		return `${who} · on disk, not loaded yet`;
	}
	const when = e.last_edit_ms ? ` · ${ago(Number(e.last_edit_ms), now)}`
		: '';
	return `${who} · ${e.prims} shape${e.prims === 1 ? '' : 's'} · ` +
		`edit ${e.order}${when}`;
}

/* The status line's part about scene memory, from STATS's memory
 * section (PROTOCOL.md 7.18): the nodes the loaded sessions hold of the
 * most the daemon lets them hold together (blobcastd --scene-memory). */
export function describeMemory(m) {
	const held = Number(m.scene_nodes), cap = Number(m.scene_nodes_cap);
	const pct = cap > 0 ? Math.round(100 * held / cap) : 0;
	return `scene memory ${held.toLocaleString('en')} of ` +
		`${cap.toLocaleString('en')} nodes (${pct} %)`;
}

/* A refusal from the daemon: code is its name ("EPERM"), text its
 * sentence. */
export class Refusal extends Error {
	constructor(code, text) {
		super(`${P.errName(code)}: ${text}`);
		this.code = P.errName(code);
		this.text = text;
	}
}

/* One short connection for session requests (no frames: HELLO announces
 * no encodings). ask() sends a request and resolves with the message
 * accept(m, seq) takes for its answer, or rejects with a Refusal for an
 * ERROR with its seq (or a fatal one), or an Error when the connection
 * closes or nothing comes in ANSWER_MS. */
export class Channel {
	constructor(url, { token, name }) {
		this.url = url;
		this.token = token;
		this.name = name;
		this.seq = 0;
		this.want = null;
		this.ws = null;
		this.features = 0; /* granted in WELCOME */
	}

	/* Connects and says HELLO; resolves with WELCOME. */
	open() {
		this.reader = new P.Reader({ side: 'client' });
		const ws = new WebSocket(this.url, ['binary']);
		ws.binaryType = 'arraybuffer';
		this.ws = ws;
		ws.onmessage = (e) => this.receive(e.data);
		ws.onerror = () => {};
		ws.onclose = () => this.settle(null, new Error('the daemon ' +
			'closed the connection (is websockify running?)'));
		return new Promise((resolve, reject) => {
			ws.onopen = () => this.ask(P.MSG.HELLO, { version_min: 1,
				version_max: 1, encodings: 0, max_frame_bytes: 0,
				client_name: this.name, token: this.token,
				features: P.FEATURE.ALL & ~P.FEATURE.ACKS }, (m) => m.type ===
				P.MSG.WELCOME).then((w) => {
				this.features = w.features ?? 0;
				resolve(w);
			}, reject);
			this.want = { accept: () => false, resolve, reject,
				seq: -1, timer: setTimeout(() => this.settle(null,
					new Error(`no answer from ${this.url} in ` +
						`${ANSWER_MS / 1000} s`)), ANSWER_MS) };
		});
	}

	ask(type, fields, accept) {
		clearTimeout(this.want?.timer);
		return new Promise((resolve, reject) => {
			if (!this.ws || this.ws.readyState !== WebSocket.OPEN) {
				reject(new Error('the connection is closed'));
				return;
			}
			this.seq++;
			this.want = { accept, resolve, reject, seq: this.seq,
				timer: setTimeout(() => this.settle(null, new Error(
					`no answer in ${ANSWER_MS / 1000} s`)), ANSWER_MS) };
			this.ws.send(P.encode({ ...fields, type, flags: 0,
				seq: this.seq }));
		});
	}

	settle(m, err) {
		const w = this.want;
		if (!w) {
			return;
		}
		this.want = null;
		clearTimeout(w.timer);
		if (err) {
			w.reject(err);
		} else {
			w.resolve(m);
		}
	}

	receive(data) {
		try {
			this.reader.feed(data);
			for (let m; (m = this.reader.next());) {
				if (m.type === P.MSG.PING) {
					this.ws.send(P.encode({ type: P.MSG.PONG, flags: 0,
						seq: m.seq, stamp: m.stamp }));
				} else if (m.type === P.MSG.ERROR && this.want &&
					(m.seq === this.want.seq || (m.flags &
						P.FLAG.FATAL))) {
					this.settle(null, new Refusal(m.code, m.text));
				} else if (this.want?.accept(m, this.want.seq)) {
					this.settle(m, null);
				}
			}
		} catch (e) {
			this.settle(null, e);
			this.close();
		}
	}

	close() {
		const ws = this.ws;
		this.ws = null;
		if (ws) {
			ws.onclose = null;
			ws.close();
		}
		this.settle(null, new Error('closed'));
	}
}

/* Requests on the page's own connection, with Channel's ask(): send(type,
 * fields) sends one and returns its seq (0 when the page cannot send),
 * socket() names the connection it went on, and the page hands every
 * message it receives to handle(), which takes the answers. A request
 * whose connection is gone is dropped by check(). */
class PageLink {
	constructor(send, socket) {
		this.sendFn = send;
		this.socket = socket;
		this.want = null;
	}

	check() {
		if (this.want && this.want.socket !== this.socket()) {
			this.drop(new Error('the page\'s connection closed before ' +
				'the answer; ask again'));
		}
	}

	ask(type, fields, accept) {
		return new Promise((resolve, reject) => {
			const seq = this.sendFn(type, fields);
			if (!seq) {
				reject(new Error('the page is not connected'));
				return;
			}
			this.drop(new Error('asked again'));
			this.want = { seq, accept, resolve, reject,
				socket: this.socket(), timer: setTimeout(
				() => this.drop(new Error(`no answer in ${ANSWER_MS /
					1000} s`)), ANSWER_MS) };
		});
	}

	drop(err) {
		const w = this.want;
		this.want = null;
		if (w) {
			clearTimeout(w.timer);
			w.reject(err);
		}
	}

	/* Whether m answered the request waiting here. */
	handle(m) {
		const w = this.want;
		if (!w || m.seq !== w.seq) {
			return false;
		}
		this.want = null;
		clearTimeout(w.timer);
		if (m.type === P.MSG.ERROR) {
			w.reject(new Refusal(m.code, m.text));
		} else if (w.accept(m, w.seq)) {
			w.resolve(m);
		} else {
			w.reject(new Error(`a ${P.typeName(m.type)} came for the ` +
				'request'));
		}
		return true;
	}
}

const $ = (id) => document.getElementById(id);

/* The "Sessions" section of the side panel. ctx gives: url(), token()
 * and name() for the short connections; canSend(), send(type, fields)
 * (returning the seq) and socket() (which connection) for the page's;
 * current(), the name of
 * the session the page is in (or ''); join(name), to move the page
 * there. The page hands every message to handle(). */
export class SessionPanel {
	constructor(ctx) {
		this.ctx = ctx;
		this.link = new PageLink(ctx.send, ctx.socket);
		this.entries = null; /* the last SESSIONS, or null */
		this.status = '';
		this.busy = false;
		this.shownFor = null; /* current() when last rendered */
		$('sessionrefresh').addEventListener('click', () =>
			this.refresh().catch(() => {}));
		$('sessionform').addEventListener('submit', (e) => {
			e.preventDefault();
			this.create($('sessionname').value.trim()).catch(() => {});
		});
	}

	setStatus(text, bad = false) {
		this.status = text;
		const el = $('sessioninfo');
		el.textContent = text;
		el.classList.toggle('bad', bad);
	}

	/* Whether m answered a request of the panel (the page then leaves
	 * it alone). */
	handle(m) {
		return this.link.handle(m);
	}

	/* Runs fn(channel) on a fresh connection, or on the page's (onPage,
	 * when it has one); what went wrong becomes the status line, saying
	 * what to try. */
	async run(what, fn, onPage = false) {
		this.busy = true;
		this.render();
		const ch = onPage && this.ctx.canSend() ? this.link
			: new Channel(this.ctx.url(), {
				token: this.ctx.token(), name: this.ctx.name() });
		try {
			if (ch !== this.link) {
				await ch.open();
			}
			return await fn(ch);
		} catch (e) {
			let text = `${what}: ${e.message}`;
			if (e.code === 'EPERM') {
				text = `${what}: refused by the daemon, this token may ` +
					`not do that (${e.message})`;
			} else if (e.code === 'EAUTH') {
				text = `${what}: the daemon refused the token ` +
					`(${e.message}); give one with the token… button`;
			}
			this.setStatus(text, true);
			throw e;
		} finally {
			if (ch !== this.link) {
				ch.close();
			}
			this.busy = false;
			this.render();
		}
	}

	/* Asks for the list again; resolves with its entries. A refresh
	 * asked for while one is on its way gets that one's answer. */
	refresh() {
		if (!this.listing) {
			this.listing = this.list().finally(() => {
				this.listing = null;
			});
		}
		return this.listing;
	}

	async list() {
		let mem = null;
		const m = await this.run('listing the sessions', async (ch) => {
			const l = await ch.ask(P.MSG.SESSION_LIST, {}, (a, seq) =>
				a.type === P.MSG.SESSIONS && a.seq === seq);
			/* The scene memory, from a daemon that tells it. */
			const granted = ch === this.link ? this.ctx.features()
				: ch.features;
			if (granted & P.FEATURE.MEMORY) {
				mem = await ch.ask(P.MSG.GET_STATS, {
					parts: P.STATS_PARTS.MEMORY }, (a, seq) =>
					a.type === P.MSG.STATS && a.seq === seq);
			}
			return l;
		}, true);
		this.entries = m.sessions;
		const n = m.sessions.length;
		/* A daemon with more lists the first ones by name (7.21). */
		this.setStatus((n >= P.LIMITS.MAX_SESSIONS_LISTED ? `the first ` +
			`${n} sessions of this daemon, by name` : `${n} session` +
			`${n === 1 ? '' : 's'} on this daemon`) + (mem?.has_memory
			? ` · ${describeMemory(mem)}` : ''));
		this.render();
		return m.sessions;
	}

	/* Creates session name with the daemon's built-in scene, then joins
	 * it. */
	async create(name) {
		const why = nameProblem(name);
		if (why) {
			this.setStatus(`create: ${why}`, true);
			throw new Error(why);
		}
		await this.run(`create “${name}”`, (ch) => ch.ask(
			P.MSG.SESSION_CREATE, { role: P.ROLE.EDITOR, name }, (a) =>
				a.type === P.MSG.SESSION_INFO));
		$('sessionname').value = '';
		await this.refresh().catch(() => {});
		this.setStatus(`created “${name}”; joining it`);
		this.ctx.join(name);
	}

	/* Deletes session name (after the user confirms, when ask). */
	async remove(name, ask = true) {
		if (ask && !window.confirm(`Delete session “${name}” for ` +
			'everyone? Its members are put out; the daemon keeps its ' +
			'files aside.')) {
			return;
		}
		await this.run(`delete “${name}”`, (ch) => ch.ask(
			P.MSG.SESSION_DELETE, { name }, (a, seq) => a.type ===
				P.MSG.OK && a.seq === seq));
		await this.refresh().catch(() => {});
		this.setStatus(`deleted “${name}”`);
	}

	join(name) {
		this.setStatus(`joining “${name}”`);
		this.ctx.join(name);
	}

	/* Redraws the list when something it shows changed. */
	update() {
		this.link.check();
		if (this.shownFor !== this.ctx.current()) {
			this.render();
		}
	}

	render() {
		const current = this.ctx.current();
		this.shownFor = current;
		const ul = $('sessionlist');
		ul.textContent = '';
		$('sessionrefresh').disabled = this.busy;
		if (!this.entries) {
			return;
		}
		const now = Date.now();
		for (const e of this.entries) {
			const li = document.createElement('li');
			li.dataset.session = e.name;
			const here = e.name === current;
			li.classList.toggle('here', here);
			const name = document.createElement('span');
			name.className = 'name';
			name.textContent = e.name + (here ? ' (this page)' : '');
			const info = document.createElement('span');
			info.className = 'info';
			info.textContent = describe(e, now);
			const join = document.createElement('button');
			join.type = 'button';
			join.className = 'join';
			join.textContent = 'join';
			join.disabled = here || this.busy;
			join.addEventListener('click', () => this.join(e.name));
			const del = document.createElement('button');
			del.type = 'button';
			del.className = 'delete';
			del.textContent = 'delete';
			del.disabled = here || this.busy;
			del.title = here ? 'join another session before deleting ' +
				'this one' : 'delete this session for everyone (editor ' +
				'tokens only)';
			del.addEventListener('click', () => this.remove(e.name)
				.catch(() => {}));
			li.append(name, join, del, info);
			ul.append(li);
		}
	}
}
