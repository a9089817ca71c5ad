/*
 * The blobcast page: one connection to blobcastd through websockify, the
 * session's frames on a canvas, and direct manipulation of the scene.
 *
 *  - Connection: HELLO, SESSION_JOIN, then VIEW for the canvas size; every
 *    message goes through protocol.js, whose push reader reassembles the
 *    WebSocket frames (websockify does not align them with messages).
 *  - Frames: each rectangle is decoded off the main thread by
 *    createImageBitmap (JPEG, PNG) or taken as ImageData (raw) and drawn in
 *    order onto a backing canvas of the VIEW size, scaled from the encoded
 *    image size (a refinement level n image by 2^n); image frames queued
 *    behind a newer full image frame are skipped. H.264 frames (encoding
 *    4, where WebCodecs decodes it: video.js) go through a VideoDecoder
 *    in order, none skipped, each picture drawn cropped to the view. A
 *    "refining · level N" mark shows while the last frame drawn had a
 *    level above 0 or INCOMPLETE.
 *  - Acknowledgements: with ACKS granted, FRAME_ACK names the newest
 *    frame below which every frame is drawn, dropped or taken (7.27).
 *  - Camera: orbit (drag), pan (right drag), zoom (wheel), sent as CAMERA
 *    with INTERACTING while the mouse moves and once more without it.
 *  - Picking and dragging: a press sends PICK; if it hits a primitive, the
 *    drag moves that primitive in the view plane through the hit point
 *    (EDITs with INTERACTING, at most one in flight, then a final EDIT
 *    without it). The picked primitive is ringed on an overlay canvas.
 *  - The side panel lists the members, who edited last, and sliders for the
 *    selected primitive (position, shape parameters, colour, the blend of
 *    its smooth parent).
 *  - The Scene panel (outliner.js) lists the tree, shares the selection
 *    and changes the structure: add, wrap, delete, duplicate, regroup,
 *    operator kind and blend, each one EDIT built by model.js.
 *  - The overlay shows frames per second, edit -> frame latency (from
 *    sending an EDIT to drawing the first frame whose order reflects it)
 *    and kilobytes per frame.
 *
 *  - Access: a token typed into the page or given as `#token=` (never in
 *    the query, which servers and proxies log) is kept in sessionStorage
 *    and the fragment scrubbed from the address bar. A refused token
 *    (EAUTH), a refused role (EPERM) or a missing session (ENOSESSION,
 *    unless `create=1` or the user asks to create it) stop the page with
 *    a notice instead of retrying; a lost connection is retried with a
 *    doubling delay and the session joined again.
 *  - Undo and redo, per person: Ctrl-Z sends UNDO (this member's own
 *    newest change that nobody built on), Ctrl-Shift-Z or Ctrl-Y REDO,
 *    Ctrl-Alt-Z UNDO with the session scope (the session's newest change,
 *    for its owner or the presenter; PROTOCOL.md 7.20), as do the header
 *    buttons; editors only, and not while typing in a field. The server
 *    answers every member with an EDIT_APPLIED flagged UNDO or REDO whose
 *    operations the mirror applies like any edit, and the page says who
 *    took back whose edit; ESTATE's text (nothing left, or the change
 *    someone built on) is shown as the daemon words it.
 *  - Presenting and following: the "present" button (or Shift-F) makes
 *    this page the session's presenter (PRESENT); "follow" (or F) makes
 *    its camera track the presenter's (FOLLOW; the server sends each of
 *    the presenter's cameras as FOLLOW_CAMERA and renders this page at its
 *    own size). Moving the camera leaves the follow. The page joins with
 *    FOLLOW 0 so the server says who presents (PRESENTER); the members
 *    list marks the presenter and the follow button says whom it follows.
 *    A page set to follow follows again after a reconnect or when a new
 *    presentation starts.
 *  - Honest frames: the "refining" mark says when the picture on screen
 *    is not final, and "render pending" when this page sent a camera,
 *    view or edit that no frame has answered yet.
 *
 * window.blobcast exposes the state read-only for the end-to-end test and
 * for anyone curious in the developer console.
 */
import * as P from './protocol.js';
import { Picture, parseSize } from './picture.js';
import { localBox } from './bounds.js';
import { layout, unaryLayout, unaryRange, unaryValue } from './prims.js';
import { kindName, nodeName } from './model.js';
import { Outliner } from './outliner.js';
import { Review, frameChoice } from './review.js';
import { HistoryPanel } from './history.js';
import { FrameAcks, VideoStream, h264Decodable } from './video.js';

/* ---- Small vector helpers ------------------------------------------------ */

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1],
	a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const len = (a) => Math.sqrt(dot(a, a));
const norm = (a) => scale(a, 1 / (len(a) || 1));

/* Rotates v about the unit axis k by angle a (Rodrigues). */
function rotate(v, k, a) {
	const c = Math.cos(a), s = Math.sin(a);
	return add(add(scale(v, c), scale(cross(k, v), s)),
		scale(k, dot(k, v) * (1 - c)));
}

/* Rotates v by the unit quaternion q = (x, y, z, w). */
function quatRotate(q, v) {
	const u = [q[0], q[1], q[2]];
	const t = scale(cross(u, v), 2);
	return add(add(v, scale(t, q[3])), cross(u, t));
}

/* The 12 edges of a box whose corner i has bit 0: x, bit 1: y, bit 2: z. */
const BOX_EDGES = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6],
	[5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];

/* ---- Camera ---------------------------------------------------------------- */

/* The client's own camera, with the server's conventions
 * (bc_view_rays_init): forward = target - eye, right = forward x up,
 * up' = right x forward; pixel rows grow downwards. */
class Camera {
	constructor(c) {
		this.set(c ?? { eye: [0, 1, 6], target: [0, 0, 0], up: [0, 1, 0],
			fov_y_deg: 45 });
	}

	set(c) {
		this.eye = c.eye.slice();
		this.target = c.target.slice();
		this.up = norm(c.up);
		this.fov = c.fov_y_deg;
	}

	basis() {
		const f = norm(sub(this.target, this.eye));
		const r = norm(cross(f, this.up));
		return { f, r, u: cross(r, f), t: Math.tan(this.fov * Math.PI / 360) };
	}

	/* World units per view pixel at forward distance z. */
	pixelSize(z, height) {
		return 2 * z * this.basis().t / height;
	}

	/* World point -> view pixel { x, y, z } (z: forward distance), or null
	 * behind the eye. */
	project(p, w, h) {
		const { f, r, u, t } = this.basis();
		const d = sub(p, this.eye);
		const z = dot(d, f);
		if (!(z > 1e-6)) {
			return null;
		}
		const x = dot(d, r) / (z * t * (w / h));
		const y = dot(d, u) / (z * t);
		return { x: (x + 1) * 0.5 * w, y: (1 - y) * 0.5 * h, z };
	}

	/* Turns the eye about the target: dx about the world up, dy about the
	 * camera's right, never past the poles (the server refuses an up
	 * parallel to the view). */
	orbit(dx, dy) {
		let off = sub(this.eye, this.target);
		off = rotate(off, this.up, -dx * 0.008);
		const r = norm(cross(off, this.up));
		const turned = rotate(off, r, dy * 0.008);
		const cos = dot(norm(turned), this.up);
		if (Math.abs(cos) < 0.995) {
			off = turned;
		}
		this.eye = add(this.target, off);
	}

	/* Moves eye and target in the view plane by view pixels. */
	pan(dx, dy, height) {
		const { r, u } = this.basis();
		const s = this.pixelSize(len(sub(this.target, this.eye)), height);
		const m = add(scale(r, -dx * s), scale(u, dy * s));
		this.eye = add(this.eye, m);
		this.target = add(this.target, m);
	}

	zoom(steps) {
		const off = sub(this.eye, this.target);
		const d = Math.min(Math.max(len(off) * Math.exp(steps * 0.0015),
			0.05), 1e5);
		this.eye = add(this.target, scale(norm(off), d));
	}

	msg() {
		const clamp = (v) => v.map((x) => Math.max(-P.LIMITS.MAX_ABS,
			Math.min(P.LIMITS.MAX_ABS, x)));
		return { eye: clamp(this.eye), target: clamp(this.target),
			up: this.up.slice(), fov_y_deg: this.fov };
	}
}

/* ---- Connection ------------------------------------------------------------ */

/* One WebSocket to websockify, speaking the binary protocol. */
class Connection {
	constructor(url, onMessage, onState) {
		this.url = url;
		this.onMessage = onMessage;
		this.onState = onState;
		this.seq = 0;
		this.ws = null;
		this.reader = null;
		this.bytesIn = 0;
	}

	open() {
		this.reader = new P.Reader({ side: 'client' });
		/* A big scene's SCENE_STATE comes in parts (FEATURE.PARTS). */
		this.parts = new P.SceneParts();
		this.seq = 0;
		/* websockify 0.10 relays binary frames under the 'binary'
		 * subprotocol. */
		const ws = new WebSocket(this.url, ['binary']);
		ws.binaryType = 'arraybuffer';
		this.ws = ws;
		ws.onopen = () => this.onState('open');
		ws.onclose = (e) => {
			if (this.ws === ws) {
				this.ws = null;
				this.onState('closed', e.reason || `code ${e.code}`);
			}
		};
		ws.onerror = () => {};
		ws.onmessage = (e) => this.receive(e.data);
	}

	receive(data) {
		this.bytesIn += data.byteLength;
		try {
			this.reader.feed(data);
			for (let m; (m = this.reader.next());) {
				const whole = this.parts.add(m);
				if (whole) {
					this.onMessage(whole);
				}
			}
		} catch (e) {
			/* A stream that broke the protocol cannot be resynchronized:
			 * tell the server why and start over. */
			this.onState('error', `${e.code ?? 'error'}: ${e.message}`);
			if (e instanceof P.ProtoError) {
				this.send(P.MSG.ERROR, { code: e.errno || P.ERR.EPARSE,
					text: e.message.slice(0, 200) }, P.FLAG.FATAL);
			} else {
				console.error(e);
			}
			this.close();
		}
	}

	/* Sends a message; returns its seq (1, 2, ...; 0 is never used). */
	send(type, fields = {}, flags = 0) {
		if (!this.ws || this.ws.readyState !== WebSocket.OPEN) {
			return 0;
		}
		this.seq = this.seq >= 0xffffffff ? 1 : this.seq + 1;
		this.ws.send(P.encode({ ...fields, type, flags, seq: this.seq }));
		return this.seq;
	}

	/* Bytes the browser has not handed to the network yet. */
	backlog() {
		return this.ws ? this.ws.bufferedAmount : 0;
	}

	close() {
		const ws = this.ws;
		this.ws = null;
		if (ws) {
			ws.close();
			this.onState('closed', 'closed');
		}
	}
}

/* ---- Frames ------------------------------------------------------------------- */

/* Decodes FRAME rectangles and draws them, in order, onto a backing canvas
 * of the VIEW size; the visible canvas shows that. */
class FrameView {
	/* onDrawn(m, receivedAt, skipped): m is on screen; onHandled(m): m
	 * needs nothing more (drawn, skipped or dropped); video: the
	 * VideoStream that decodes encoding-4 frames. */
	constructor(canvas, { onDrawn, onHandled, video }) {
		this.canvas = canvas;
		this.ctx = canvas.getContext('2d');
		this.back = document.createElement('canvas');
		this.bctx = this.back.getContext('2d');
		this.queue = [];
		this.busy = false;
		this.onDrawn = onDrawn;
		this.onHandled = onHandled;
		this.video = video;
	}

	/* A full picture that makes every image frame before it moot. H.264
	 * frames are never moot: each one is a link of the stream's chain. */
	static isFull(m) {
		const r = m.rects[0];
		return m.encoding !== P.ENC.H264 && m.rects.length === 1 &&
			r.x === 0 && r.y === 0 && r.w === m.image_width &&
			r.h === m.image_height;
	}

	push(m, receivedAt) {
		this.queue.push({ m, receivedAt });
		this.pump();
	}

	async pump() {
		if (this.busy) {
			return;
		}
		this.busy = true;
		try {
			while (this.queue.length) {
				/* A newer full frame makes the image frames before it
				 * moot: a slow decoder catches up instead of falling
				 * behind. */
				let start = 0;
				this.queue.forEach((f, i) => {
					if (FrameView.isFull(f.m)) {
						start = i;
					}
				});
				const skipped = this.queue.slice(0, start).filter((f) =>
					f.m.encoding !== P.ENC.H264);
				this.queue = this.queue.filter((f, i) => i >= start ||
					f.m.encoding === P.ENC.H264);
				skipped.forEach((f) => this.onHandled(f.m));
				const { m, receivedAt } = this.queue.shift();
				try {
					if (await this.draw(m)) {
						this.onDrawn(m, receivedAt, skipped.length);
					}
				} finally {
					this.onHandled(m);
				}
			}
		} finally {
			this.busy = false;
		}
	}

	async decode(m, r) {
		if (m.encoding === P.ENC.RAW) {
			const px = new Uint8ClampedArray(r.data.buffer, r.data.byteOffset,
				r.data.byteLength);
			return createImageBitmap(new ImageData(px, r.w, r.h));
		}
		const type = m.encoding === P.ENC.JPEG ? 'image/jpeg' : 'image/png';
		return createImageBitmap(new Blob([r.data], { type }));
	}

	/* Draws m; resolves with whether it is on screen (an H.264 frame the
	 * decoder could not take is not). */
	async draw(m) {
		if (this.back.width !== m.width || this.back.height !== m.height) {
			/* A new size: start from black, the next still is whole. */
			this.back.width = m.width;
			this.back.height = m.height;
		}
		if (m.encoding === P.ENC.H264) {
			/* The view's size at every level; an odd side was coded
			 * one pixel larger: the top-left width x height is the
			 * picture. */
			const drawn = await this.video.decode(m, (frame) =>
				this.bctx.drawImage(frame, 0, 0, m.width, m.height, 0, 0,
					m.width, m.height));
			if (drawn) {
				this.show();
			}
			return drawn;
		}
		const bitmaps = await Promise.all(m.rects.map((r) =>
			this.decode(m, r).catch(() => null)));
		/* A level-n image is one pixel per 2^n block, drawn from the
		 * view's top-left; the backing canvas clips what a last block
		 * reaches past the view. */
		const [sx, sy] = P.frameScale(m);
		m.rects.forEach((r, i) => {
			if (bitmaps[i]) {
				this.bctx.drawImage(bitmaps[i], r.x * sx, r.y * sy,
					r.w * sx, r.h * sy);
				bitmaps[i].close();
			}
		});
		this.show();
		return true;
	}

	show() {
		if (this.back.width) {
			this.ctx.drawImage(this.back, 0, 0, this.canvas.width,
				this.canvas.height);
		}
	}
}

/* ---- Statistics ---------------------------------------------------------- */

/* Rolling numbers for the overlay. */
class Meter {
	constructor() {
		this.frameTimes = [];
		this.frameBytes = [];
		this.latencies = [];
	}

	frame(bytes, now) {
		this.frameTimes.push(now);
		this.frameBytes.push(bytes);
		while (this.frameTimes.length && this.frameTimes[0] < now - 1000) {
			this.frameTimes.shift();
		}
		if (this.frameBytes.length > 30) {
			this.frameBytes.shift();
		}
	}

	fps(now) {
		return this.frameTimes.filter((t) => t >= now - 1000).length;
	}

	kbPerFrame() {
		const n = this.frameBytes.length;
		return n ? this.frameBytes.reduce((a, b) => a + b, 0) / n / 1024 : 0;
	}

	latency(ms) {
		this.latencies.push(ms);
		if (this.latencies.length > 50) {
			this.latencies.shift();
		}
	}
}

/* ---- The application ------------------------------------------------------------ */

const $ = (id) => document.getElementById(id);

class App {
	constructor() {
		const q = new URLSearchParams(location.search);
		this.tokenInQuery = q.has('token');
		this.cfg = {
			token: takeToken(),
			create: q.get('create') === '1',
			ws: wsUrl(q.get('ws')),
			session: q.get('session') || 'default',
			name: (q.get('name') || 'browser').slice(0, 32),
			role: q.get('role') === 'viewer' ? P.ROLE.VIEWER : P.ROLE.EDITOR,
			/* enc: jpeg (the default), png, raw, h264 or h264png
			 * (H.264 moving, the still a PNG). */
			...(frameChoice(q.get('enc')) ?? frameChoice('jpeg')),
			downscale: clampInt(q.get('downscale'), 1, 8, 2),
			quality: clampInt(q.get('quality'), 1, 100, 85),
		};
		this.canvas = $('view');
		this.overlay = $('overlay');
		this.octx = this.overlay.getContext('2d');
		/* H.264 through WebCodecs, when this browser has it: HELLO
		 * waits for the answer. */
		this.videoOk = null; /* null: not known yet */
		this.videoProbe = h264Decodable().then((ok) => this.videoKnown(ok));
		this.video = new VideoStream({ needKey: () => this.keyWanted(),
			failed: (text) => this.videoFailed(text) });
		this.frames = new FrameView(this.canvas, {
			onDrawn: (m, t, skipped) => this.drawn(m, t, skipped),
			onHandled: (m) => m.acks?.done(m.frame_no),
			video: this.video });
		this.meter = new Meter();
		this.camera = new Camera();
		this.conn = new Connection(this.cfg.ws, (m) => this.handle(m),
			(s, why) => this.connState(s, why));
		this.reset();
		this.framesDrawn = 0;
		this.framesSkipped = 0;
		this.retryMs = 500;
		this.halted = null; /* { code, text }: stopped, not retrying */
		this.installInput();
		this.installAccess();
		this.installUndo();
		this.followWanted = false; /* F: kept across reconnects */
		this.installPresent();
		this.installPicture();
		this.outliner = new Outliner(this);
		this.review = new Review(this); /* review.js: toolbar, sessions */
		this.history = new HistoryPanel(this); /* history.js */
		new ResizeObserver(() => this.resize()).observe($('stage'));
		setInterval(() => this.tick(), 250);
		this.conn.open();
	}

	/* Everything tied to one connection. */
	reset() {
		this.welcome = null;
		this.info = null;
		this.scene = null;
		this.order = 0n;
		this.view = null;
		this.selected = 0;
		this.lastEdits = new Map(); /* member id -> { order, node, at } */
		this.lastEdit = null;
		this.lastRemoteEdit = null;
		this.editSent = new Map(); /* my EDIT seq -> { sentAt, done } */
		this.undoSent = new Map(); /* my UNDO/REDO seq -> 'undo' | 'redo' */
		this.notice = ''; /* the last undo/redo notice */
		this.awaitFrame = []; /* { order, sentAt, done } of my applied edits */
		this.inflight = 0; /* seq of my interacting EDIT not yet applied */
		this.pendingEdit = null; /* the newest edit waiting for it */
		this.picks = new Map(); /* PICK seq -> resolve */
		this.drag = null;
		this.cameraDirty = false;
		this.cameraSeq = 0; /* my last CAMERA, and when it left */
		this.cameraSentAt = 0;
		this.viewSentAt = 0; /* my last VIEW, until a frame comes */
		this.viewSent = null; /* { seq, encoding, still } of my last VIEW */
		this.keyAskedAt = -Infinity; /* a VIEW sent again for a KEY */
		this.acks = null; /* FrameAcks, when WELCOME granted ACKS */
		this.snapshots = new Map(); /* my SNAPSHOT seq -> resolve */
		this.video?.reset();
		this.lastFrame = null;
		this.presenter = 0; /* PRESENTER: who presents, 0 nobody */
		this.following = false;
		this.presenceAsked = false;
		this.renderPresent();
		this.outliner?.reset();
	}

	/* ---- connection and messages ---- */

	connState(s, why) {
		const el = $('conn');
		if (s === 'open') {
			el.textContent = 'connected';
			el.className = 'conn up';
			/* Encoding 4 only where WebCodecs decodes H.264; every
			 * feature this page knows, acknowledgements included. */
			const ws = this.conn.ws;
			this.videoProbe.then(() => {
				if (this.conn.ws !== ws) {
					return;
				}
				this.conn.send(P.MSG.HELLO, { version_min: 1,
					version_max: 1, encodings: this.encodings(),
					max_frame_bytes: 0, client_name: this.cfg.name,
					token: this.cfg.token, features: P.FEATURE.ALL });
			});
			return;
		}
		if (s === 'error') {
			this.say(why);
			return;
		}
		for (const resolve of [...this.picks.values(),
			...this.snapshots.values()]) {
			resolve(null);
		}
		this.picture?.fail(`the connection was lost (${why})`);
		this.review.lost(why);
		this.reset();
		this.renderPanel();
		this.showPending();
		this.showRefining();
		if (this.halted) {
			el.textContent = `stopped (${P.errName(this.halted.code)})`;
			el.className = 'conn down';
			return;
		}
		el.textContent = `disconnected (${why}) – retrying in ` +
			`${(this.retryMs / 1000).toFixed(1)} s`;
		el.className = 'conn down';
		clearTimeout(this.retryTimer);
		this.retryTimer = setTimeout(() => this.conn.open(), this.retryMs);
		this.retryMs = Math.min(this.retryMs * 2, 8000);
	}

	/* Stops the page on an error that retrying would meet again: shows
	 * why, and what the user can do about it. */
	halt(code, text) {
		this.halted = { code, text };
		clearTimeout(this.retryTimer);
		const box = $('alert');
		box.hidden = false;
		box.dataset.code = P.errName(code);
		$('alerttext').textContent = text;
		$('tokenform').hidden = code !== P.ERR.EAUTH;
		$('create').hidden = code !== P.ERR.ENOSESSION ||
			this.cfg.role !== P.ROLE.EDITOR;
		$('create').textContent = `create session “${this.cfg.session}”`;
		$('conn').textContent = `stopped (${P.errName(code)})`;
		$('conn').className = 'conn down';
		if (code === P.ERR.EAUTH) {
			$('token').focus();
		}
	}

	/* Moves the page to session name (the session list): a new
	 * connection joins it from that session's camera. */
	switchSession(name) {
		this.cfg.session = name;
		this.cameraMoved = false;
		this.followWanted = false;
		this.resume();
	}

	/* Starts over after a halt, with what the user gave. */
	resume() {
		this.halted = null;
		$('alert').hidden = true;
		if (this.conn.ws) {
			/* Its close event schedules a retry: this one replaces it. */
			this.conn.close();
		}
		clearTimeout(this.retryTimer);
		this.retryMs = 500;
		this.conn.open();
	}

	installAccess() {
		$('tokenform').addEventListener('submit', (e) => {
			e.preventDefault();
			this.cfg.token = $('token').value;
			$('token').value = '';
			storeToken(this.cfg.token);
			this.resume();
		});
		$('tokenbtn').addEventListener('click', () => {
			const box = $('alert');
			if (!box.hidden && !$('tokenform').hidden && !this.halted) {
				box.hidden = true;
				return;
			}
			box.hidden = false;
			$('tokenform').hidden = false;
			$('create').hidden = !!this.halted ? $('create').hidden : true;
			if (!this.halted) {
				$('alerttext').textContent = this.cfg.token
					? 'a token is set for this tab; enter another to ' +
						'reconnect with it'
					: 'enter the token the daemon was given (kept in ' +
						'this tab only)';
			}
			$('token').focus();
		});
		$('create').addEventListener('click', () => {
			this.halted = null;
			$('alert').hidden = true;
			this.conn.send(P.MSG.SESSION_CREATE, { role: this.cfg.role,
				name: this.cfg.session });
		});
		if (this.tokenInQuery) {
			this.say('a token in the query (?token=) is ignored: proxies ' +
				'and servers log it; use #token= or the token button');
		}
	}

	say(text) {
		/* The title shows the whole of a long message (the daemon's
		 * words) where the header cuts it short. */
		$('message').textContent = text;
		$('message').title = text;
		clearTimeout(this.sayTimer);
		this.sayTimer = setTimeout(() => {
			$('message').textContent = '';
			$('message').title = '';
		}, 6000);
	}

	handle(m) {
		if (m.type === P.MSG.FRAME && this.acks) {
			/* Every FRAME is acknowledged once handled (7.27). */
			m.acks = this.acks;
			this.acks.got(m.frame_no, performance.now());
		}
		/* review.js takes the answers to its own requests: among them
		 * a MESH's MESH_DATA or ERROR, matched by seq, which may come
		 * after the answers to later requests (PROTOCOL.md 7.28). */
		if (this.review.saw(m) || this.history.saw(m)) {
			return;
		}
		/* The answers to a picture's tiles are its own, not frames of
		 * the view; a snapshot's answer is handled once taken. */
		if ((m.type === P.MSG.FRAME || m.type === P.MSG.ERROR) &&
			(this.picture?.handle(m) || this.snapshotAnswer(m))) {
			m.acks?.done(m.frame_no);
			return;
		}
		/* A snapshot whose asker gave up is not for the view. */
		if (m.type === P.MSG.FRAME && (m.flags & P.FLAG.SNAPSHOT)) {
			m.acks?.done(m.frame_no);
			return;
		}
		switch (m.type) {
		case P.MSG.WELCOME:
			this.welcome = m;
			if ((m.features ?? 0) & P.FEATURE.ACKS) {
				this.acks = new FrameAcks((n) => this.conn.send(
					P.MSG.FRAME_ACK, { frame_no: n }));
			}
			this.conn.send(P.MSG.SESSION_JOIN, { role: this.cfg.role,
				name: this.cfg.session });
			break;
		case P.MSG.SESSION_INFO:
			this.info = m;
			$('session').textContent = `session ${m.name}` +
				(m.role === P.ROLE.VIEWER ? ' · view only' : '');
			for (const id of ['undobtn', 'redobtn', 'undoanybtn']) {
				$(id).disabled = m.role !== P.ROLE.EDITOR;
			}
			this.renderPicture();
			if (this.viewOnly) {
				$('session').title = this.viewOnly;
				this.say(this.viewOnly);
			}
			if (!this.view) {
				this.resize(true);
				if (this.cameraMoved) {
					/* Rejoined: the server starts from the session's
					 * camera, this page keeps its own. */
					this.sendCamera(false);
				}
			}
			if (!this.presenceAsked) {
				/* FOLLOW 0: the server tells us who presents. */
				this.presenceAsked = true;
				this.conn.send(P.MSG.FOLLOW, { on: 0 });
			}
			this.renderPresent();
			this.renderMembers();
			break;
		case P.MSG.SCENE_STATE:
			this.sceneState(m);
			break;
		case P.MSG.PRESENTER:
			this.presenterChanged(m);
			break;
		case P.MSG.FOLLOW_CAMERA:
			/* The server renders us from the presenter's camera; ours
			 * becomes it, so that a drag starts from what is shown. */
			this.camera.set(m);
			this.cameraMoved = true;
			this.drawOverlay();
			break;
		case P.MSG.SESSION_CAMERA_SET:
			this.order = m.order;
			this.say(`${this.memberName(m.author)} set the session's ` +
				`camera`);
			break;
		case P.MSG.EDIT_APPLIED:
			this.editApplied(m);
			this.history.changed();
			break;
		case P.MSG.FRAME:
			this.frames.push(m, performance.now());
			break;
		case P.MSG.PICK_RESULT: {
			const resolve = this.picks.get(m.seq);
			this.picks.delete(m.seq);
			if (resolve) {
				resolve(m);
			}
			break;
		}
		case P.MSG.PING:
			this.conn.send(P.MSG.PONG, { stamp: m.stamp });
			break;
		case P.MSG.ERROR:
			this.serverError(m);
			break;
		default:
			break;
		}
	}

	serverError(m) {
		this.outliner.refused(m);
		const undo = this.undoSent.get(m.seq);
		this.undoSent.delete(m.seq);
		if (undo) {
			this.editSent.delete(m.seq);
			/* The daemon says why: nothing of mine left, my newest
			 * change built on by someone else's (ESTATE), or an undo
			 * of the session's change from neither its owner nor the
			 * presenter (EPERM). */
			this.showNotice(m.code === P.ERR.ESTATE
				? m.text || `nothing to ${undo}`
				: `${P.errName(m.code)}: ${m.text}`);
			return;
		}
		this.say(`${P.errName(m.code)}: ${m.text}`);
		/* A refused edit, camera or view gets no frame: not pending. */
		this.editSent.delete(m.seq);
		if (m.seq && m.seq === this.cameraSeq) {
			this.cameraSeq = 0;
		}
		if (m.seq && m.seq === this.viewSeq) {
			this.viewSentAt = 0;
			if (this.viewSent?.encoding === P.ENC.H264) {
				/* No H.264 from this daemon (ENOTSUP: built without
				 * an encoder): images instead. */
				this.review.refuse(this.viewSent, m);
				this.fallBack(`H.264 frames refused by the daemon ` +
					`(${P.errName(m.code)}: ${m.text})`);
				return;
			}
		}
		if (m.code === P.ERR.ECODEC && m.seq === 0 &&
			this.cfg.encoding === P.ENC.H264) {
			/* The daemon's encoder failed: its frames come in the
			 * still's encoding or JPEG now (7.15); so says the
			 * control. */
			this.cfg.encoding = this.cfg.still || P.ENC.JPEG;
			this.cfg.still = 0;
			this.review.renderView();
			return;
		}
		if (m.code === P.ERR.EAUTH) {
			this.halt(m.code, `The daemon refused ${this.cfg.token
				? 'the token' : 'to let this page in without a token'} ` +
				`(EAUTH: ${m.text}). Enter a token to try again.`);
			return;
		}
		if (m.code === P.ERR.EPROTO_VERSION) {
			this.halt(m.code, `The daemon speaks another protocol ` +
				`version (${m.text}).`);
			return;
		}
		if (m.seq === this.inflight) {
			/* The server refused my interacting edit: let the next one go. */
			this.inflight = 0;
			this.flushEdit();
		}
		const resolve = this.picks.get(m.seq);
		if (resolve) {
			this.picks.delete(m.seq);
			resolve(null);
		}
		if (m.code === P.ERR.EPERM && !this.info) {
			if (this.cfg.role === P.ROLE.EDITOR) {
				/* The token grants viewing only: look, do not touch,
				 * and say so where it stays visible. */
				this.cfg.role = P.ROLE.VIEWER;
				this.viewOnly = `view only: this token does not allow ` +
					`editing (EPERM: ${m.text})`;
				this.conn.send(P.MSG.SESSION_JOIN, { role: this.cfg.role,
					name: this.cfg.session });
			} else {
				this.halt(m.code, `The daemon refused to let this page ` +
					`into session “${this.cfg.session}” (EPERM: ${m.text}).`);
			}
			return;
		}
		if (m.code === P.ERR.EPERM) {
			/* An edit from a viewer: the page offers none, but say it
			 * plainly if one slipped through. */
			this.say(`not allowed: viewers cannot edit (EPERM: ${m.text})`);
			return;
		}
		if (m.code === P.ERR.ENOSESSION && !this.info) {
			if (this.cfg.create && this.cfg.role === P.ROLE.EDITOR) {
				/* Asked for with create=1. */
				this.conn.send(P.MSG.SESSION_CREATE, { role: this.cfg.role,
					name: this.cfg.session });
				return;
			}
			/* Joining a session that is not there is a mistake to show,
			 * not a reason to invent one with the built-in scene. */
			this.halt(m.code, `There is no session “${this.cfg.session}” ` +
				`on this daemon (ENOSESSION).` + (this.cfg.role ===
				P.ROLE.EDITOR ? ' Create it with the built-in scene, or ' +
				'check the name (?session=).' : ' Check the name ' +
				'(?session=); a viewer cannot create one.'));
		}
	}

	sceneState(m) {
		try {
			this.scene = P.parseScene(m.scene);
		} catch (e) {
			this.say(`scene not understood: ${e.message}`);
			this.scene = null;
			return;
		}
		this.order = m.order;
		if (this.scene.camera && !this.cameraMoved) {
			this.camera.set(this.scene.camera);
		}
		if (this.selected && !this.scene.byId.has(this.selected)) {
			this.selected = 0;
		}
		this.renderPanel();
		this.outliner.sceneChanged(null);
	}

	editApplied(m) {
		const now = performance.now();
		this.order = m.order;
		const nodes = m.ops.map((op) => op.node ?? op.parent);
		if (this.scene) {
			try {
				P.applyOps(this.scene, m.ops, layout);
			} catch (e) {
				/* Only a fresh SCENE_STATE can put it right: join
				 * again on a new connection. */
				this.say(`scene out of step (${e.message}); reconnecting`);
				this.conn.close();
				return;
			}
		}
		const mine = this.info && m.author === this.info.member_id;
		if (m.flags & (P.FLAG.UNDO | P.FLAG.REDO)) {
			if (mine) {
				this.undoSent.delete(m.author_seq);
			}
			const redo = (m.flags & P.FLAG.REDO) !== 0;
			this.showNotice(`${this.memberName(m.author)} ` +
				`${redo ? 'redid' : 'undid'} ` +
				`${m.target_author || 'an unnamed member'}'s edit ` +
				`${m.target_order}`);
		}
		/* The author's name as the roster gives it now: a CLI member
		 * leaves right after its edit, and the label outlives it. */
		const rec = { order: m.order, author: m.author,
			name: this.memberName(m.author), node: nodes[0],
			at: now, frameAt: 0, interacting: !!(m.flags &
				P.FLAG.INTERACTING) };
		this.lastEdits.set(m.author, rec);
		this.lastEdit = rec;
		if (mine) {
			const sent = this.editSent.get(m.author_seq);
			this.editSent.delete(m.author_seq);
			/* A change of names only draws nothing new: no frame to
			 * wait for. */
			if (sent && !m.ops.every((op) => op.kind === P.EDIT.NAME)) {
				this.awaitFrame.push({ order: m.order, ...sent });
			}
			if (m.author_seq === this.inflight) {
				this.inflight = 0;
				this.flushEdit();
			}
		} else {
			this.lastRemoteEdit = rec;
		}
		this.renderMembers();
		this.refreshSliders();
		if (m.ops.some((op) => op.kind === P.EDIT.NAME &&
			op.node === this.selected)) {
			this.renderSelName();
		}
		this.drawOverlay();
		this.outliner.sceneChanged(m);
	}

	/* A frame is on screen: settle the latencies it answers. */
	drawn(m, receivedAt, skipped) {
		const now = performance.now();
		/* Bytes on the wire: header, fixed fields, each rectangle's 12
		 * bytes and data. */
		this.meter.frame(m.rects.reduce((n, r) => n + r.data.length + 12,
			P.HEADER_SIZE + 27), now);
		this.framesDrawn++;
		this.framesSkipped += skipped;
		this.lastFrame = { frame_no: m.frame_no, order: m.order,
			still: (m.flags & P.FLAG.STILL) !== 0,
			level: P.frameLevel(m.flags),
			refining: P.frameRefining(m.flags),
			incomplete: (m.flags & P.FLAG.INCOMPLETE) !== 0,
			camera_seq: m.camera_seq, width: m.width,
			height: m.height, image_width: m.image_width,
			image_height: m.image_height, rects: m.rects.length,
			encoding: m.encoding, at: now };
		while (this.awaitFrame.length && this.awaitFrame[0].order <=
			m.order) {
			const a = this.awaitFrame.shift();
			this.meter.latency(now - a.sentAt);
			this.lastLatency = now - a.sentAt;
			a.done?.(now - a.sentAt);
		}
		for (const rec of this.lastEdits.values()) {
			if (!rec.frameAt && rec.order <= m.order) {
				rec.frameAt = now;
			}
		}
		this.viewSentAt = 0;
		this.showRefining();
		this.showPending();
		this.drawOverlay();
	}

	/* When the oldest request of this page that no frame answers yet
	 * left, or 0: an edit not applied or applied but not drawn, a CAMERA
	 * newer than the last frame's camera_seq, a VIEW before any frame. */
	pendingSince() {
		let t = Infinity;
		for (const e of this.editSent.values()) {
			t = Math.min(t, e.sentAt);
		}
		if (this.awaitFrame.length) {
			t = Math.min(t, this.awaitFrame[0].sentAt);
		}
		if (this.cameraSeq && this.cameraSeq > (this.lastFrame?.camera_seq ??
			0)) {
			t = Math.min(t, this.cameraSentAt);
		}
		if (this.viewSentAt) {
			t = Math.min(t, this.viewSentAt);
		}
		return t === Infinity ? 0 : t;
	}

	showPending() {
		const since = this.info ? this.pendingSince() : 0;
		const el = $('pending');
		el.hidden = !since;
		el.textContent = since ? `render pending · ${((performance.now() -
			since) / 1000).toFixed(1)} s` : '';
	}

	/* The "refining" mark follows the last frame drawn: shown while it
	 * was coarse (level > 0) or cut by the time budget, hidden by the
	 * first finished level-0 frame. */
	showRefining() {
		const f = this.lastFrame;
		const el = $('refining');
		el.hidden = !f?.refining;
		el.textContent = f?.refining ? `refining · level ${f.level}` +
			(f.incomplete ? ' · cut by time budget' : '') : '';
	}

	/* ---- view, camera, edits ---- */

	resize(force = false) {
		const stage = $('stage');
		const max = this.welcome ? this.welcome.max_dim : 4096;
		const w = Math.max(1, Math.min(max, Math.round(stage.clientWidth)));
		const h = Math.max(1, Math.min(max, Math.round(stage.clientHeight)));
		if (!force && this.view && this.view.width === w &&
			this.view.height === h) {
			return;
		}
		for (const c of [this.canvas, this.overlay]) {
			c.width = w;
			c.height = h;
		}
		this.frames.show();
		this.drawOverlay();
		if (!this.info) {
			return;
		}
		this.view = { width: w, height: h };
		/* Resizing sends many sizes in a row: the last one counts. */
		clearTimeout(this.viewTimer);
		this.viewTimer = setTimeout(() => this.sendView(), force ? 0 : 120);
	}

	/* VIEW for this.view in the chosen encoding; the still in its own
	 * (still_encoding) only after a HELLO with encoding 4 that the
	 * daemon took. */
	sendView() {
		const { width, height } = this.view;
		const { encoding, quality } = this.cfg;
		const still = encoding === P.ENC.H264 ? this.cfg.still : 0;
		const seq = this.conn.send(P.MSG.VIEW, { width, height, encoding,
			quality_interactive: Math.min(quality, 70),
			quality_still: quality, downscale: this.cfg.downscale,
			...(still ? { still_encoding: still } : {}) });
		this.viewSeq = seq;
		if (seq) {
			this.viewSentAt = performance.now();
			this.viewSent = { seq, encoding, still };
		}
	}

	/* ---- H.264 (video.js) ---- */

	/* HELLO's encodings: the images, and H.264 where it decodes. */
	encodings() {
		return P.ENCODINGS_IMAGES | (this.videoOk ? 1 << (P.ENC.H264 - 1)
			: 0);
	}

	/* The answer of the WebCodecs probe: without H.264 the page keeps
	 * to images, whatever enc= asked. */
	videoKnown(ok) {
		this.videoOk = ok;
		if (!ok && this.cfg.encoding === P.ENC.H264) {
			this.cfg.encoding = P.ENC.JPEG;
			this.cfg.still = 0;
			this.say('H.264 video needs WebCodecs\' VideoDecoder with ' +
				'H.264, which this browser lacks: JPEG frames instead');
		}
		this.review?.renderView();
	}

	/* A delta frame came with no KEY before it (or the decoder lost its
	 * place): the same VIEW again makes the daemon start the stream
	 * over with a KEY (7.15). At most once a second. */
	keyWanted() {
		const now = performance.now();
		if (!this.info || !this.view || this.cfg.encoding !==
			P.ENC.H264 || now - this.keyAskedAt < 1000) {
			return;
		}
		this.keyAskedAt = now;
		this.sendView();
	}

	/* The decoder broke: say so and ask for JPEG. */
	videoFailed(text) {
		this.review.videoFailed(text);
		this.fallBack(`H.264 decoding failed (${text})`);
	}

	/* JPEG frames instead of H.264, saying why. */
	fallBack(why) {
		if (this.cfg.encoding !== P.ENC.H264) {
			return;
		}
		this.cfg.encoding = P.ENC.JPEG;
		this.cfg.still = 0;
		this.say(`${why}: JPEG frames instead`);
		this.review.renderView();
		if (this.info && this.view) {
			this.sendView();
		}
	}

	/* ---- snapshots of the view (tests and the console) ---- */

	/* SNAPSHOT of the view (PNG or raw): resolves with the answering
	 * FRAME, or null when refused or the connection went. */
	snapshot(encoding) {
		return new Promise((resolve) => {
			const seq = this.conn.send(P.MSG.SNAPSHOT, { encoding });
			if (!seq) {
				resolve(null);
				return;
			}
			this.snapshots.set(seq, resolve);
		});
	}

	/* Takes the answer to snapshot() (FRAME or ERROR); returns whether m
	 * was one. */
	snapshotAnswer(m) {
		const resolve = m.seq ? this.snapshots.get(m.seq) : undefined;
		if (!resolve || (m.type === P.MSG.FRAME && !(m.flags &
			P.FLAG.SNAPSHOT))) {
			return false;
		}
		this.snapshots.delete(m.seq);
		resolve(m.type === P.MSG.FRAME ? m : null);
		return true;
	}

	sendCamera(interacting) {
		this.cameraMoved = true;
		if (this.following) {
			/* Our own camera ends the follow (PRESENTER says so). */
			this.followWanted = false;
		}
		const seq = this.conn.send(P.MSG.CAMERA, this.camera.msg(),
			interacting ? P.FLAG.INTERACTING : 0);
		if (seq) {
			this.cameraSeq = seq;
			this.cameraSentAt = performance.now();
		}
		this.drawOverlay();
	}

	/* Queues a SET of node's fields. Interacting edits go one at a time
	 * (the next when the server has applied the last), the newest values
	 * replacing any not yet sent, so a slow server is never flooded and
	 * never lags behind the mouse; a final edit goes at once. */
	edit(node, fields, interacting, done) {
		if (!this.info || this.info.role !== P.ROLE.EDITOR) {
			this.say('viewers cannot edit');
			return;
		}
		this.pendingEdit = { node, fields, interacting, done };
		if (!interacting || !this.inflight) {
			this.flushEdit();
		}
	}

	flushEdit() {
		const e = this.pendingEdit;
		if (!e) {
			return;
		}
		this.pendingEdit = null;
		const seq = this.sendOps([{ kind: P.EDIT.SET, node: e.node,
			fields: e.fields }], e.interacting, e.done);
		if (seq && e.interacting) {
			this.inflight = seq;
		}
	}

	/* Sends one EDIT of ops (the outliner's structural edits go at once,
	 * whole); returns its seq, 0 when not sent. */
	sendOps(ops, interacting = false, done = undefined) {
		let seq;
		try {
			seq = this.conn.send(P.MSG.EDIT, { ops },
				interacting ? P.FLAG.INTERACTING : 0);
		} catch (err) {
			this.say(`edit not sent: ${err.message}`);
			return 0;
		}
		if (seq) {
			this.editSent.set(seq, { sentAt: performance.now(), done });
		}
		return seq;
	}

	pick(x, y) {
		return new Promise((resolve) => {
			const seq = this.conn.send(P.MSG.PICK, { x, y });
			if (!seq) {
				resolve(null);
				return;
			}
			this.picks.set(seq, resolve);
		});
	}

	/* Sends UNDO (redo false) or REDO without waiting: the answer is
	 * the EDIT_APPLIED every member gets, or ERROR ESTATE. */
	undo(redo, session = false) {
		if (!this.info || this.info.role !== P.ROLE.EDITOR) {
			this.say('viewers cannot undo');
			return;
		}
		/* A daemon that granted HISTORY undoes the member's own change
		 * for an empty UNDO; the session's newest needs the scope byte
		 * (owner or presenter only: others get EPERM, shown as is). */
		const history = ((this.welcome?.features ?? 0) &
			P.FEATURE.HISTORY) !== 0;
		if (session && !history) {
			this.say('this daemon has no per-person undo: undo takes ' +
				"back the session's newest change already");
			return;
		}
		const seq = this.conn.send(redo ? P.MSG.REDO : P.MSG.UNDO,
			session ? { scope: P.UNDO_SCOPE.SESSION } : {});
		if (seq) {
			this.undoSent.set(seq, redo ? 'redo' : 'undo');
			this.editSent.set(seq, { sentAt: performance.now() });
		}
	}

	/* PRESENTER: who presents now, and whether we follow. */
	presenterChanged(m) {
		const was = this.presenter;
		const followed = this.following;
		const me = this.info?.member_id ?? 0;
		this.presenter = m.presenter;
		this.following = !!m.following;
		if (m.presenter && m.presenter !== me && !m.following &&
			this.followWanted) {
			this.conn.send(P.MSG.FOLLOW, { on: 1 });
		} else if (this.following && !followed) {
			this.say(`following ${this.memberName(m.presenter)}`);
		} else if (!m.presenter && was) {
			this.say(`${was === me ? 'you' : this.memberName(was)} ` +
				'stopped presenting');
		} else if (m.presenter !== was && m.presenter === me) {
			this.say('you present: followers see your camera');
		} else if (m.presenter !== was) {
			this.say(`${this.memberName(m.presenter)} presents: ` +
				'follow (F) to see the camera');
		} else if (followed && !this.following) {
			this.say('not following');
		}
		this.renderPresent();
		this.renderMembers();
	}

	/* The follow button (F): on follows the presenter (or whoever
	 * presents next); off stops. */
	toggleFollow() {
		const me = this.info?.member_id ?? 0;
		if (this.following || this.followWanted) {
			this.followWanted = false;
			if (this.following) {
				this.conn.send(P.MSG.FOLLOW, { on: 0 });
			} else {
				this.say('not following');
			}
			this.renderPresent();
			return;
		}
		if (this.presenter && this.presenter === me) {
			this.say('you present; stop presenting to follow');
			return;
		}
		this.followWanted = true;
		if (this.presenter) {
			this.conn.send(P.MSG.FOLLOW, { on: 1 });
		} else {
			this.say('nobody presents; following whoever starts');
		}
		this.renderPresent();
	}

	/* The present button (Shift-F). */
	togglePresent() {
		const me = this.info?.member_id ?? 0;
		const on = !(this.presenter && this.presenter === me);
		if (on) {
			this.followWanted = false;
		}
		this.conn.send(P.MSG.PRESENT, { on: on ? 1 : 0 });
	}

	renderPresent() {
		const me = this.info?.member_id ?? 0;
		const fb = $('followbtn');
		const pb = $('presentbtn');
		const presenting = !!this.presenter && this.presenter === me;
		fb.setAttribute('aria-pressed', String(this.following ||
			this.followWanted));
		fb.textContent = this.following
			? `following ${this.memberName(this.presenter)}`
			: this.followWanted ? 'follow: waiting' : 'follow';
		fb.disabled = !this.info || presenting;
		pb.setAttribute('aria-pressed', String(presenting));
		pb.textContent = presenting ? 'presenting' : 'present';
		pb.disabled = !this.info;
	}

	installPresent() {
		$('followbtn').addEventListener('click', () => this.toggleFollow());
		$('presentbtn').addEventListener('click', () => this.togglePresent());
		document.addEventListener('keydown', (e) => {
			const t = e.target;
			if (e.ctrlKey || e.metaKey || e.altKey || e.key.toLowerCase() !==
				'f' || (t && (t.isContentEditable || ['INPUT', 'TEXTAREA',
				'SELECT'].includes(t.tagName)))) {
				return;
			}
			e.preventDefault();
			if (e.shiftKey) {
				this.togglePresent();
			} else {
				this.toggleFollow();
			}
		});
	}

	/* ---- big pictures (picture.js) ---- */

	installPicture() {
		$('pictureform').addEventListener('submit', (e) => {
			e.preventDefault();
			const size = parseSize($('picturesize').value);
			if (!size) {
				this.say('picture size: WxH, each 1..8192');
				return;
			}
			this.savePicture(size.w, size.h).catch(() => {});
		});
	}

	/* The form works once joined, with a daemon that takes tiles; the
	 * line under it says so, or what the last picture did (keep). */
	renderPicture(keep = false) {
		const tiles = !!this.welcome && ((this.welcome.features ?? 0) &
			P.FEATURE.TILES) !== 0;
		$('picturebtn').disabled = !this.info || !tiles || !!this.picture;
		if (!keep) {
			$('pictureinfo').textContent = this.info && !tiles
				? 'this daemon does not take pictures in tiles'
				: 'lossless PNG up to 8192×8192 of this view\'s camera';
		}
	}

	/* Asks for a w x h picture in tiles and saves it as a download;
	 * resolves with { canvas, order } (tile: the tile edge, tests). */
	async savePicture(w, h, tile) {
		if (this.picture) {
			throw new Error('a picture is on its way');
		}
		this.picture = new Picture({ width: w, height: h, tile,
			send: (type, fields) => this.conn.send(type, fields),
			progress: (done, total) => {
				$('pictureinfo').textContent =
					`picture ${w}×${h}: tile ${done} of ${total}`;
			} });
		this.renderPicture();
		try {
			const r = await this.picture.start();
			const blob = await new Promise((resolve) =>
				r.canvas.toBlob(resolve, 'image/png'));
			const a = document.createElement('a');
			a.href = URL.createObjectURL(blob);
			a.download = `blobcast-${this.cfg.session}-${r.order}.png`;
			a.click();
			setTimeout(() => URL.revokeObjectURL(a.href), 60000);
			$('pictureinfo').textContent = `saved ${w}×${h} of edit ` +
				`${r.order} (${this.picture.total} tiles)`;
			this.lastPicture = r;
			return r;
		} catch (e) {
			$('pictureinfo').textContent = `picture: ${e.message}`;
			throw e;
		} finally {
			this.picture = null;
			this.renderPicture(true);
		}
	}

	showNotice(text) {
		this.notice = text;
		this.say(text);
	}

	installUndo() {
		$('undobtn').addEventListener('click', () => this.undo(false));
		$('redobtn').addEventListener('click', () => this.undo(true));
		$('undoanybtn').addEventListener('click', () =>
			this.undo(false, true));
		document.addEventListener('keydown', (e) => {
			if (!(e.ctrlKey || e.metaKey)) {
				return;
			}
			const t = e.target;
			if (t && (t.isContentEditable || ['INPUT', 'TEXTAREA',
				'SELECT'].includes(t.tagName))) {
				return; /* the field's own undo */
			}
			if (e.altKey) {
				if (e.code === 'KeyZ' && !e.shiftKey) {
					e.preventDefault();
					this.undo(false, true);
				}
				return;
			}
			const k = e.key.toLowerCase();
			if (k === 'z' || (k === 'y' && !e.shiftKey)) {
				e.preventDefault();
				this.undo(k === 'y' || e.shiftKey);
			}
		});
	}

	/* ---- input ---- */

	viewXY(e) {
		const r = this.canvas.getBoundingClientRect();
		const w = this.view ? this.view.width : this.canvas.width;
		const h = this.view ? this.view.height : this.canvas.height;
		return {
			x: Math.min(w - 1, Math.max(0, Math.floor((e.clientX - r.left) *
				w / r.width))),
			y: Math.min(h - 1, Math.max(0, Math.floor((e.clientY - r.top) *
				h / r.height))),
		};
	}

	installInput() {
		const c = this.canvas;
		c.addEventListener('contextmenu', (e) => e.preventDefault());
		c.addEventListener('pointerdown', (e) => this.pointerDown(e));
		c.addEventListener('pointermove', (e) => this.pointerMove(e));
		c.addEventListener('pointerup', (e) => this.pointerUp(e));
		c.addEventListener('pointercancel', (e) => this.pointerUp(e));
		c.addEventListener('wheel', (e) => {
			e.preventDefault();
			this.camera.zoom(e.deltaY);
			this.sendCamera(true);
			clearTimeout(this.wheelTimer);
			this.wheelTimer = setTimeout(() => this.sendCamera(false), 200);
		}, { passive: false });
		requestAnimationFrame(() => this.animate());
	}

	pointerDown(e) {
		if (this.drag || !this.info) {
			return;
		}
		this.canvas.setPointerCapture(e.pointerId);
		this.canvas.classList.add('dragging');
		const p = this.viewXY(e);
		const d = { id: e.pointerId, start: p, last: p, now: p, moved: false,
			mode: e.button === 2 || e.button === 1 || e.shiftKey ? 'pan'
				: 'pending' };
		this.drag = d;
		if (d.mode === 'pan') {
			return;
		}
		/* Whether this press starts a camera orbit or a shape drag
		 * depends on what is under it: ask the server. */
		this.pick(p.x, p.y).then((r) => {
			if (this.drag !== d) {
				return;
			}
			const n = r && r.node && this.scene ? this.scene.byId.get(r.node)
				: null;
			if (n && !n.isOp && this.info.role === P.ROLE.EDITOR) {
				this.select(r.node);
				const z = dot(sub(r.position, this.camera.eye),
					this.camera.basis().f);
				d.mode = 'move';
				d.node = r.node;
				d.origin = n.translate.slice();
				d.perPixel = this.camera.pixelSize(z, this.view.height);
			} else {
				if (n && !n.isOp) {
					this.select(r.node);
				} else if (!d.moved) {
					this.select(0);
				}
				d.mode = 'orbit';
			}
			this.dragStep();
		});
	}

	pointerMove(e) {
		const d = this.drag;
		if (!d || d.id !== e.pointerId) {
			return;
		}
		d.now = this.viewXY(e);
		if (Math.abs(d.now.x - d.start.x) + Math.abs(d.now.y - d.start.y) >
			2) {
			d.moved = true;
		}
	}

	/* Applies the pointer's motion since the last step; called once per
	 * animation frame so that bursts of mouse events cost one message. */
	dragStep(final = false) {
		const d = this.drag;
		if (!d || d.mode === 'pending') {
			return;
		}
		const dx = d.now.x - d.last.x, dy = d.now.y - d.last.y;
		if (!dx && !dy && !final) {
			return;
		}
		d.last = d.now;
		if (d.mode === 'orbit') {
			this.camera.orbit(dx, dy);
			this.sendCamera(!final);
		} else if (d.mode === 'pan') {
			this.camera.pan(dx, dy, this.view ? this.view.height : 1);
			this.sendCamera(!final);
		} else if (d.mode === 'move') {
			/* Through the hit point, parallel to the screen. */
			const { r, u } = this.camera.basis();
			const tx = (d.now.x - d.start.x) * d.perPixel;
			const ty = (d.now.y - d.start.y) * d.perPixel;
			const t = add(d.origin, add(scale(r, tx), scale(u, -ty)));
			d.translate = t;
			this.edit(d.node, [{ field: P.FIELD.TRANSLATE, values: t }],
				!final);
		}
	}

	pointerUp(e) {
		const d = this.drag;
		if (!d || d.id !== e.pointerId) {
			return;
		}
		this.canvas.classList.remove('dragging');
		if (d.mode === 'pending') {
			/* Let the pick answer decide, then finish. */
			const wait = () => {
				if (d.mode === 'pending' && this.drag === d) {
					setTimeout(wait, 10);
					return;
				}
				this.finishDrag(d);
			};
			wait();
			return;
		}
		this.finishDrag(d);
	}

	finishDrag(d) {
		if (this.drag !== d) {
			return;
		}
		if (d.moved) {
			this.dragStep(true);
		}
		this.drag = null;
	}

	animate() {
		this.dragStep();
		requestAnimationFrame(() => this.animate());
	}

	/* ---- selection and panel ---- */

	select(id) {
		if (this.selected === id) {
			return;
		}
		this.selected = id;
		this.renderPanel();
		this.drawOverlay();
		this.outliner.selected(id);
	}

	/* Rough size of a primitive, for slider ranges. */
	static radius(n) {
		const s = n.params.reduce((a, v) => a + v * v, 0);
		return Math.max(0.05, Math.min(Math.sqrt(s), 1e3));
	}

	/* The corners of a primitive's bounding box, in view pixels (null if
	 * one is behind the eye). */
	corners(n) {
		const [lo, hi] = localBox(n.kind, n.params);
		const out = [];
		for (let i = 0; i < 8; i++) {
			const c = [i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1],
				i & 4 ? hi[2] : lo[2]];
			const w = add(n.translate, quatRotate(n.rotate, c));
			const p = this.camera.project(w, this.view.width,
				this.view.height);
			if (!p) {
				return null;
			}
			out.push(p);
		}
		return out;
	}

	/* Where a primitive appears: its centre and half the diagonal of its
	 * box's screen extent, in view pixels; null when off to the side or
	 * behind. */
	project(id) {
		const n = this.scene?.byId.get(id);
		if (!n || n.isOp || !this.view) {
			return null;
		}
		const c = this.camera.project(n.translate, this.view.width,
			this.view.height);
		const k = this.corners(n);
		if (!c || !k) {
			return null;
		}
		const xs = k.map((p) => p.x), ys = k.map((p) => p.y);
		const r = Math.hypot(Math.max(...xs) - Math.min(...xs),
			Math.max(...ys) - Math.min(...ys)) / 2;
		return { x: c.x, y: c.y, r };
	}

	/* Outlines the selected primitive's bounding box on the overlay. */
	drawOverlay() {
		const ctx = this.octx;
		ctx.clearRect(0, 0, this.overlay.width, this.overlay.height);
		const n = this.selected ? this.scene?.byId.get(this.selected) : null;
		if (!n || n.isOp || !this.view) {
			return;
		}
		const k = this.corners(n);
		if (!k) {
			return;
		}
		const sx = this.overlay.width / this.view.width;
		const sy = this.overlay.height / this.view.height;
		ctx.lineWidth = 1.5;
		ctx.strokeStyle = '#f2b84b';
		ctx.setLineDash([5, 3]);
		ctx.beginPath();
		for (const [a, b] of BOX_EDGES) {
			ctx.moveTo(k[a].x * sx, k[a].y * sy);
			ctx.lineTo(k[b].x * sx, k[b].y * sy);
		}
		ctx.stroke();
		ctx.setLineDash([]);
		const top = k.reduce((a, p) => (p.y < a.y ? p : a));
		ctx.font = '12px system-ui, sans-serif';
		ctx.fillStyle = '#f2b84b';
		ctx.fillText(nodeName(n), top.x * sx + 6,
			Math.max(14, top.y * sy - 6));
	}

	memberName(id) {
		const m = this.info?.members.find((k) => k.id === id);
		return m ? m.name || `member ${id}` : `member ${id}`;
	}

	renderMembers() {
		const ul = $('members');
		ul.textContent = '';
		if (!this.info) {
			return;
		}
		const last = this.lastEdit ? this.lastEdit.author : 0;
		for (const m of this.info.members) {
			const li = document.createElement('li');
			const name = document.createElement('span');
			name.textContent = (m.name || `member ${m.id}`) +
				(m.id === this.info.member_id ? ' (you)' : '');
			const role = document.createElement('span');
			role.className = 'role';
			role.textContent = m.role === P.ROLE.EDITOR ? 'editor' : 'viewer';
			li.append(name, role);
			if (m.id === this.presenter) {
				const mark = document.createElement('span');
				mark.className = 'presenting';
				mark.textContent = this.following ? '▶ presenting · followed'
					: '▶ presenting';
				li.append(mark);
			}
			if (m.id === last) {
				const mark = document.createElement('span');
				mark.className = 'last';
				mark.textContent = '✎ last edit';
				li.append(mark);
			}
			li.dataset.member = String(m.id);
			ul.append(li);
		}
		this.renderLastEdit();
	}

	renderLastEdit() {
		const e = this.lastEdit;
		if (!e) {
			$('lastedit').textContent = 'no edit yet';
			return;
		}
		const n = this.scene?.byId.get(e.node);
		const ago = ((performance.now() - e.at) / 1000).toFixed(1);
		$('lastedit').textContent = `last edit: ${e.name}` +
			` · ${n ? nodeName(n) : 'node ' + e.node}` +
			` · order ${e.order} · ${ago} s ago`;
	}

	/* The selection's line: its name (when it has one), kind and id. */
	renderSelName() {
		const n = this.selected ? this.scene?.byId.get(this.selected) : null;
		const p = $('selname');
		if (!n) {
			p.textContent = 'click a shape to select it';
			return;
		}
		const what = document.createElement('span');
		what.className = n.name ? 'kindid' : '';
		what.textContent = `${kindName(n)} #${n.id}` +
			(n.stale ? ' (parameters out of date)' : '');
		if (n.name) {
			const name = document.createElement('strong');
			name.className = 'selnodename';
			name.textContent = n.name;
			p.replaceChildren(name, ' ', what);
		} else {
			p.replaceChildren(what);
		}
	}

	renderPanel() {
		const box = $('sliders');
		box.textContent = '';
		this.sliders = [];
		this.renderSelName();
		const n = this.selected ? this.scene?.byId.get(this.selected) : null;
		if (!n) {
			return;
		}
		if (n.isOp) {
			/* Operators and unary nodes are edited in the Scene panel. */
			return;
		}
		const size = App.radius(n);
		const group = (title) => {
			this.group = title.split(' ')[0];
			const g = document.createElement('div');
			g.className = 'group';
			g.textContent = title;
			box.append(g);
		};
		group('position');
		['x', 'y', 'z'].forEach((c, i) => this.slider(box, c,
			() => n.translate[i], n.translate[i] - 3 * size - 1,
			n.translate[i] + 3 * size + 1, (v, live) => {
				const t = n.translate.slice();
				t[i] = v;
				this.edit(n.id, [{ field: P.FIELD.TRANSLATE, values: t }],
					live);
			}));
		const lay = layout(n.kind);
		if (lay && lay.reduce((a, d) => a + d.count, 0) === n.params.length) {
			group('shape');
			lay.forEach((d, k) => {
				for (let i = 0; i < d.count; i++) {
					const at = d.offset + i;
					const v0 = n.params[at];
					const [lo, hi] = d.rule === 'deg' ? [1, 359]
						: d.rule === 'free' ? [v0 - 2 * size - 1,
							v0 + 2 * size + 1]
							: [d.rule === 'pos' ? 0.005 : 0,
								Math.max(1, 3 * v0)];
					const label = d.count > 1 ? `${d.name}.${'xyz'[i]}` : d.name;
					this.slider(box, label, () => n.params[at], lo, hi,
						(v, live) => {
							const vals = n.params.slice(d.offset,
								d.offset + d.count);
							vals[i] = v;
							this.edit(n.id, [{ field: P.FIELD.PARAM0 + k,
								values: vals }], live);
						});
				}
			});
		} else if (n.params.length) {
			group(`shape (${n.params.length} values, layout unknown)`);
		}
		group('colour');
		const col = () => n.color ?? [0.8, 0.8, 0.8];
		['r', 'g', 'b'].forEach((c, i) => this.slider(box, c,
			() => col()[i], 0, 1, (v, live) => {
				const rgb = col().slice();
				rgb[i] = v;
				this.edit(n.id, [{ field: P.FIELD.COLOR, values: rgb }], live);
			}));
		const op = n.parent;
		if (op && op.kind >= 4 && op.kind <= 6) {
			group(`${kindName(op)} #${op.id}`);
			this.slider(box, 'blend', () => op.blend, 0.005,
				Math.max(1, 3 * op.blend), (v, live) => {
					/* The range must stay above blend / 6 (G is continuous
					 * for range >= blend): raise it along when needed. */
					const fields = [{ field: P.FIELD.BLEND, values: [v] }];
					if (op.range < v) {
						fields.push({ field: P.FIELD.RANGE, values: [v] });
					}
					this.edit(op.id, fields, live);
				});
		}
		/* The unary and domain nodes above the shape, their parameters. */
		for (let u = n.parent; u; u = u.parent) {
			const ul = u.unary ? unaryLayout(u.kind) : null;
			if (!ul || ul.reduce((a, d) => a + d.count, 0) !==
				u.params.length) {
				continue;
			}
			group(`${kindName(u)} #${u.id}`);
			ul.forEach((d, k) => {
				for (let i = 0; i < d.count; i++) {
					const at = d.offset + i;
					const [lo, hi] = unaryRange(d.rule, u.params[at]);
					this.slider(box, d.count > 1 ? `${d.name}.${'xyz'[i]}`
						: d.name, () => u.params[at], lo, hi, (v, live) => {
						const vals = u.params.slice(d.offset,
							d.offset + d.count);
						vals[i] = unaryValue(d.rule, v);
						this.edit(u.id, [{ field: P.FIELD.PARAM0 + k,
							values: vals }], live);
					});
				}
			});
		}
	}

	/* One slider: input events edit with INTERACTING, change ends it. */
	slider(box, label, get, lo, hi, send) {
		const row = document.createElement('div');
		row.className = 'slider';
		const l = document.createElement('label');
		l.textContent = label;
		const input = document.createElement('input');
		input.type = 'range';
		input.min = String(lo);
		input.max = String(hi);
		input.step = String((hi - lo) / 500);
		input.value = String(get());
		input.setAttribute('aria-label', label);
		/* Viewers see the values but cannot change them. */
		input.disabled = this.info?.role !== P.ROLE.EDITOR;
		input.dataset.key = `${this.group}/${label}`;
		const out = document.createElement('output');
		out.textContent = get().toFixed(3);
		input.addEventListener('input', () => {
			out.textContent = Number(input.value).toFixed(3);
			send(Number(input.value), true);
		});
		input.addEventListener('change', () => send(Number(input.value),
			false));
		row.append(l, input, out);
		box.append(row);
		this.sliders.push({ input, out, get });
	}

	/* New values from the session, except under the user's own hand. */
	refreshSliders() {
		for (const s of this.sliders ?? []) {
			if (document.activeElement !== s.input) {
				s.input.value = String(s.get());
				s.out.textContent = s.get().toFixed(3);
			}
		}
		const n = this.selected ? this.scene?.byId.get(this.selected) : null;
		if (this.selected && !n) {
			this.selected = 0;
			this.renderPanel();
		}
	}

	/* ---- the overlay numbers ---- */

	tick() {
		const now = performance.now();
		$('fps').textContent = String(this.meter.fps(now));
		const l = this.meter.latencies;
		if (l.length) {
			const avg = l.reduce((a, b) => a + b, 0) / l.length;
			$('latency').textContent = `${this.lastLatency.toFixed(0)} ms ` +
				`(avg ${avg.toFixed(0)})`;
		}
		const kb = this.meter.kbPerFrame();
		$('kb').textContent = kb ? kb.toFixed(1) : '–';
		const f = this.lastFrame;
		if (f) {
			$('frameinfo').textContent = `#${f.frame_no} · ` +
				`${f.image_width}×${f.image_height}` +
				(f.image_width !== f.width ? ` → ${f.width}×${f.height}` : '') +
				` · ${['', 'jpeg', 'png', 'raw', 'h264'][f.encoding]}` +
				` · ${f.rects} rect${f.rects > 1 ? 's' : ''}` +
				(f.level ? ` · level ${f.level}` : '') +
				(f.still ? ' · still' : '') + ` · order ${f.order}`;
		}
		this.renderLastEdit();
		this.showPending();
		this.review.update();
		/* A frame nothing took in 5 s is let go: never a stall. */
		this.acks?.let(now, 5000);
	}

	/* ---- for tests and the console ---- */

	state() {
		return {
			connected: !!this.info,
			features: this.welcome?.features ?? 0,
			memberId: this.info?.member_id ?? 0,
			members: this.info?.members.map((m) => ({ ...m })) ?? [],
			order: String(this.order),
			framesDrawn: this.framesDrawn,
			lastFrame: this.lastFrame ? { ...this.lastFrame,
				order: String(this.lastFrame.order) } : null,
			selected: this.selected,
			lastEdit: this.lastEdit ? { ...this.lastEdit,
				order: String(this.lastEdit.order) } : null,
			lastRemoteEdit: this.lastRemoteEdit ? { ...this.lastRemoteEdit,
				order: String(this.lastRemoteEdit.order) } : null,
			latencies: this.meter.latencies.slice(),
			view: this.view,
			role: this.info?.role ?? 0,
			presenter: this.presenter,
			following: this.following,
			followWanted: this.followWanted,
			camera: { eye: this.camera.eye.slice(),
				target: this.camera.target.slice(), fov: this.camera.fov },
			notice: this.notice,
			halted: this.halted ? { code: P.errName(this.halted.code),
				text: this.halted.text } : null,
			tokenSet: !!this.cfg.token,
			pending: !!(this.info && this.pendingSince()),
			encoding: this.cfg.encoding,
			stillEncoding: this.cfg.still,
			encodings: this.encodings(),
			videoOk: this.videoOk,
			video: this.video.state(),
			acks: this.acks ? this.acks.state() : null,
			/* A scene file from the page: 'reading' (in a worker, or
			 * here where none could), 'loading' (sent) or ''. */
			loading: this.review.loading().state,
		};
	}
}

/* The token lives in this tab's sessionStorage: it survives a reload,
 * not the tab, and never travels in a URL the server or a proxy logs. A
 * `#token=` fragment (which browsers do not send) is taken once and
 * scrubbed from the address bar and the history entry. */
const TOKEN_KEY = 'blobcast.token';

function storeToken(t) {
	try {
		if (t) {
			sessionStorage.setItem(TOKEN_KEY, t);
		} else {
			sessionStorage.removeItem(TOKEN_KEY);
		}
	} catch {
		/* Storage disabled: the token lasts until the page reloads. */
	}
}

function takeToken() {
	const h = new URLSearchParams(location.hash.slice(1));
	if (h.has('token')) {
		const t = h.get('token').slice(0, P.LIMITS.MAX_TOKEN);
		storeToken(t);
		h.delete('token');
		const rest = h.toString();
		history.replaceState(null, '', location.pathname + location.search +
			(rest ? `#${rest}` : ''));
		return t;
	}
	try {
		return sessionStorage.getItem(TOKEN_KEY) || '';
	} catch {
		return '';
	}
}

function clampInt(s, lo, hi, def) {
	const v = Number.parseInt(s ?? '', 10);
	return Number.isFinite(v) ? Math.min(hi, Math.max(lo, v)) : def;
}

/* ?ws= takes a URL or a port; by default websockify listens on the page's
 * port plus one (deploy/web-demo.sh). */
function wsUrl(v) {
	const host = location.hostname || '127.0.0.1';
	if (v && /^wss?:\/\//.test(v)) {
		return v;
	}
	const port = v && /^\d+$/.test(v) ? v : String(Number(location.port ||
		80) + 1);
	return `${location.protocol === 'https:' ? 'wss' : 'ws'}://${host}:${port}/`;
}

const app = new App();
window.blobcast = {
	state: () => app.state(),
	/* View pixel of a node's centre and its ring radius, or null. */
	project: (id) => app.project(id),
	primitives: () => app.scene ? [...app.scene.byId.values()]
		.filter((n) => !n.isOp).map((n) => ({ id: n.id, kind: kindName(n),
			translate: n.translate.slice() })) : [],
	node: (id) => {
		const n = app.scene?.byId.get(id);
		return n ? { id: n.id, kind: kindName(n), name: n.name ?? '',
			translate: n.isOp ? null : n.translate.slice(),
			params: n.isOp ? null : n.params.slice() } : null;
	},
	pick: (x, y) => app.pick(x, y).then((r) => r ? { node: r.node,
		position: r.position, depth: r.depth } : null),
	/* Moves a primitive with one final EDIT; resolves with the ms from
	 * sending it to drawing the first frame that reflects it (the
	 * overlay's edit -> frame number, for the latency benchmark). */
	moveTo: (id, translate) => new Promise((resolve) => app.edit(id,
		[{ field: P.FIELD.TRANSLATE, values: translate }], false, resolve)),
	/* Turns the camera as a drag of (dx, dy) view pixels would, with one
	 * final CAMERA. */
	orbit: (dx, dy) => {
		app.camera.orbit(dx, dy);
		app.sendCamera(false);
	},
	/* Saves a w x h picture in tiles of tile (as the form does);
	 * resolves with its size and edit order. */
	picture: (w, h, tile) => app.savePicture(w, h, tile).then((r) => ({
		width: r.canvas.width, height: r.canvas.height,
		order: String(r.order) })),
	/* The Scene panel: the tree, its rows, its message line. */
	outliner: () => app.outliner.state(),
	/* SNAPSHOT of the view in encoding (2 PNG, 3 raw): resolves with
	 * { encoding, width, height, flags, data (the colour's bytes) }, or
	 * null when refused. */
	snapshot: (encoding) => app.snapshot(encoding).then((m) => m && {
		encoding: m.encoding, width: m.width, height: m.height,
		flags: m.flags, data: m.rects[0].data }),
	/* RGBA of the last picture's rectangle (x, y, w, h), as an array. */
	picturePixels: (x, y, w, h) => Array.from(app.lastPicture.canvas
		.getContext('2d').getImageData(x, y, w, h).data),
};
Object.assign(window.blobcast, app.review.api());
window.blobcast.history = () => app.history.state();
