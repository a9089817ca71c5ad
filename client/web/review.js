/*
 * What a reviewer needs around the picture, on the page's toolbar and
 * header:
 *  - camera reset (R): back to the session's camera (the one the scene
 *    carries, PROTOCOL.md 7.25), or bc_camera_default() without one; and
 *    set (Shift-R, editors): this view becomes the session's camera
 *    (SESSION_CAMERA);
 *  - zoom to fit (Home): the whole scene in view, from conservative boxes
 *    of the mirror's primitives (bounds.js);
 *  - downloads: a PNG of the view (the Picture panel's tiled snapshot at
 *    the view's size) and the scene as a JSON scene file (scenejson.js)
 *    or a binary one (protocol.js encodeSceneFile);
 *  - the session's solid as a mesh file (glb, OBJ, PLY or STL), made by
 *    the daemon (MESH, PROTOCOL.md 7.28) while the page goes on: the
 *    file `blobcast mesh --session` writes, byte for byte;
 *  - the frame encoding (JPEG, PNG, raw, H.264 video, or H.264 with an
 *    exact PNG still) and JPEG quality, sent as VIEW (7.14); H.264 is
 *    offered only where WebCodecs decodes it (video.js); an encoding the
 *    daemon refuses is marked and the control goes back;
 *  - load (editors): a scene file, JSON or binary, read by sceneload.js
 *    as `blobcast load` reads it, in a worker (sceneworker.js) so that
 *    the page stays live through a big file, and sent as SCENE_LOAD (in
 *    parts when it is bigger than one message), after the person
 *    confirms that it replaces the scene for everyone;
 *  - the token state in the header: editor, viewer, view only (a
 *    viewer-only token), with or without a token, refused, and the
 *    warnings that go with them;
 *  - the session list (sessions.js).
 * The page (app.js) calls saw(m) with every message before handling it
 * (true: an answer to this module's own requests), lost(why) when its
 * connection goes and update() on its overlay tick; everything else
 * starts from here.
 */
import * as P from './protocol.js';
import { DEFAULT_CAMERA, fitCamera, treeBox } from './bounds.js';
import { sceneJsonParts } from './scenejson.js';
import { readSceneFile, sceneParts } from './sceneload.js';
import { SessionPanel } from './sessions.js';

const $ = (id) => document.getElementById(id);

/* What the encoding control and the page's `enc` parameter choose: the
 * VIEW's encoding and its still_encoding (0: the still in the same). */
const FRAME_CHOICES = Object.freeze([
	{ name: 'jpeg', encoding: P.ENC.JPEG, still: 0 },
	{ name: 'png', encoding: P.ENC.PNG, still: 0 },
	{ name: 'raw', encoding: P.ENC.RAW, still: 0 },
	{ name: 'h264', encoding: P.ENC.H264, still: 0 },
	{ name: 'h264png', encoding: P.ENC.H264, still: P.ENC.PNG },
]);

/* { encoding, still } for an `enc` name, or undefined. */
export function frameChoice(name) {
	const c = FRAME_CHOICES.find((f) => f.name === name);
	return c ? { encoding: c.encoding, still: c.still } : undefined;
}

/* The choice's name, and its value in the control ("4+2": H.264 with a
 * PNG still). */
const choiceName = (encoding, still) => FRAME_CHOICES.find((f) =>
	f.encoding === encoding && f.still === still)?.name ?? 'jpeg';
const choiceValue = (encoding, still) => (still ? `${encoding}+${still}`
	: String(encoding));

/* The mesh file formats of the mesh control (PROTOCOL.md 7.28), by the
 * name its choices carry, which is also the file's extension. */
const MESH_FORMATS = Object.freeze([
	{ name: 'glb', format: P.MESH_FORMAT.GLB, type: 'model/gltf-binary' },
	{ name: 'obj', format: P.MESH_FORMAT.OBJ, type: 'model/obj' },
	{ name: 'ply', format: P.MESH_FORMAT.PLY,
		type: 'application/octet-stream' },
	{ name: 'stl', format: P.MESH_FORMAT.STL, type: 'model/stl' },
]);

const meshFormat = (format) => MESH_FORMATS.find((f) =>
	f.format === format);

/* What a mesh asked for, as the page says it: "glb, 128" or "obj, 48,
 * raw". */
const meshWhat = (ask) => `${meshFormat(ask.format).name}, ` +
	`${ask.resolution}${ask.options & P.MESH_OPTION.RAW ? ', raw' : ''}`;

/* The grid blobcastd meshes at most (BC_SRV_MESH_MAX_RESOLUTION; its
 * ELIMIT above), as index.html's field and its title say too. The
 * daemon does not announce it, and another may allow more, up to the
 * protocol's MAX_MESH_RESOLUTION: the page sends what is typed within
 * that and lets the daemon say no in its words. */
const DAEMON_MESH_RESOLUTION = 256;

/* Keys typed into a field keep their meaning there. */
function typing(e) {
	const t = e.target;
	return t && (t.isContentEditable || ['INPUT', 'TEXTAREA', 'SELECT']
		.includes(t.tagName));
}

/* A file's size for the page's messages ("21.7 MB": SI units). */
function sizeText(n) {
	if (n < 1000) {
		return `${n} bytes`;
	}
	return n < 1e6 ? `${(n / 1e3).toFixed(1)} kB`
		: `${(n / 1e6).toFixed(1)} MB`;
}

/* Reads a scene file (a File or Blob) as readSceneFile does, in a module
 * worker (sceneworker.js) that gets the file's bytes and hands the scene
 * bytes back, both transferred: a big JSON file takes seconds to read,
 * which on the page's thread would stop its frames, input and messages.
 * Calls started() once the worker has the bytes. Resolves with { bytes,
 * nodes }, or rejects with an Error carrying the reader's message (a
 * SceneFileError's, the same text). Resolves with null where no worker
 * did the work: none in this browser, or one that failed before
 * answering (its script not loaded, as from a page opened from a file:
 * URL); the bytes went to it, so the caller reads the file again on the
 * page. */
async function readInWorker(file, started) {
	const buf = await file.arrayBuffer();
	let w;
	try {
		w = new Worker(new URL('./sceneworker.js', import.meta.url),
			{ type: 'module' });
	} catch {
		return null;
	}
	return new Promise((resolve, reject) => {
		w.onmessage = (e) => {
			w.terminate();
			if (typeof e.data?.error === 'string') {
				reject(new Error(e.data.error));
			} else {
				resolve({ bytes: e.data.bytes, nodes: e.data.nodes });
			}
		};
		w.onerror = (e) => {
			/* Said nowhere: the page reads the file itself. */
			e.preventDefault();
			w.terminate();
			resolve(null);
		};
		w.onmessageerror = () => {
			w.terminate();
			resolve(null);
		};
		w.postMessage(buf, [buf]);
		started();
	});
}

/* Saves a Blob as a download named name. */
function download(blob, name) {
	const a = document.createElement('a');
	a.href = URL.createObjectURL(blob);
	a.download = name;
	a.click();
	setTimeout(() => URL.revokeObjectURL(a.href), 60000);
}

export class Review {
	constructor(app) {
		this.app = app;
		this.refused = new Set(); /* encodings the daemon refused */
		this.viewAsk = null; /* { seq, back: { encoding, quality } } */
		this.listedFor = null; /* the session the list was asked in */
		this.camAsk = 0; /* the SESSION_CAMERA on its way (its seq) */
		/* The load on its way: { name, nodes, seqs } (its parts' seqs;
		 * the last one's is the load's), or null. */
		this.loadAsk = null;
		/* The file being read before that: { name, reader } (reader:
		 * '' while its bytes are fetched, 'worker' once a worker reads
		 * them, 'page' where none could), or null; and the last read
		 * done: { name, reader, nodes (0: refused), ms }. */
		this.reading = null;
		this.lastRead = null;
		/* The mesh on its way: { seq, format, options, resolution }
		 * (the MESH's), or null; the last one saved: { name, format,
		 * resolution, raw, vertices, triangles, order, bytes }; the last
		 * one not made: { code (a name, or 'lost'), text }. */
		this.meshAsk = null;
		this.lastMesh = null;
		this.meshError = null;
		/* What the page said of the last mesh, kept in the button's
		 * title: the header's message is cut short and goes. */
		this.meshNote = '';
		/* This daemon refused MESH (ENOTSUP) though it granted it. */
		this.meshRefused = false;
		this.sessions = new SessionPanel({
			url: () => app.cfg.ws,
			token: () => app.cfg.token,
			name: () => app.cfg.name,
			canSend: () => !!app.welcome && app.conn.ws?.readyState ===
				WebSocket.OPEN,
			features: () => app.welcome?.features ?? 0,
			send: (type, fields) => app.conn.send(type, fields),
			socket: () => app.conn.ws,
			current: () => (app.info ? app.info.name : ''),
			join: (name) => this.join(name),
		});
		this.installToolbar();
		this.installKeys();
		this.update();
	}

	installToolbar() {
		$('resetbtn').addEventListener('click', () => this.resetCamera());
		$('setcambtn').addEventListener('click', () =>
			this.setSessionCamera());
		$('fitbtn').addEventListener('click', () => this.fit());
		$('pngbtn').addEventListener('click', () => this.savePng()
			.catch(() => {}));
		$('jsonbtn').addEventListener('click', () => this.saveJson());
		$('binbtn').addEventListener('click', () => this.saveBinary());
		$('meshbtn').dataset.title = $('meshbtn').title;
		$('meshbtn').addEventListener('click', () => this.saveMesh());
		$('loadbtn').addEventListener('click', () => $('loadfile').click());
		$('loadfile').addEventListener('change', () => {
			const file = $('loadfile').files[0];
			$('loadfile').value = '';
			if (file) {
				this.loadFile(file).catch((e) => this.app.say(
					`${file.name} not loaded: ${e.message}`));
			}
		});
		const enc = $('encoding');
		for (const o of enc.options) {
			o.dataset.label = o.textContent;
		}
		$('quality').value = String(this.app.cfg.quality);
		enc.addEventListener('change', () => {
			const [e, still = 0] = enc.value.split('+').map(Number);
			this.setView(e, this.app.cfg.quality, still);
		});
		$('quality').addEventListener('change', () => {
			const q = Math.round(Number($('quality').value));
			if (!(q >= 1 && q <= P.LIMITS.MAX_QUALITY)) {
				this.app.say(`JPEG quality: a whole number from 1 to ` +
					`${P.LIMITS.MAX_QUALITY}`);
				$('quality').value = String(this.app.cfg.quality);
				return;
			}
			this.setView(this.app.cfg.encoding, q);
		});
		this.renderView();
	}

	installKeys() {
		document.addEventListener('keydown', (e) => {
			if (e.ctrlKey || e.metaKey || e.altKey || typing(e)) {
				return;
			}
			if (e.key === 'Home') {
				e.preventDefault();
				this.fit();
			} else if (e.key.toLowerCase() === 'r') {
				e.preventDefault();
				if (e.shiftKey) {
					this.setSessionCamera();
				} else {
					this.resetCamera();
				}
			}
		});
	}

	/* ---- camera ---- */

	/* The session's camera, as the scene carries it, or the default. */
	sessionCamera() {
		return this.app.scene?.camera ?? DEFAULT_CAMERA;
	}

	resetCamera() {
		if (!this.app.info) {
			return;
		}
		this.app.camera.set(this.sessionCamera());
		this.app.sendCamera(false);
	}

	/* This view becomes the session's camera (SESSION_CAMERA, 7.25): the
	 * one joiners start from, reset comes back to and the scene is saved
	 * with. The daemon's SESSION_CAMERA_SET tells every member (the page
	 * says who set it); a refusal is said here. */
	setSessionCamera() {
		const app = this.app;
		if (!app.info) {
			return;
		}
		if (app.info.role !== P.ROLE.EDITOR) {
			app.say('setting the session\'s camera needs the editor role');
			return;
		}
		this.camAsk = app.conn.send(P.MSG.SESSION_CAMERA,
			app.camera.msg());
	}

	/* Reads and checks a scene file as readSceneFile does, in a worker
	 * where one can, else here; keeps this.reading while it does. Returns
	 * { bytes, nodes }; throws the reader's error. */
	async readScene(file) {
		const read = { name: file.name, reader: '' };
		const start = performance.now();
		this.reading = read;
		let scene = null;
		try {
			scene = await readInWorker(file, () => {
				read.reader = 'worker';
			});
			if (!scene) {
				read.reader = 'page';
				scene = readSceneFile(new Uint8Array(await file
					.arrayBuffer()));
			}
			return scene;
		} finally {
			this.reading = null;
			this.lastRead = { ...read, nodes: scene?.nodes ?? 0,
				ms: Math.round(performance.now() - start) };
		}
	}

	/* Loads a scene file (a File or Blob with a name) into the session:
	 * read and checked first (a file the CLI would refuse is refused with
	 * its reason, and nothing is sent), in a worker so that the page
	 * stays live meanwhile, then confirmed, then sent as SCENE_LOAD, in
	 * parts when it passes the daemon's max_payload (a daemon that did
	 * not grant PARTS refuses it here, as the library does). The daemon's
	 * SCENE_STATE or ERROR says what became of it. */
	async loadFile(file) {
		const app = this.app;
		if (!app.info) {
			return;
		}
		if (app.info.role !== P.ROLE.EDITOR) {
			app.say('loading a scene needs the editor role');
			return;
		}
		if (this.reading) {
			app.say(`${this.reading.name} is still being read; load ` +
				'another once it is');
			return;
		}
		if (this.loadAsk) {
			app.say(`${this.loadAsk.name} is still being loaded`);
			return;
		}
		app.say(`reading ${file.name} (${sizeText(file.size)})...`);
		let scene;
		try {
			scene = await this.readScene(file);
		} catch (e) {
			app.say(`${file.name} not loaded: ${e.message}`);
			return;
		}
		if (!app.info) {
			/* The connection went while the file was read. */
			app.say(`${file.name} not loaded: the connection is gone`);
			return;
		}
		const w = app.welcome;
		/* A part's payload: the scene piece behind its u32 length. */
		const parts = sceneParts(scene.bytes, (w?.max_payload ?? 0) - 4);
		if (parts.length > 1 && !(w.features & P.FEATURE.PARTS)) {
			app.say(`${file.name} not loaded: ${scene.bytes.length} bytes ` +
				'need several messages, and this daemon does not take a ' +
				'scene in parts');
			return;
		}
		if (!window.confirm(`Load ${file.name} (${scene.nodes} nodes) into ` +
			`session ${app.info.name}? It replaces the scene for every ` +
			'member, and the undo history starts again.')) {
			app.say(`${file.name}: not loaded`);
			return;
		}
		const seqs = [];
		for (const part of parts) {
			const seq = app.conn.send(P.MSG.SCENE_LOAD, { scene: part.scene },
				part.flags);
			if (!seq) {
				app.say(`${file.name} not loaded: the connection is gone`);
				return;
			}
			seqs.push(seq);
		}
		this.loadAsk = { name: file.name, nodes: scene.nodes, seqs };
		app.say(`loading ${file.name} (${scene.nodes} nodes)...`);
	}

	/* The scene's box, or null (no scene, or nothing to show). */
	box() {
		return this.app.scene ? treeBox(this.app.scene.root) : null;
	}

	fit() {
		const box = this.box();
		const v = this.app.view;
		if (!this.app.info || !v) {
			return;
		}
		if (!box) {
			this.app.say('zoom to fit: the scene has no shape to frame');
			return;
		}
		this.app.camera.set(fitCamera(this.app.camera.msg(), box,
			v.width / v.height));
		this.app.sendCamera(false);
	}

	/* ---- downloads ---- */

	/* blobcast-SESSION-ORDER.EXT, of the page's edit order or the one
	 * given (what a mesh is of). */
	fileName(ext, order = this.app.order) {
		return `blobcast-${this.app.cfg.session}-${order}.${ext}`;
	}

	/* A PNG of this view's size, through the Picture panel's tiles. */
	savePng() {
		const v = this.app.view;
		if (!v) {
			return Promise.reject(new Error('no view yet'));
		}
		return this.app.savePicture(v.width, v.height).catch((e) => {
			this.app.say(`PNG not saved: ${e.message}`);
			throw e;
		});
	}

	/* The scene file text of the mirror (throws saying why not). */
	sceneJson() {
		const s = this.app.scene;
		if (!s) {
			throw new Error('no scene yet');
		}
		return sceneJsonParts({ camera: s.camera, root: s.root });
	}

	saveJson() {
		let parts;
		try {
			parts = this.sceneJson();
		} catch (e) {
			this.app.say(`JSON not saved: ${e.message}`);
			return;
		}
		download(new Blob(parts, { type: 'application/json' }),
			this.fileName('json'));
	}

	/* The mirror as a binary scene file (`blobcast scene --binary`). */
	saveBinary() {
		const s = this.app.scene;
		let bytes;
		try {
			if (!s) {
				throw new Error('no scene yet');
			}
			bytes = P.encodeSceneFile({ camera: s.camera, root: s.root });
		} catch (e) {
			this.app.say(`binary scene not saved: ${e.message}`);
			return;
		}
		download(new Blob([bytes], { type: 'application/octet-stream' }),
			this.fileName('bin'));
	}

	/* Asks the daemon for a mesh of the session's solid in the format,
	 * resolution and raw option of the mesh control (MESH, PROTOCOL.md
	 * 7.28); any role may. Meshing takes the daemon seconds for a big
	 * scene: the page goes on meanwhile, and its MESH_DATA, which may
	 * come after the answers to later requests, is matched by its seq
	 * (saw). One at a time, as the daemon takes one per client. */
	saveMesh() {
		const app = this.app;
		if (!app.info) {
			return;
		}
		if (!this.meshGranted()) {
			app.say(this.meshOff());
			return;
		}
		if (this.meshAsk) {
			app.say(`the mesh (${meshWhat(this.meshAsk)}) is still being ` +
				'made on the daemon: one at a time');
			return;
		}
		const L = P.LIMITS;
		const typed = $('meshres').value.trim();
		const resolution = typed === '' ? L.MESH_DEFAULT_RESOLUTION
			: Number(typed);
		if (!Number.isInteger(resolution) ||
			resolution < L.MIN_MESH_RESOLUTION ||
			resolution > L.MAX_MESH_RESOLUTION) {
			app.say(`mesh resolution: a whole number of cells from ` +
				`${L.MIN_MESH_RESOLUTION} to ${DAEMON_MESH_RESOLUTION} ` +
				`(finer meshes: blobcast mesh on a machine)`);
			return;
		}
		$('meshres').value = String(resolution);
		const f = MESH_FORMATS.find((x) => x.name === $('meshformat')
			.value) ?? MESH_FORMATS[0];
		const ask = { seq: 0, format: f.format, resolution,
			options: $('meshraw').checked ? P.MESH_OPTION.RAW : 0 };
		ask.seq = app.conn.send(P.MSG.MESH, { format: ask.format,
			options: ask.options, resolution: ask.resolution });
		if (!ask.seq) {
			app.say('mesh not asked for: the connection is gone');
			return;
		}
		this.meshAsk = ask;
		app.say(`meshing on the daemon (${meshWhat(ask)})...`);
		this.update();
	}

	/* The daemon's answer m (MESH_DATA) to the mesh on its way: saved
	 * as blobcast-SESSION-ORDER.EXT, with the order the mesh is of. */
	meshDone(m) {
		this.meshAsk = null;
		const f = meshFormat(m.format);
		const name = this.fileName(f.name, m.order);
		download(new Blob([m.file], { type: f.type }), name);
		this.lastMesh = { name, format: f.name, resolution: m.resolution,
			raw: !!(m.options & P.MESH_OPTION.RAW), vertices: m.vertices,
			triangles: m.triangles, order: String(m.order),
			bytes: m.file.length };
		this.meshError = null;
		this.meshSay(`saved ${name}: ${m.triangles} triangles, edit order ` +
			`${m.order} (${sizeText(m.file.length)})`);
		this.update();
	}

	/* The daemon's ERROR m for the mesh on its way: its words say what
	 * to do (a lower resolution, later, another format). */
	meshRefusal(m) {
		const ask = this.meshAsk;
		this.meshAsk = null;
		if (m.code === P.ERR.ENOTSUP) {
			this.meshRefused = true;
		}
		this.meshError = { code: P.errName(m.code), text: m.text };
		this.meshSay(`mesh (${meshWhat(ask)}) not made: ${m.text} ` +
			`(${P.errName(m.code)})`);
		this.update();
	}

	/* The page's connection went (why): a mesh on its way will never
	 * come to the next one, so it is forgotten, saying so. */
	lost(why) {
		const ask = this.meshAsk;
		this.meshRefused = false;
		if (!ask) {
			return;
		}
		this.meshAsk = null;
		this.meshError = { code: 'lost', text: why };
		this.meshSay(`mesh (${meshWhat(ask)}) not made: the connection ` +
			`was lost (${why}); ask again once the page is back`);
	}

	/* Says text of the last mesh, and keeps it for the button. */
	meshSay(text) {
		this.meshNote = text;
		this.app.say(text);
	}

	/* Whether this daemon makes meshes for the page (it granted MESH,
	 * PROTOCOL.md 4.1, and has not refused one). */
	meshGranted() {
		return !!((this.app.welcome?.features ?? 0) & P.FEATURE.MESH) &&
			!this.meshRefused;
	}

	/* Why the mesh control is off, for its title and a message. */
	meshOff() {
		return 'this daemon does not make meshes (it did not grant MESH: ' +
			'an earlier blobcastd): make one on a machine with blobcast ' +
			'mesh --session';
	}

	/* ---- frames ---- */

	/* Asks for frames in encoding at quality (VIEW); the daemon's refusal
	 * puts the control back. Also kept in the address bar. */
	setView(encoding, quality, still = 0) {
		const cfg = this.app.cfg;
		const back = { encoding: cfg.encoding, quality: cfg.quality,
			still: cfg.still };
		cfg.encoding = encoding;
		cfg.quality = quality;
		cfg.still = still;
		if (encoding === P.ENC.H264) {
			this.videoError = ''; /* a new decoder tries again */
		}
		const q = new URLSearchParams(location.search);
		q.set('enc', choiceName(encoding, still));
		q.set('quality', String(quality));
		history.replaceState(null, '', `${location.pathname}?${q}` +
			location.hash);
		if (this.app.info) {
			/* resize(true) sends the VIEW from a zero timer: its seq is
			 * known after that one runs. */
			const ask = { seq: 0, back };
			this.viewAsk = ask;
			this.app.resize(true);
			setTimeout(() => {
				ask.seq = this.app.viewSeq;
			}, 0);
		}
		this.renderView();
	}

	renderView() {
		const cfg = this.app.cfg;
		const enc = $('encoding');
		for (const o of enc.options) {
			const e = Number(o.value.split('+')[0]);
			/* Only what the page announces in HELLO: H.264 where
			 * WebCodecs decodes it (not known yet: not offered). */
			const video = e === P.ENC.H264;
			const unsupported = video ? !this.app.videoOk
				: !(P.ENCODINGS_IMAGES & (1 << (e - 1)));
			o.disabled = unsupported || this.refused.has(e);
			o.textContent = o.dataset.label + (this.refused.has(e)
				? ' (refused)' : video && unsupported &&
				this.app.videoOk === false ? ' (not in this browser)'
				: video && this.videoError ? ' (failed)' : '');
			o.title = video && this.videoError
				? `decoding failed: ${this.videoError}` : '';
		}
		enc.value = choiceValue(cfg.encoding, cfg.still);
		$('quality').value = String(cfg.quality);
		$('quality').disabled = cfg.encoding !== P.ENC.JPEG;
	}

	/* The daemon refused a VIEW ({ encoding }) with ERROR m: an encoding
	 * it does not take (EINVAL: not announced; ENOTSUP: H.264 from a
	 * daemon without an encoder) is marked and no longer offered. */
	refuse(view, m) {
		if (m.code === P.ERR.EINVAL || (m.code === P.ERR.ENOTSUP &&
			view.encoding === P.ENC.H264)) {
			this.refused.add(view.encoding);
		}
		this.renderView();
	}

	/* The page's H.264 decoder failed (text: why): the control says so;
	 * choosing H.264 again tries a new decoder. */
	videoFailed(text) {
		this.videoError = text;
		this.renderView();
	}

	/* ---- messages the page receives ---- */

	/* Sees every message before the page; returns whether it was an
	 * answer to this module's requests, which it has dealt with (the
	 * page then skips it). */
	saw(m) {
		const app = this.app;
		if (this.sessions.handle(m)) {
			return true;
		}
		if (m.type === P.MSG.SESSION_INFO || m.type === P.MSG.ERROR) {
			/* The header follows a join or a refusal at once, once the
			 * page has taken the message (not at the next tick). */
			setTimeout(() => this.update(), 0);
		}
		if (m.type === P.MSG.SESSION_CAMERA_SET &&
				m.author === app.info?.member_id &&
				m.author_seq === this.camAsk) {
			this.camAsk = 0;
		}
		if (m.type === P.MSG.SESSION_CAMERA_SET && app.scene) {
			/* The mirror keeps the session's camera (7.25): reset goes
			 * there. */
			app.scene.camera = { eye: m.eye.slice(), target: m.target
				.slice(), up: m.up.slice(), fov_y_deg: m.fov_y_deg };
		}
		const mesh = this.meshAsk;
		if (mesh && m.seq === mesh.seq && m.type === P.MSG.MESH_DATA) {
			this.meshDone(m);
			return true;
		}
		if (m.type === P.MSG.MESH_DATA) {
			/* The answer to a mesh the page gave up on: not for it. */
			return true;
		}
		const load = this.loadAsk;
		if (load && m.type === P.MSG.SCENE_STATE &&
				m.author === app.info?.member_id &&
				m.author_seq === load.seqs[load.seqs.length - 1]) {
			this.loadAsk = null;
			app.say(`loaded ${load.name}: ${load.nodes} nodes, edit order ` +
				`${m.order} (the undo history starts here)`);
		}
		if (m.type !== P.MSG.ERROR) {
			return false;
		}
		if (load && m.seq &&
				load.seqs.includes(m.seq)) {
			this.loadAsk = null;
			app.say(`${load.name} not loaded: ${m.text} ` +
				`(${P.errName(m.code)})`);
			return true;
		}
		if (mesh && m.seq && m.seq === mesh.seq) {
			this.meshRefusal(m);
			return true;
		}
		if (m.seq && m.seq === this.camAsk) {
			this.camAsk = 0;
			app.say(`the session's camera was not set: ${m.text} ` +
				`(${P.errName(m.code)})`);
			return true;
		}
		const ask = this.viewAsk;
		if (ask && m.seq && m.seq === ask.seq) {
			/* The daemon keeps the VIEW it had: so does the control. */
			this.viewAsk = null;
			this.refuse(app.viewSent ?? app.cfg, m);
			app.say(`${choiceName(app.cfg.encoding, app.cfg.still)} ` +
				`frames refused by the daemon (${P.errName(m.code)}: ` +
				`${m.text})`);
			app.cfg.encoding = ask.back.encoding;
			app.cfg.quality = ask.back.quality;
			app.cfg.still = ask.back.still;
			this.renderView();
			/* Said here, in full; a refused VIEW gets no frame, so it
			 * is not pending (what the page does with such an ERROR). */
			app.viewSentAt = 0;
			return true;
		}
		if (m.code === P.ERR.ENOSESSION && m.seq === 0 && app.info) {
			/* Someone deleted this page's session. */
			this.sessions.setStatus(`this session was deleted (${m.text});` +
				' join or create another', true);
			this.sessions.refresh().catch(() => {});
		}
		return false;
	}

	/* ---- the header and the buttons, on the page's tick ---- */

	join(name) {
		const q = new URLSearchParams(location.search);
		q.set('session', name);
		history.replaceState(null, '', `${location.pathname}?${q}` +
			location.hash);
		this.app.switchSession(name);
	}

	/* { state, text, warn } for the header: how the page is connected
	 * and with what token. */
	tokenState() {
		const app = this.app;
		const token = !!app.cfg.token;
		const warns = [];
		if (app.tokenInQuery) {
			warns.push('a ?token= in the address is ignored (proxies log ' +
				'it): use #token= or the token… button');
		}
		let state, text;
		if (app.halted?.code === P.ERR.EAUTH) {
			state = 'refused';
			text = token ? 'token refused' : 'token needed';
			warns.unshift(token ? 'the daemon refused this token: enter ' +
				'another with the token… button' : 'the daemon wants a ' +
				'token: enter it with the token… button');
		} else if (!app.info) {
			state = 'connecting';
			text = token ? 'token set' : 'no token';
		} else if (app.info.role === P.ROLE.EDITOR) {
			state = 'editor';
			text = `editor · ${token ? 'token' : 'no token'}`;
		} else if (app.viewOnly) {
			state = 'view-only';
			text = 'view only · viewer token';
			warns.unshift('this token allows viewing only: edits, undo, ' +
				'creating and deleting sessions are refused');
		} else {
			state = 'viewer';
			text = `viewer · ${token ? 'token' : 'no token'}`;
		}
		return { state, text, warn: warns.join('; ') };
	}

	update() {
		const app = this.app;
		const t = this.tokenState();
		const el = $('tokenstate');
		const text = t.warn ? `${t.text} ⚠` : t.text;
		if (el.textContent !== text || el.dataset.state !== t.state) {
			el.textContent = text;
			el.dataset.state = t.state;
			el.classList.toggle('warn', !!t.warn);
		}
		$('tokenwarn').textContent = t.warn;
		$('tokenwarn').hidden = !t.warn;
		el.title = t.warn || 'how this page is connected';
		const joined = !!app.info;
		$('resetbtn').disabled = !joined;
		$('setcambtn').disabled = !joined ||
			app.info.role !== P.ROLE.EDITOR;
		$('loadbtn').disabled = !joined || app.info.role !== P.ROLE.EDITOR;
		$('fitbtn').disabled = !joined || !app.scene;
		$('jsonbtn').disabled = !app.scene;
		$('binbtn').disabled = !app.scene;
		$('pngbtn').disabled = $('picturebtn').disabled;
		this.renderMesh();
		const name = app.info?.name ?? null;
		if (name && name !== this.listedFor && !this.sessions.busy) {
			/* Each session joined: what else is there. */
			this.listedFor = name;
			this.sessions.refresh().catch(() => {});
		} else if (!name && app.halted?.code === P.ERR.ENOSESSION &&
			this.listedFor !== '') {
			/* Stopped on a missing session: show the ones there are. */
			this.listedFor = '';
			this.sessions.refresh().catch(() => {});
		}
		this.sessions.update();
	}

	/* The mesh control: any role, while joined to a daemon that makes
	 * meshes (else off, its title saying why); the button says when a
	 * mesh is on its way. */
	renderMesh() {
		const on = !!this.app.info && this.meshGranted();
		const ask = this.meshAsk;
		const b = $('meshbtn');
		const title = !this.app.info || on ? (ask ? `the daemon is ` +
			`making the mesh (${meshWhat(ask)}); one at a time`
			: b.dataset.title + (this.meshNote ? `\nlast: ${this.meshNote}`
				: '')) : this.meshOff();
		const label = ask ? 'meshing…' : 'save';
		if (b.title !== title || b.textContent !== label) {
			b.title = title;
			b.textContent = label;
		}
		b.disabled = !on;
		b.setAttribute('aria-busy', ask ? 'true' : 'false');
		for (const id of ['meshformat', 'meshres', 'meshraw']) {
			$(id).disabled = !on;
		}
	}

	/* { granted, pending, last, error } (api's mesh). */
	mesh() {
		const ask = this.meshAsk;
		const pending = ask ? { seq: ask.seq,
			format: meshFormat(ask.format).name,
			resolution: ask.resolution,
			raw: !!(ask.options & P.MESH_OPTION.RAW) } : null;
		return { granted: this.meshGranted(), pending,
			last: this.lastMesh ? { ...this.lastMesh } : null,
			error: this.meshError ? { ...this.meshError } : null };
	}

	/* { state, name, reader, last } (api's loading). */
	loading() {
		const now = this.reading ?? this.loadAsk;
		const state = this.reading ? 'reading' : this.loadAsk ? 'loading'
			: '';
		return { state, name: now?.name ?? '',
			reader: this.reading?.reader ?? '',
			last: this.lastRead ? { ...this.lastRead } : null };
	}

	/* For tests and the console (window.blobcast). */
	api() {
		return {
			sceneBox: () => this.box(),
			sceneJson: () => this.sceneJson().join(''),
			sessionCamera: () => this.sessionCamera(),
			cameraSeq: () => this.app.cameraSeq,
			tokenState: () => this.tokenState(),
			/* Encodings the daemon refused (EINVAL, or ENOTSUP for
			 * H.264). */
			refusedEncodings: () => [...this.refused],
			/* The scene file being loaded: state 'reading' (its bytes
			 * being read, by reader: 'worker' or 'page'; '' while they
			 * are fetched), 'loading' (sent, the daemon's answer
			 * awaited) or ''; last: the last read done. */
			loading: () => this.loading(),
			/* The mesh download: granted (the daemon makes meshes),
			 * pending (the MESH on its way: { seq, format, resolution,
			 * raw }, or null), last (the last one saved: { name,
			 * format, resolution, raw, vertices, triangles, order,
			 * bytes }) and error (the last one not made: { code, text
			 * }, code 'lost' when the connection went first). */
			mesh: () => this.mesh(),
			sessions: () => ({ status: this.sessions.status,
				busy: this.sessions.busy,
				names: this.sessions.entries?.map((e) => e.name) ?? null }),
		};
	}
}
