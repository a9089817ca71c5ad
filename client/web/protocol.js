/*
 * The blobcast wire protocol in JavaScript: message objects to bytes and
 * back, with no I/O, for the browser page and for node (tests, benchmark).
 * It is the JavaScript form of protocol/include/blobcast/proto.h and follows
 * the C codec rule for rule, so that both accept and refuse the same bytes
 * with the same error codes; protocol/vectors/*.json pins that down.
 *
 * Reading is a push parser: feed() bytes as they arrive, then next() until
 * it returns null. WebSocket frames from websockify do not line up with
 * protocol messages, so the reader reassembles them. Every length and count
 * is checked against the limits and against the bytes actually present
 * before anything is copied; the first error is sticky, because a stream
 * that went wrong once cannot be trusted to be in step again.
 *
 * Writing: encode(msg) writes a message and then runs the finished payload
 * through the decoder, so one definition of "valid" serves both directions
 * (the C encoder does the same).
 *
 * Message objects are plain objects { type, flags, seq, ...fields } whose
 * field names are those of proto.h and of the test vectors. u64 fields
 * (order, stamp, uptime_ms, frames, bytes) are BigInt; byte ranges (scene,
 * subtree, rect data) are Uint8Array copies that outlive the reader.
 */

/* ---- Constants (proto.h, proto_limits.h, base/include/blobcast/error.h) - */

export const HEADER_SIZE = 16;
export const VERSION = 1;
const MAGIC = [0x42, 0x43, 0x53, 0x54]; /* "BCST" */

/* Each limit with the reason for its value is in proto_limits.h; these are
 * the same numbers. */
export const LIMITS = Object.freeze({
	MAX_PAYLOAD: 64 * 1024 * 1024,
	MAX_SCENE_BYTES: 1024 * 1024 * 1024, /* a scene in parts, 7.10.1 */
	HELLO_MAX_PAYLOAD: 4096,
	READ_SLACK: 1024 * 1024,
	MAX_NAME: 64,
	MAX_TOKEN: 1024,
	MAX_ERROR_TEXT: 1024,
	MAX_MEMBERS: 64,
	MAX_SESSIONS_LISTED: 1024,
	MAX_HISTORY: 200,
	MAX_HISTORY_TEXT: 128,
	MAX_MESH_RESOLUTION: 4096, /* MESH's grid; 0 asks for the default */
	MIN_MESH_RESOLUTION: 5,
	MESH_DEFAULT_RESOLUTION: 128,
	MAX_DIM: 8192,
	MIN_FRAME_BYTES: 64 * 1024,
	MAX_RECTS: 4096,
	MAX_DOWNSCALE: 8,
	MAX_QUALITY: 100,
	MAX_VIDEO_DIM: 4096,   /* an H.264 view's width and height */
	MAX_VIDEO_MBS: 36864,  /* an H.264 view's 16x16 macroblocks, sides even */
	MAX_EDIT_OPS: 1024,
	MAX_SET_FIELDS: 14,
	MAX_FIELD_VALUES: 4,
	MAX_PRIM_PARAMS: 8,
	MAX_ABS: 1.0e6,
	SCENE_MAX_NODES: (1 << 22) - 1,
	SCENE_MAX_DEPTH: 1 << 20,
	OP_KIND_MAX: 14,
	OP_KIND_FIRST_UNARY: 7,
	MAX_UNARY_PARAMS: 6,
	PRIM_KIND_MAX: 32,
});
const L = LIMITS;

export const MSG = Object.freeze({
	HELLO: 1, WELCOME: 2, ERROR: 3, PING: 4, PONG: 5, OK: 6,
	SESSION_CREATE: 7, SESSION_JOIN: 8, SESSION_LEAVE: 9,
	SESSION_INFO: 10, SCENE_LOAD: 11, SCENE_STATE: 12, EDIT: 13,
	EDIT_APPLIED: 14, CAMERA: 15, VIEW: 16, FRAME: 17, PICK: 18,
	PICK_RESULT: 19, SNAPSHOT: 20, GET_STATS: 21, STATS: 22,
	SESSION_DELETE: 23, UNDO: 24, REDO: 25, SESSION_LIST: 26, SESSIONS: 27,
	PRESENT: 28, FOLLOW: 29, PRESENTER: 30, FOLLOW_CAMERA: 31,
	SESSION_CAMERA: 32, SESSION_CAMERA_SET: 33, HISTORY_GET: 34,
	HISTORY: 35, FRAME_ACK: 36, MESH: 37, MESH_DATA: 38,
});

/* Header flag bits; each is defined for some types only. */
export const FLAG = Object.freeze({
	FATAL: 0x0001,       /* ERROR */
	INTERACTING: 0x0001, /* CAMERA, EDIT, EDIT_APPLIED */
	UNDO: 0x0002,        /* EDIT_APPLIED: undoes target_order */
	REDO: 0x0004,        /* EDIT_APPLIED: redoes target_order */
	STILL: 0x0001,       /* FRAME */
	SNAPSHOT: 0x0002,    /* FRAME */
	INCOMPLETE: 0x0004,  /* FRAME: refinement stopped by the time budget */
	LEVEL_MASK: 0x0018,  /* FRAME: the refinement level, bits 3..4 */
	DEPTH: 0x0020,       /* FRAME, with SNAPSHOT only: a depth plane */
	IDS: 0x0040,         /* FRAME, with SNAPSHOT only: an id plane */
	KEY: 0x0080,         /* FRAME of encoding 4 only: an IDR, a start */
	MORE: 0x0001,        /* SCENE_LOAD, SCENE_STATE: another part follows */
	CONT: 0x0002,        /* SCENE_LOAD, SCENE_STATE: continues a scene */
});

/* SNAPSHOT's optional planes byte: the planes the answering FRAME carries
 * after its colour rectangle, each covering the image at 4 bytes a pixel:
 * depth as little-endian f32 (+inf on a miss), then ids as little-endian
 * u32 (0 on a miss). Other bits are EPROTO_FLAGS; 0 or absent is colour
 * only. */
export const PLANE = Object.freeze({ DEPTH: 0x01, IDS: 0x02, ALL: 0x03 });

/* GET_STATS parts: the daemon's load section, a reset of its maxima, the
 * TLS section (the certificate's end of validity), the link section and
 * the memory section (scene nodes held and their cap; asked only of a
 * server that granted FEATURE.MEMORY). */
export const STATS_PARTS = Object.freeze({ LOAD: 0x01, RESET: 0x02, TLS: 0x04,
	LINK: 0x08, MEMORY: 0x10, ALL: 0x1f });

/* Features (PROTOCOL.md 4): what version 1 gained after its first text; a
 * server sends each only to a client that announced it in HELLO, and
 * WELCOME says which it grants. */
export const FEATURE = Object.freeze({ LEVELS: 0x01, UNDO: 0x02,
	PRESENT: 0x04, KINDS: 0x08, TILES: 0x10, HISTORY: 0x20, NAMES: 0x40,
	ACKS: 0x80, PARTS: 0x100, MEMORY: 0x200, MESH: 0x400, ALL: 0x7ff });

/* MESH's file formats and options (PROTOCOL.md 7.28): RAW keeps every
 * triangle (no edge collapse). */
export const MESH_FORMAT = Object.freeze({ OBJ: 1, PLY: 2, STL: 3, GLB: 4 });
export const MESH_OPTION = Object.freeze({ RAW: 0x01, ALL: 0x01 });

/* FRAMEs of the view a client granted ACKS may leave unacknowledged
 * (PROTOCOL.md 7.27). */
export const ACK_WINDOW = 2;

/* UNDO and REDO's optional scope byte (PROTOCOL.md 7.20), only for a
 * client granted HISTORY: its own newest change, or the session's (the
 * owner or presenter). Without the byte a client granted HISTORY undoes
 * its own. */
export const UNDO_SCOPE = Object.freeze({ MINE: 1, SESSION: 2 });
/* HISTORY entries (PROTOCOL.md 7.26): state and flags. */
export const HISTORY_STATE = Object.freeze({ APPLIED: 1, UNDONE: 2 });
export const HISTORY_FLAG = Object.freeze({ YOURS: 0x01, NEXT: 0x02,
	ALL: 0x03 });

/* The number of plane rectangles (0..2) a FRAME with these flags carries
 * after its colour rectangle. */
export function framePlanes(flags) {
	return ((flags & FLAG.DEPTH) ? 1 : 0) + ((flags & FLAG.IDS) ? 1 : 0);
}
/* FRAME's refinement level n (0..MAX_LEVEL) is flags bits 3..4. A level
 * n > 0 frame is one whole picture with one ray per 2^n x 2^n block of the
 * view: its image is exactly ceil(width / 2^n) x ceil(height / 2^n) in one
 * rectangle, image pixel (i, j) being the view's pixel (2^n i, 2^n j); it
 * is never STILL or SNAPSHOT. Level 0 is a full-resolution frame. */
export const LEVEL_SHIFT = 3;
export const MAX_LEVEL = 3;

/* The refinement level of a FRAME's flags. */
export function frameLevel(flags) {
	return (flags & FLAG.LEVEL_MASK) >> LEVEL_SHIFT;
}

/* flags with its level field set to level (0..MAX_LEVEL). */
export function flagsWithLevel(flags, level) {
	return (flags & ~FLAG.LEVEL_MASK) |
		((level << LEVEL_SHIFT) & FLAG.LEVEL_MASK);
}

/* ceil(dim / 2^level): a level frame's image size for a view size. */
export function levelDim(dim, level) {
	return (dim + (1 << level) - 1) >> level;
}

/* Whether a FRAME leaves the picture still refining: a level above 0, or
 * INCOMPLETE (the time budget stopped refinement); more frames follow. */
export function frameRefining(flags) {
	return frameLevel(flags) > 0 || (flags & FLAG.INCOMPLETE) !== 0;
}

/* View pixels per image pixel of a decoded FRAME, [sx, sy]: 2^n at level
 * n > 0, where image pixel (i, j) stands for the view's 2^n block at
 * (2^n i, 2^n j) (the last column or row may reach past the view); at
 * level 0 the image stretched over the view. */
export function frameScale(m) {
	const level = frameLevel(m.flags);
	if (level > 0) {
		return [1 << level, 1 << level];
	}
	return [m.width / m.image_width, m.height / m.image_height];
}

export const ROLE = Object.freeze({ EDITOR: 1, VIEWER: 2 });
export const ENC = Object.freeze({ JPEG: 1, PNG: 2, RAW: 3, H264: 4 });
/* HELLO.encodings: bit (encoding - 1) set = the client decodes it. */
export const ENCODINGS_ALL = 0x0f;
/* The image encodings (JPEG, PNG, raw), which every server takes in HELLO
 * (a server of a text before H.264 refuses bit 3, PROTOCOL.md 7.1). */
export const ENCODINGS_IMAGES = 0x07;
export const EDIT = Object.freeze({ SET: 1, INSERT: 2, REMOVE: 3, REPLACE: 4,
	NAME: 5 });
export const FIELD = Object.freeze({
	TRANSLATE: 1, ROTATE: 2, COLOR: 3, PARAM0: 16,
	BLEND: 32, RANGE: 33, OP_KIND: 34,
});

/* The project's error list: the same numbers travel in ERROR messages. */
const ERRORS = [
	/* NONE, not OK: message type 6 is OK, and one module exports both. */
	['NONE', 'no error (success)'],
	['EINVAL', 'invalid argument'],
	['ENOMEM', 'out of memory'],
	['ERANGE', 'value out of range'],
	['ELIMIT', 'a named limit was exceeded'],
	['EIO', 'input/output error'],
	['EPARSE', 'malformed input'],
	['ENOTFOUND', 'no such object'],
	['EEXIST', 'object already exists'],
	['ENOTSUP', 'operation not supported'],
	['ESTATE', 'operation not allowed in this state'],
	['EAGAIN', 'more input needed'],
	['EPROTO_MAGIC', 'bad protocol magic'],
	['EPROTO_VERSION', 'unsupported protocol version'],
	['EPROTO_TYPE', 'unknown message type'],
	['EPROTO_LENGTH', 'payload length invalid or over the limit'],
	['EPROTO_TRUNCATED', 'message body shorter than its fields'],
	['EPROTO_TRAILING', "bytes left after the message's fields"],
	['EPROTO_COUNT', 'a count exceeds its limit or the bytes left'],
	['EPROTO_FLAGS', 'reserved flag bits set'],
	['ENONFINITE', 'NaN or infinite number where a finite one is required'],
	['EDEPTH', 'nesting deeper than the limit'],
	['EAUTH', 'authentication failed'],
	['EPERM', 'not permitted for this role'],
	['ENOSESSION', 'no such session'],
	['ENONODE', 'no node with that id'],
	['EDUPID', 'duplicate node id'],
	['EBUSY', 'resource busy, try again'],
	['ETIMEOUT', 'timed out'],
	['EGL', 'graphics driver error'],
	['ECODEC', 'image encoding or decoding failed'],
	['ESTRING', 'string not valid UTF-8 or contains NUL'],
	['EENUM', 'enumeration value out of range'],
	['ECLOSED', 'connection closed'],
];

/* ERR.ENOMEM === 2: magnitudes, as ERROR.code carries them. */
export const ERR = Object.freeze(
	Object.fromEntries(ERRORS.map(([name], i) => [name, i])));

/* "ENOMEM" for 2 (or -2); "UNKNOWN" for codes not in the list. */
export function errName(code) {
	const e = ERRORS[Math.abs(code)];
	return e ? e[0] : 'UNKNOWN';
}

/* The human sentence of an error code. */
export function errText(code) {
	const e = ERRORS[Math.abs(code)];
	return e ? e[1] : 'unknown error';
}

/* Assembles a SCENE_STATE that a server sends in parts (header flags MORE
 * and CONT, PROTOCOL.md 7.10.1) to a client granted FEATURE.PARTS. add(m)
 * takes every decoded message in order and returns it, or null while a
 * scene's parts are still coming; the last part comes back as one
 * SCENE_STATE holding the whole scene, without the part flags. Parts out
 * of their order throw EPROTO_FLAGS, a scene past MAX_SCENE_BYTES
 * EPROTO_LENGTH (the server broke the protocol: the caller closes). */
export class SceneParts {
	constructor(max = L.MAX_SCENE_BYTES) {
		this.max = max;
		this.pieces = null; /* the parts so far, while a scene is open */
		this.length = 0;
		this.first = null;
	}

	add(m) {
		const part = m.type === MSG.SCENE_STATE &&
			(m.flags & (FLAG.MORE | FLAG.CONT)) !== 0;
		if (!part) {
			if (this.pieces) {
				this.fail('EPROTO_FLAGS', `a ${typeName(m.type)} ` +
					'came between the parts of a scene');
			}
			return m;
		}
		if (m.flags & FLAG.CONT) {
			const f = this.first;
			if (!this.pieces || f.order !== m.order ||
			    f.author !== m.author || f.author_seq !== m.author_seq) {
				this.fail('EPROTO_FLAGS', 'a SCENE_STATE part (CONT) ' +
					'that continues no scene begun');
			}
		} else if (this.pieces) {
			this.fail('EPROTO_FLAGS', 'a SCENE_STATE part began a ' +
				'scene before the last one ended');
		} else {
			this.pieces = [];
			this.length = 0;
			this.first = m;
		}
		if (m.scene.length > this.max - this.length) {
			this.fail('EPROTO_LENGTH', 'a scene in parts of more ' +
				`than ${this.max} bytes`);
		}
		/* The reader's bytes are reused: keep a copy. */
		this.pieces.push(m.scene.slice());
		this.length += m.scene.length;
		if (m.flags & FLAG.MORE) {
			return null;
		}
		const scene = new Uint8Array(this.length);
		let at = 0;
		for (const p of this.pieces) {
			scene.set(p, at);
			at += p.length;
		}
		this.pieces = null;
		this.first = null;
		return { ...m, flags: m.flags & ~(FLAG.MORE | FLAG.CONT), scene };
	}

	fail(code, text) {
		this.pieces = null;
		this.first = null;
		throw new ProtoError(code, text);
	}
}

/* Every failure of this module: code is the symbolic name ("EPROTO_MAGIC"),
 * errno its number. */
export class ProtoError extends Error {
	constructor(code, message) {
		super(message);
		this.name = 'ProtoError';
		this.code = code;
		this.errno = ERR[code] ?? 0;
	}
}

/* ---- The type table ------------------------------------------------------ */

const FROM_CLIENT = 1, FROM_SERVER = 2, FROM_BOTH = 3;
const strMax = (n) => 2 + n;
const BULK = L.MAX_PAYLOAD;
/* A camera: eye, target, up (3 f32 each) and fov_y_deg. */
const CAMERA_SIZE = 40;

/* name, who sends it, the flag bits it defines, its largest valid payload
 * (so a header announcing more is refused before its payload arrives). */
const TYPES = [];
function T(type, name, from, flags, max) {
	TYPES[type] = Object.freeze({ type, name, from, flags, max });
}
T(1, 'HELLO', FROM_CLIENT, 0,
	2 + 2 + 1 + 4 + strMax(L.MAX_NAME) + strMax(L.MAX_TOKEN) + 4);
T(2, 'WELCOME', FROM_SERVER, 0,
	2 + 4 * 4 + 2 * 3 + strMax(L.MAX_NAME) + 4);
T(3, 'ERROR', FROM_BOTH, FLAG.FATAL, 2 + strMax(L.MAX_ERROR_TEXT));
T(4, 'PING', FROM_BOTH, 0, 8);
T(5, 'PONG', FROM_BOTH, 0, 8);
T(6, 'OK', FROM_SERVER, 0, 0);
T(7, 'SESSION_CREATE', FROM_CLIENT, 0, 1 + strMax(L.MAX_NAME));
T(8, 'SESSION_JOIN', FROM_CLIENT, 0, 1 + strMax(L.MAX_NAME));
T(9, 'SESSION_LEAVE', FROM_CLIENT, 0, 0);
T(10, 'SESSION_INFO', FROM_SERVER, 0, 4 + 4 + 1 + strMax(L.MAX_NAME) + 2 +
	L.MAX_MEMBERS * (4 + 1 + strMax(L.MAX_NAME)));
T(11, 'SCENE_LOAD', FROM_CLIENT, FLAG.MORE | FLAG.CONT, BULK);
T(12, 'SCENE_STATE', FROM_SERVER, FLAG.MORE | FLAG.CONT, BULK);
T(13, 'EDIT', FROM_CLIENT, FLAG.INTERACTING, BULK);
T(14, 'EDIT_APPLIED', FROM_SERVER, FLAG.INTERACTING | FLAG.UNDO | FLAG.REDO,
	BULK);
T(15, 'CAMERA', FROM_CLIENT, FLAG.INTERACTING, CAMERA_SIZE);
T(16, 'VIEW', FROM_CLIENT, 0, 9);
T(17, 'FRAME', FROM_SERVER, FLAG.STILL | FLAG.SNAPSHOT | FLAG.INCOMPLETE |
	FLAG.LEVEL_MASK | FLAG.DEPTH | FLAG.IDS | FLAG.KEY,
  BULK);
T(18, 'PICK', FROM_CLIENT, 0, 4);
T(19, 'PICK_RESULT', FROM_SERVER, 0, 24);
T(20, 'SNAPSHOT', FROM_CLIENT, 0, 14);
T(21, 'GET_STATS', FROM_CLIENT, 0, 1);
/* + load, TLS, link, memory */
T(22, 'STATS', FROM_SERVER, 0, 64 + 44 + 9 + 32 + 28);
T(23, 'SESSION_DELETE', FROM_CLIENT, 0, strMax(L.MAX_NAME));
T(24, 'UNDO', FROM_CLIENT, 0, 1);
T(25, 'REDO', FROM_CLIENT, 0, 1);
T(26, 'SESSION_LIST', FROM_CLIENT, 0, 0);
T(27, 'SESSIONS', FROM_SERVER, 0, 2 + L.MAX_SESSIONS_LISTED *
	(strMax(L.MAX_NAME) + 2 + 4 + 8 + 8 + 1));

T(28, 'PRESENT', FROM_CLIENT, 0, 1);
T(29, 'FOLLOW', FROM_CLIENT, 0, 1);
T(30, 'PRESENTER', FROM_SERVER, 0, 5);
T(31, 'FOLLOW_CAMERA', FROM_SERVER, FLAG.INTERACTING, 4 + CAMERA_SIZE);
T(32, 'SESSION_CAMERA', FROM_CLIENT, 0, CAMERA_SIZE);
T(33, 'SESSION_CAMERA_SET', FROM_SERVER, 0, 8 + 4 + 4 + CAMERA_SIZE);
T(34, 'HISTORY_GET', FROM_CLIENT, 0, 0);
T(35, 'HISTORY', FROM_SERVER, 0, 8 + 2 + L.MAX_HISTORY *
	(8 + 8 + 8 + 1 + 1 + strMax(L.MAX_NAME) + strMax(L.MAX_HISTORY_TEXT)));
T(36, 'FRAME_ACK', FROM_CLIENT, 0, 4);
T(37, 'MESH', FROM_CLIENT, 0, 4);
T(38, 'MESH_DATA', FROM_SERVER, 0, BULK);

function typeInfo(type) {
	return Number.isInteger(type) ? TYPES[type] ?? null : null;
}

/* "FRAME" for 17; null when type is not a message type. */
export function typeName(type) {
	const t = typeInfo(type);
	return t ? t.name : null;
}

/* ---- Byte helpers -------------------------------------------------------- */

const utf8enc = new TextEncoder();
const utf8dec = new TextDecoder('utf-8', { fatal: true });

function toU8(bytes) {
	if (bytes instanceof Uint8Array) {
		return bytes;
	}
	if (bytes instanceof ArrayBuffer) {
		return new Uint8Array(bytes);
	}
	if (ArrayBuffer.isView(bytes)) {
		return new Uint8Array(bytes.buffer, bytes.byteOffset,
			bytes.byteLength);
	}
	throw new ProtoError('EINVAL', 'expected bytes');
}

/* Offset of the first byte of p[0..n) that breaks strict UTF-8 (overlong
 * forms, surrogates, code points above U+10FFFF, cut sequences) or is NUL;
 * n when the whole string is valid. The same rule as bc__utf8_check. */
export function utf8Check(p, start = 0, n = p.length - start) {
	let i = 0;
	while (i < n) {
		const c = p[start + i];
		if (c >= 0x01 && c <= 0x7f) {
			i++;
			continue;
		}
		/* The lead byte fixes the length and the range of the second
		 * byte, which excludes overlong forms, surrogates and code
		 * points over U+10FFFF (RFC 3629, section 4). */
		let len, lo = 0x80, hi = 0xbf;
		if (c >= 0xc2 && c <= 0xdf) {
			len = 2;
		} else if (c === 0xe0) {
			len = 3;
			lo = 0xa0;
		} else if (c === 0xed) {
			len = 3;
			hi = 0x9f;
		} else if (c >= 0xe1 && c <= 0xef) {
			len = 3;
		} else if (c === 0xf0) {
			len = 4;
			lo = 0x90;
		} else if (c >= 0xf1 && c <= 0xf3) {
			len = 4;
		} else if (c === 0xf4) {
			len = 4;
			hi = 0x8f;
		} else {
			return i;
		}
		if (n - i < len) {
			return i;
		}
		const c1 = p[start + i + 1];
		if (c1 < lo || c1 > hi) {
			return i;
		}
		for (let k = 2; k < len; k++) {
			const ck = p[start + i + k];
			if (ck < 0x80 || ck > 0xbf) {
				return i;
			}
		}
		i += len;
	}
	return n;
}

/* Finite means the exponent is not all ones; tested on the bits. */
const bitsFinite = (u) => (u & 0x7f800000) !== 0x7f800000;

/* ---- Decoding -------------------------------------------------------------- */

/* Smallest encodings of repeated elements, for the count-versus-bytes-left
 * checks (the same numbers as protocol/decode.c). */
const MEMBER_MIN = 7; /* u32 id, u8 role, empty name */
const SESSION_ENTRY_MIN = 26; /* a 1-byte name and the fixed fields */
const HISTORY_ENTRY_MIN = 30; /* the fixed fields and two empty strings */
/* SESSIONS entry flags: loaded in the server's memory; details known. */
export const SESSION_FLAG = Object.freeze({ LOADED: 0x01, KNOWN: 0x02,
	ALL: 0x03 });
const OP_MIN = 5;     /* REMOVE: u8 kind, u32 node */
const FIELD_MIN = 6;  /* u8 field, u8 count, one f32 */
const RECT_MIN = 13;  /* 4 x u16, u32 length, one byte */

/* A read cursor over a payload; every read checks the bytes left first, and
 * the first field that fails decides the error (fields are checked in wire
 * order, as soon as each is read). */
class Dec {
	constructor(bytes, name) {
		this.b = bytes;
		this.dv = new DataView(bytes.buffer, bytes.byteOffset,
			bytes.byteLength);
		this.pos = 0;
		this.name = name;
	}

	left() {
		return this.b.length - this.pos;
	}

	fail(code, reason) {
		throw new ProtoError(code,
			`${this.name}: ${reason} (payload byte ${this.pos})`);
	}

	need(what, n) {
		if (this.left() < n) {
			this.fail('EPROTO_TRUNCATED',
				`${what} needs ${n} bytes, ${this.left()} left`);
		}
	}

	u8(what) {
		this.need(what, 1);
		return this.b[this.pos++];
	}

	u16(what) {
		this.need(what, 2);
		const v = this.dv.getUint16(this.pos, true);
		this.pos += 2;
		return v;
	}

	u32(what) {
		this.need(what, 4);
		const v = this.dv.getUint32(this.pos, true);
		this.pos += 4;
		return v;
	}

	u64(what) {
		this.need(what, 8);
		const v = this.dv.getBigUint64(this.pos, true);
		this.pos += 8;
		return v;
	}

	/* A u32 id that must not be 0. */
	id(what) {
		const v = this.u32(what);
		if (v === 0) {
			this.fail('ERANGE', `${what} is 0`);
		}
		return v;
	}

	/* Every f32 of a payload must be finite. */
	f32(what) {
		this.need(what, 4);
		const u = this.dv.getUint32(this.pos, true);
		if (!bitsFinite(u)) {
			this.pos += 4;
			this.fail('ENONFINITE', `${what} is not finite (bits ` +
				`${u.toString(16).padStart(8, '0')})`);
		}
		const v = this.dv.getFloat32(this.pos, true);
		this.pos += 4;
		return v;
	}

	/* A finite f32 with |v| <= MAX_ABS. */
	f32abs(what) {
		const v = this.f32(what);
		if (Math.abs(v) > L.MAX_ABS) {
			this.fail('ERANGE', `|${what}| = ${Math.abs(v)} is over ` +
				`${L.MAX_ABS}`);
		}
		return v;
	}

	f32nonneg(what) {
		const v = this.f32(what);
		if (v < 0) {
			this.fail('ERANGE', `${what} = ${v} is negative`);
		}
		return v;
	}

	range(what, v, lo, hi) {
		if (v < lo || v > hi) {
			this.fail('ERANGE', `${what} = ${v} is outside ${lo}..${hi}`);
		}
		return v;
	}

	u8range(what, lo, hi) {
		return this.range(what, this.u8(what), lo, hi);
	}

	u16range(what, lo, hi) {
		return this.range(what, this.u16(what), lo, hi);
	}

	u32range(what, lo, hi) {
		return this.range(what, this.u32(what), lo, hi);
	}

	role(what) {
		const v = this.u8(what);
		if (v === 0 || v > ROLE.VIEWER) {
			this.fail('EENUM', `${what} = ${v} is not a role`);
		}
		return v;
	}

	encoding(what) {
		const v = this.u8(what);
		if (v === 0 || v > ENC.H264) {
			this.fail('EENUM', `${what} = ${v} is not an encoding`);
		}
		return v;
	}

	/* u16 byte length (min..max), then that many bytes of strict UTF-8. */
	str(what, min, max) {
		const n = this.u16(what);
		if (n < min || n > max) {
			this.fail('EPROTO_LENGTH',
				`${what} length ${n} is outside ${min}..${max}`);
		}
		this.need(what, n);
		const bad = utf8Check(this.b, this.pos, n);
		if (bad < n) {
			this.pos += bad;
			this.fail('ESTRING',
				`${what}: byte ${bad} breaks UTF-8 or is NUL`);
		}
		const s = utf8dec.decode(this.b.subarray(this.pos, this.pos + n));
		this.pos += n;
		return s;
	}

	/* u32 byte length (>= 1), then that many opaque bytes (copied). */
	blob(what) {
		const n = this.u32(what);
		if (n === 0) {
			this.fail('EPROTO_LENGTH', `${what} is empty`);
		}
		this.need(what, n);
		const b = this.b.slice(this.pos, this.pos + n);
		this.pos += n;
		return b;
	}

	/* A count n in min..max whose n elements of at least elem bytes each
	 * must fit in what is left: a lying count fails before any element
	 * is read. */
	count(what, n, min, max, elem) {
		if (n < min || n > max) {
			this.fail('EPROTO_COUNT', `${what} ${n} is outside ` +
				`${min}..${max}`);
		}
		if (n * elem > this.left()) {
			this.fail('EPROTO_COUNT', `${what} ${n} needs at least ` +
				`${n * elem} bytes, ${this.left()} left`);
		}
	}
}

/* Values a field number takes: 0 = not a field, -1 = a shape parameter
 * (1..MAX_FIELD_VALUES values). */
function fieldValues(field) {
	switch (field) {
	case FIELD.TRANSLATE:
	case FIELD.COLOR:
		return 3;
	case FIELD.ROTATE:
		return 4;
	case FIELD.BLEND:
	case FIELD.RANGE:
	case FIELD.OP_KIND:
		return 1;
	default:
		return field >= FIELD.PARAM0 &&
			field < FIELD.PARAM0 + L.MAX_PRIM_PARAMS ? -1 : 0;
	}
}

function decField(d, seen) {
	const field = d.u8('field');
	const want = fieldValues(field);
	if (want === 0) {
		d.fail('EENUM', `field ${field} is not a field number`);
	}
	if (seen.has(field)) {
		d.fail('EPARSE', `field ${field} given twice`);
	}
	seen.add(field);
	const count = d.u8('field.count');
	const ok = want > 0 ? count === want
		: count >= 1 && count <= L.MAX_FIELD_VALUES;
	if (!ok) {
		d.fail('EPROTO_COUNT', `field ${field} has ${count} values, ` +
			`expected ${want > 0 ? want : '1..' + L.MAX_FIELD_VALUES}`);
	}
	if (count * 4 > d.left()) {
		d.fail('EPROTO_COUNT', `field ${field}: ${count} values need ` +
			`${count * 4} bytes, ${d.left()} left`);
	}
	const values = [];
	for (let k = 0; k < count; k++) {
		values.push(d.f32abs('field value'));
	}
	// An operator kind's value (an integer 1..6) is meaning, checked by
	// the server when it applies the SET (PROTOCOL.md 9), not here.
	return { field, values };
}

function decOps(d) {
	const nops = d.u16('op_count');
	d.count('op_count', nops, 1, L.MAX_EDIT_OPS, OP_MIN);
	const ops = [];
	for (let i = 0; i < nops; i++) {
		const kind = d.u8('op.kind');
		switch (kind) {
		case EDIT.SET: {
			const node = d.id('op.node');
			const nfields = d.u8('op.field_count');
			d.count('op.field_count', nfields, 1, L.MAX_SET_FIELDS,
				FIELD_MIN);
			const seen = new Set();
			const fields = [];
			for (let k = 0; k < nfields; k++) {
				fields.push(decField(d, seen));
			}
			ops.push({ kind, node, fields });
			break;
		}
		case EDIT.INSERT: {
			const parent = d.id('op.parent');
			const position = d.u32('op.position');
			const subtree = d.blob('op.subtree');
			ops.push({ kind, parent, position, subtree });
			break;
		}
		case EDIT.REMOVE:
			ops.push({ kind, node: d.id('op.node') });
			break;
		case EDIT.REPLACE: {
			const node = d.id('op.node');
			ops.push({ kind, node, subtree: d.blob('op.subtree') });
			break;
		}
		case EDIT.NAME: {
			/* An empty name takes the node's name away. */
			const node = d.id('op.node');
			ops.push({ kind, node, name: d.str('op.name', 0, L.MAX_NAME) });
			break;
		}
		default:
			d.fail('EENUM', `op ${i}: kind ${kind} is unknown`);
		}
	}
	return ops;
}

function decFrame(d, flags, m) {
	const snap = (flags & FLAG.SNAPSHOT) !== 0;
	const full = snap || (flags & FLAG.STILL) !== 0;
	/* checkFlags keeps STILL and SNAPSHOT off levels above 0. */
	const level = frameLevel(flags);
	/* A snapshot and a refinement frame are one rectangle that is the
	 * whole image. */
	const whole = snap || level > 0;
	/* A snapshot's colour rectangle is followed by one per plane asked
	 * (checkFlags keeps DEPTH and IDS on snapshots). */
	const nwhole = 1 + framePlanes(flags);
	m.frame_no = d.u32('frame_no');
	m.order = d.u64('order');
	m.camera_seq = d.u32('camera_seq');
	m.encoding = d.encoding('encoding');
	if (snap && (m.encoding === ENC.JPEG || m.encoding === ENC.H264)) {
		d.fail('EENUM', 'a snapshot cannot be ' +
			(m.encoding === ENC.JPEG ? 'JPEG' : 'H.264'));
	}
	/* H.264: one access unit of the whole view at every level. */
	const video = m.encoding === ENC.H264;
	if ((flags & FLAG.KEY) && !video) {
		d.fail('EPROTO_FLAGS', `KEY on a FRAME of encoding ${m.encoding}`);
	}
	m.width = d.u16range('width', 1, L.MAX_DIM);
	m.height = d.u16range('height', 1, L.MAX_DIM);
	/* Level n: exactly the 2^n blocks that cover the view; level 0: at
	 * most the view (the view itself when full); H.264: the view. */
	const iw = video ? m.width : levelDim(m.width, level);
	const ih = video ? m.height : levelDim(m.height, level);
	const fixed = full || level > 0 || video;
	m.image_width = d.u16range('image_width', fixed ? iw : 1, iw);
	m.image_height = d.u16range('image_height', fixed ? ih : 1, ih);
	const nrects = d.u16('rect_count');
	const one = whole || video;
	d.count('rect_count', nrects, snap ? nwhole : 1,
		one ? nwhole : L.MAX_RECTS, RECT_MIN);
	m.rects = [];
	for (let i = 0; i < nrects; i++) {
		const x = d.u16('rect.x');
		const y = d.u16('rect.y');
		const w = d.u16('rect.w');
		/* A snapshot's or a refinement's one rectangle is the
		 * whole image. */
		if (w < (one ? m.image_width : 1) || x + w > m.image_width) {
			d.fail('ERANGE', `rect ${i}: x ${x} + w ${w} is outside ` +
				`1..${m.image_width}`);
		}
		const h = d.u16('rect.h');
		if (h < (one ? m.image_height : 1) || y + h > m.image_height) {
			d.fail('ERANGE', `rect ${i}: y ${y} + h ${h} is outside ` +
				`1..${m.image_height}`);
		}
		const n = d.u32('rect.length');
		const raw = w * h * 4;
		/* A plane (every rectangle after a snapshot's first) is 4
		 * bytes a pixel whatever the colour's encoding. */
		const plane = snap && i > 0;
		const exact = m.encoding === ENC.RAW || plane;
		if (n === 0 || (exact && n !== raw)) {
			d.fail('EPROTO_LENGTH', `rect ${i}: length ${n} ` +
				`(${plane ? 'a plane' : 'raw'} needs ${raw})`);
		}
		d.need('rect.data', n);
		const data = d.b.slice(d.pos, d.pos + n);
		d.pos += n;
		m.rects.push({ x, y, w, h, data });
	}
}

const STATS_FLOATS = ['render_ms_last', 'render_ms_avg', 'encode_ms_last',
	'encode_ms_avg', 'edit_ms_avg', 'fps'];
/* STATS's optional load, TLS, link and memory sections (PROTOCOL.md
 * 7.18). */
const STATS_LOAD_BYTES = 44;
const STATS_TLS_BYTES = 9;
const STATS_LINK_BYTES = 32;
const STATS_MEMORY_BYTES = 28;
const MEMORY_U64 = ['scene_nodes', 'scene_nodes_cap', 'session_nodes'];
const LOAD_F32 = ['loop_turn_max_ms', 'loop_request_max_ms'];
const LOAD_U32 = ['render_workers', 'jobs_queued', 'jobs_running'];
const LOAD_U64 = ['view_bytes', 'view_cap', 'session_render_us'];

/* The origin of an applied change, as EDIT_APPLIED and SESSION_CAMERA_SET
 * carry it: its order (from 1), its author's id and the author's seq. */
function decOrigin(d, m) {
	m.order = d.u64('order');
	if (m.order === 0n) {
		d.fail('ERANGE', 'order is 0');
	}
	m.author = d.id('author');
	m.author_seq = d.u32('author_seq');
}

/* A camera's fields, as CAMERA, SESSION_CAMERA, FOLLOW_CAMERA and
 * SESSION_CAMERA_SET carry them, into m. */
function decCamera(d, m) {
	for (const v of ['eye', 'target', 'up']) {
		m[v] = ['x', 'y', 'z'].map((c) => d.f32abs(`${v}.${c}`));
	}
	m.fov_y_deg = d.f32('fov_y_deg');
	if (!(m.fov_y_deg > 0 && m.fov_y_deg < 180)) {
		d.fail('ERANGE', `fov_y_deg ${m.fov_y_deg} is outside (0, 180)`);
	}
}

/* MESH's and MESH_DATA's first fields; lo is the one resolution under the
 * least also allowed (a MESH's 0 asks for the default). */
function decMeshHead(d, m, lo) {
	m.format = d.u8('format');
	if (m.format < MESH_FORMAT.OBJ || m.format > MESH_FORMAT.GLB) {
		d.fail('EENUM', `format ${m.format} is not a mesh format`);
	}
	m.options = d.u8('options');
	if (m.options & ~MESH_OPTION.ALL) {
		d.fail('EPROTO_FLAGS', `options ${m.options} has undefined bits`);
	}
	m.resolution = d.u16('resolution');
	if ((m.resolution < L.MIN_MESH_RESOLUTION && m.resolution !== lo) ||
	    m.resolution > L.MAX_MESH_RESOLUTION) {
		d.fail('ERANGE', `resolution ${m.resolution} is outside ` +
			`${L.MIN_MESH_RESOLUTION}..${L.MAX_MESH_RESOLUTION}`);
	}
}

function decBody(d, m) {
	switch (m.type) {
	case MSG.HELLO: {
		m.version_min = d.u16('version_min');
		if (m.version_min === 0) {
			d.fail('ERANGE', 'version_min is 0');
		}
		m.version_max = d.u16('version_max');
		if (m.version_max < m.version_min) {
			d.fail('ERANGE', `version_max ${m.version_max} < ` +
				`version_min ${m.version_min}`);
		}
		m.encodings = d.u8('encodings');
		if (m.encodings & ~ENCODINGS_ALL) {
			d.fail('EPROTO_FLAGS',
				`encodings ${m.encodings} has reserved bits`);
		}
		m.max_frame_bytes = d.u32('max_frame_bytes');
		if (m.max_frame_bytes !== 0 &&
		    m.max_frame_bytes < L.MIN_FRAME_BYTES) {
			d.fail('ERANGE', `max_frame_bytes ${m.max_frame_bytes} ` +
				`is under ${L.MIN_FRAME_BYTES}`);
		}
		m.client_name = d.str('client_name', 0, L.MAX_NAME);
		m.token = d.str('token', 0, L.MAX_TOKEN);
		/* features: absent in an earlier client's HELLO; bits this
		 * text does not name are a later client's, not an error. */
		if (d.left()) {
			m.features = d.u32('features');
		}
		break;
	}
	case MSG.WELCOME:
		m.version = d.u16range('version', 1, 0xffff);
		m.connection_id = d.id('connection_id');
		m.max_payload = d.u32range('max_payload', L.HELLO_MAX_PAYLOAD,
			L.MAX_PAYLOAD);
		m.max_frame_bytes = d.u32range('max_frame_bytes',
			L.MIN_FRAME_BYTES, L.MAX_PAYLOAD);
		m.max_nodes = d.u32range('max_nodes', 1, L.SCENE_MAX_NODES);
		m.max_dim = d.u16range('max_dim', 1, L.MAX_DIM);
		m.max_members = d.u16range('max_members', 1, L.MAX_MEMBERS);
		m.max_edit_ops = d.u16range('max_edit_ops', 1, L.MAX_EDIT_OPS);
		m.server_id = d.str('server_id', 0, L.MAX_NAME);
		/* Granted features: only when the HELLO announced some. */
		if (d.left()) {
			m.features = d.u32('features');
			if (m.features & ~FEATURE.ALL) {
				d.fail('EPROTO_FLAGS', `features ${m.features} ` +
					'has undefined bits');
			}
		}
		break;
	case MSG.ERROR:
		m.code = d.u16range('code', 1, 0xffff);
		m.text = d.str('text', 0, L.MAX_ERROR_TEXT);
		break;
	case MSG.PING:
	case MSG.PONG:
		m.stamp = d.u64('stamp');
		break;
	case MSG.GET_STATS:
		/* parts is optional, left out when 0 (PROTOCOL.md 7.18). */
		m.parts = 0;
		if (d.left()) {
			m.parts = d.u8('parts');
			if (m.parts & ~STATS_PARTS.ALL) {
				d.fail('EPROTO_FLAGS',
					`parts ${m.parts} has undefined bits`);
			}
			if (m.parts === 0) {
				d.fail('ERANGE', 'parts 0 (leave it out)');
			}
			if ((m.parts & STATS_PARTS.RESET) &&
			    !(m.parts & STATS_PARTS.LOAD)) {
				d.fail('ERANGE', 'parts RESET without LOAD');
			}
		}
		break;
	case MSG.OK:
	case MSG.SESSION_LEAVE:
	case MSG.SESSION_LIST:
	case MSG.HISTORY_GET:
		break;
	case MSG.UNDO:
	case MSG.REDO:
		/* scope is optional: the first text's UNDO is empty. */
		if (d.left()) {
			m.scope = d.u8('scope');
			if (m.scope < UNDO_SCOPE.MINE ||
			    m.scope > UNDO_SCOPE.SESSION) {
				d.fail('EENUM', `scope ${m.scope} is unknown`);
			}
		}
		break;
	case MSG.HISTORY: {
		m.order = d.u64('order');
		const n = d.u16('entry_count');
		d.count('entry_count', n, 0, L.MAX_HISTORY, HISTORY_ENTRY_MIN);
		m.entries = [];
		for (let i = 0; i < n; i++) {
			const e = {};
			e.order = d.u64('entry.order');
			if (e.order === 0n) {
				d.fail('ERANGE', 'entry.order is 0');
			}
			e.time_ms = d.u64('entry.time_ms');
			e.built_on = d.u64('entry.built_on');
			e.state = d.u8('entry.state');
			if (e.state < HISTORY_STATE.APPLIED ||
			    e.state > HISTORY_STATE.UNDONE) {
				d.fail('EENUM', `entry.state ${e.state} is unknown`);
			}
			e.flags = d.u8('entry.flags');
			if (e.flags & ~HISTORY_FLAG.ALL) {
				d.fail('EPROTO_FLAGS', 'entry flags ' + e.flags +
					' has undefined bits');
			}
			e.author = d.str('entry.author', 0, L.MAX_NAME);
			e.what = d.str('entry.what', 0, L.MAX_HISTORY_TEXT);
			m.entries.push(e);
		}
		break;
	}
	case MSG.SESSION_CREATE:
	case MSG.SESSION_JOIN:
		m.role = d.role('role');
		m.name = d.str('name', 1, L.MAX_NAME);
		break;
	case MSG.SESSION_DELETE:
		m.name = d.str('name', 1, L.MAX_NAME);
		break;
	case MSG.SESSION_INFO: {
		m.session_id = d.id('session_id');
		m.member_id = d.id('member_id');
		m.role = d.role('role');
		m.name = d.str('name', 1, L.MAX_NAME);
		const n = d.u16('member_count');
		d.count('member_count', n, 1, L.MAX_MEMBERS, MEMBER_MIN);
		m.members = [];
		for (let i = 0; i < n; i++) {
			const id = d.id('member.id');
			const role = d.role('member.role');
			const name = d.str('member.name', 0, L.MAX_NAME);
			m.members.push({ id, role, name });
		}
		break;
	}
	case MSG.SESSIONS: {
		const n = d.u16('session_count');
		d.count('session_count', n, 0, L.MAX_SESSIONS_LISTED,
			SESSION_ENTRY_MIN);
		m.sessions = [];
		for (let i = 0; i < n; i++) {
			const e = {};
			e.name = d.str('session.name', 1, L.MAX_NAME);
			e.members = d.u16('session.members');
			e.prims = d.u32('session.prims');
			e.order = d.u64('session.order');
			e.last_edit_ms = d.u64('session.last_edit_ms');
			e.flags = d.u8('session.flags');
			if (e.flags & ~SESSION_FLAG.ALL) {
				d.fail('EPROTO_FLAGS', 'session flags ' +
					e.flags + ' has undefined bits');
			}
			m.sessions.push(e);
		}
		break;
	}
	case MSG.SCENE_LOAD:
		m.scene = d.blob('scene');
		break;
	case MSG.SCENE_STATE:
		m.order = d.u64('order');
		m.author = d.u32('author');
		m.author_seq = d.u32('author_seq');
		m.scene = d.blob('scene');
		break;
	case MSG.EDIT:
		m.ops = decOps(d);
		break;
	case MSG.EDIT_APPLIED:
		decOrigin(d, m);
		m.ops = decOps(d);
		if (m.flags & (FLAG.UNDO | FLAG.REDO)) {
			if ((m.flags & FLAG.UNDO) && (m.flags & FLAG.REDO)) {
				d.fail('EPROTO_FLAGS',
					'EDIT_APPLIED with both UNDO and REDO');
			}
			m.target_order = d.u64('target_order');
			if (m.target_order === 0n) {
				d.fail('ERANGE', 'target_order is 0');
			}
			m.target_author = d.str('target_author', 0, L.MAX_NAME);
		}
		break;
	case MSG.CAMERA:
	case MSG.SESSION_CAMERA:
		decCamera(d, m);
		break;
	case MSG.PRESENT:
	case MSG.FOLLOW:
		m.on = d.u8range('on', 0, 1);
		break;
	case MSG.PRESENTER:
		m.presenter = d.u32('presenter');
		m.following = d.u8range('following', 0, 1);
		if (m.following && m.presenter === 0) {
			d.fail('ERANGE', 'following 1 while nobody presents');
		}
		break;
	case MSG.FOLLOW_CAMERA:
		m.presenter = d.id('presenter');
		decCamera(d, m);
		break;
	case MSG.SESSION_CAMERA_SET:
		decOrigin(d, m);
		decCamera(d, m);
		break;
	case MSG.VIEW:
		m.width = d.u16range('width', 1, L.MAX_DIM);
		m.height = d.u16range('height', 1, L.MAX_DIM);
		m.encoding = d.encoding('encoding');
		m.quality_interactive = d.u8range('quality_interactive', 1,
			L.MAX_QUALITY);
		m.quality_still = d.u8range('quality_still', 1, L.MAX_QUALITY);
		m.downscale = d.u8range('downscale', 1, L.MAX_DOWNSCALE);
		/* still_encoding is optional: left out, the still is in
		 * encoding (a present 0 or 4 is EENUM). */
		if (d.left()) {
			m.still_encoding = d.encoding('still_encoding');
			if (m.still_encoding === ENC.H264) {
				d.fail('EENUM', 'still_encoding 4 (leave it out)');
			}
		}
		break;
	case MSG.FRAME_ACK:
		m.frame_no = d.u32('frame_no');
		if (m.frame_no === 0) {
			d.fail('ERANGE', 'frame_no 0');
		}
		break;
	case MSG.FRAME:
		decFrame(d, m.flags, m);
		break;
	case MSG.MESH:
		decMeshHead(d, m, 0);
		break;
	case MSG.MESH_DATA:
		decMeshHead(d, m, L.MIN_MESH_RESOLUTION);
		m.order = d.u64('order');
		m.vertices = d.u32('vertices');
		m.triangles = d.u32('triangles');
		m.file = d.blob('file');
		break;
	case MSG.PICK:
		m.x = d.u16('x');
		m.y = d.u16('y');
		break;
	case MSG.PICK_RESULT:
		m.x = d.u16('x');
		m.y = d.u16('y');
		m.node = d.u32('node');
		m.position = [];
		for (const c of ['x', 'y', 'z']) {
			const v = d.f32(`position.${c}`);
			if (m.node === 0 && v !== 0) {
				d.fail('ERANGE', `a miss has position.${c} != 0`);
			}
			m.position.push(v);
		}
		m.depth = d.f32nonneg('depth');
		if (m.node === 0 && m.depth !== 0) {
			d.fail('ERANGE', 'a miss has depth != 0');
		}
		break;
	case MSG.SNAPSHOT:
		m.encoding = d.encoding('encoding');
		if (m.encoding === ENC.JPEG) {
			d.fail('EENUM', 'a snapshot cannot be JPEG');
		}
		/* planes is optional: a colour-only SNAPSHOT stops here, and
		 * leaves the byte out rather than send 0 (one encoding per
		 * SNAPSHOT). */
		m.planes = 0;
		if (d.left()) {
			m.planes = d.u8('planes');
			if (m.planes & ~PLANE.ALL) {
				d.fail('EPROTO_FLAGS',
					`planes ${m.planes} has undefined bits`);
			}
			if (m.planes === 0 && !d.left()) {
				d.fail('ERANGE', 'planes 0 (leave it out)');
			}
		}
		/* The tile form (feature TILES): the picture's size, then
		 * the tile inside it. */
		if (d.left()) {
			m.full_width = d.u16range('full_width', 1, L.MAX_DIM);
			m.full_height = d.u16range('full_height', 1, L.MAX_DIM);
			m.tile_x = d.u16range('tile_x', 0, m.full_width - 1);
			m.tile_y = d.u16range('tile_y', 0, m.full_height - 1);
			m.tile_width = d.u16range('tile_width', 1,
				m.full_width - m.tile_x);
			m.tile_height = d.u16range('tile_height', 1,
				m.full_height - m.tile_y);
		}
		break;
	case MSG.STATS:
		for (const k of ['uptime_ms', 'frames', 'bytes', 'order']) {
			m[k] = d.u64(k);
		}
		m.sessions = d.u32('sessions');
		m.clients = d.u32('clients');
		for (const k of STATS_FLOATS) {
			m[k] = d.f32nonneg(k);
		}
		/* The load, TLS, link and memory sections answer a
		 * GET_STATS that asked for them, in that order: the length
		 * tells which (every sum of 44, 9, 32 and 28 differs). */
		const left = d.left();
		let sections = -1;
		for (let k = 0; k < 16; k++) {
			if (left === ((k & 1) ? STATS_LOAD_BYTES : 0) +
			    ((k & 2) ? STATS_TLS_BYTES : 0) +
			    ((k & 4) ? STATS_LINK_BYTES : 0) +
			    ((k & 8) ? STATS_MEMORY_BYTES : 0)) {
				sections = k;
				break;
			}
		}
		if (sections < 0) {
			d.fail('EPROTO_TRAILING',
				`${d.left()} bytes after the last field`);
		}
		if (sections & 1) {
			m.has_load = true;
			for (const k of LOAD_F32) {
				m[k] = d.f32nonneg(k);
			}
			for (const k of LOAD_U32) {
				m[k] = d.u32(k);
			}
			for (const k of LOAD_U64) {
				m[k] = d.u64(k);
			}
		}
		if (sections & 2) {
			m.has_tls = true;
			m.tls_not_after_ms = d.u64('tls_not_after_ms');
			m.tls_expiring = d.u8('tls_expiring');
			if (m.tls_expiring > 1) {
				d.fail('ERANGE', `tls_expiring ${m.tls_expiring} ` +
					'is not 0 or 1');
			}
		}
		if (sections & 4) {
			m.has_link = true;
			m.rtt_us = d.u32('rtt_us');
			m.min_rtt_us = d.u32('min_rtt_us');
			m.delivery_bps = d.u64('delivery_bps');
			m.unacked_bytes = d.u32('unacked_bytes');
			m.frames_paced = d.u32('frames_paced');
			m.frames_spoiled = d.u64('frames_spoiled');
		}
		if (sections & 8) {
			m.has_memory = true;
			for (const k of MEMORY_U64) {
				m[k] = d.u64(k);
			}
			m.sessions_loaded = d.u32('sessions_loaded');
		}
		break;
	default:
		d.fail('EPROTO_TYPE', `type ${m.type} is unknown`);
	}
	if (d.left()) {
		d.fail('EPROTO_TRAILING', `${d.left()} bytes after the last field`);
	}
	return m;
}

/* The header flag rule (PROTOCOL.md 3.1 step 5): bits the type does not
 * define, and on FRAME a level above 0 with STILL or SNAPSHOT, are
 * EPROTO_FLAGS. Only FRAME defines the level bits. Throws a ProtoError. */
function checkFlags(t, flags, prefix = '') {
	if (flags & ~t.flags) {
		throw new ProtoError('EPROTO_FLAGS',
			`${prefix}${t.name} with undefined flags ${flags & ~t.flags}`);
	}
	const level = frameLevel(flags);
	if (level > 0 && (flags & (FLAG.STILL | FLAG.SNAPSHOT))) {
		throw new ProtoError('EPROTO_FLAGS', `${prefix}${t.name} at ` +
			`level ${level} with ` +
			((flags & FLAG.SNAPSHOT) ? 'SNAPSHOT' : 'STILL'));
	}
	/* The depth and id planes answer a SNAPSHOT only. */
	if ((flags & (FLAG.DEPTH | FLAG.IDS)) && !(flags & FLAG.SNAPSHOT)) {
		throw new ProtoError('EPROTO_FLAGS', `${prefix}${t.name} with ` +
			((flags & FLAG.DEPTH) ? 'DEPTH' : 'IDS') +
			' but not SNAPSHOT');
	}
}

/* Decodes one payload of the given type outside any stream: no header, no
 * side or stage rules, only the type's own checks (its flags and maximum
 * size included). Returns the message; throws a ProtoError. */
export function decodePayload(type, flags, seq, payload) {
	const t = typeInfo(type);
	if (!t) {
		throw new ProtoError('EPROTO_TYPE', `message type ${type} is unknown`);
	}
	checkFlags(t, flags);
	const p = toU8(payload);
	if (p.length > t.max) {
		throw new ProtoError('EPROTO_LENGTH', `${t.name} payload length ` +
			`${p.length} is over its maximum ${t.max}`);
	}
	return decBody(new Dec(p, t.name), { type, flags, seq });
}

/* ---- The push reader ------------------------------------------------------- */

const SIDES = { any: FROM_BOTH, server: FROM_CLIENT, client: FROM_SERVER };

function clampPayload(max) {
	return !max || max > L.MAX_PAYLOAD ? L.MAX_PAYLOAD : max;
}

export class Reader {
	/* side: 'any' (tools, tests), 'server' (reads what clients send) or
	 * 'client' (reads what servers send). maxPayload: 0 = the protocol's
	 * maximum; a client sets its HELLO max_frame_bytes. awaitHello: only
	 * HELLO and PING, with small payloads, until helloDone(). */
	constructor({ side = 'any', maxPayload = 0, awaitHello = false } = {}) {
		if (!(side in SIDES)) {
			throw new ProtoError('EINVAL', `side ${side} is unknown`);
		}
		this.want = SIDES[side];
		this.maxPayload = clampPayload(maxPayload);
		this.preHello = awaitHello;
		this.buf = new Uint8Array(0);
		this.len = 0; /* bytes buffered */
		this.pos = 0; /* bytes parsed */
		this.nmsgs = 0;
		this.err = null; /* the sticky ProtoError */
	}

	/* The payload limit now in force. */
	limit() {
		return this.preHello ? Math.min(this.maxPayload,
			L.HELLO_MAX_PAYLOAD) : this.maxPayload;
	}

	setError(code, message) {
		this.err = new ProtoError(code, message);
		return this.err;
	}

	helloDone() {
		this.preHello = false;
	}

	setMaxPayload(max) {
		this.maxPayload = clampPayload(max);
	}

	/* Bytes buffered and not yet returned as messages. */
	get pending() {
		return this.len - this.pos;
	}

	/* Appends bytes (copied). Throws the sticky error, or ELIMIT when more
	 * than one whole message plus READ_SLACK would wait unparsed (drain
	 * with next() between feeds). */
	feed(bytes) {
		if (this.err) {
			throw this.err;
		}
		const b = toU8(bytes);
		if (b.length === 0) {
			return;
		}
		/* Drop what was parsed: only the unparsed tail moves. */
		if (this.pos > 0) {
			this.buf.copyWithin(0, this.pos, this.len);
			this.len -= this.pos;
			this.pos = 0;
		}
		const ceiling = HEADER_SIZE + this.limit() + L.READ_SLACK;
		if (b.length > ceiling - this.len) {
			throw this.setError('ELIMIT', `${this.len} unparsed bytes ` +
				`plus ${b.length} more exceed the reader's ${ceiling}`);
		}
		if (this.len + b.length > this.buf.length) {
			/* Grows with the bytes that arrive, never with what a
			 * header announces. */
			let cap = this.buf.length || 4096;
			while (cap < this.len + b.length) {
				cap = cap > ceiling / 2 ? ceiling : cap * 2;
			}
			const grown = new Uint8Array(cap);
			grown.set(this.buf.subarray(0, this.len));
			this.buf = grown;
		}
		this.buf.set(b, this.len);
		this.len += b.length;
	}

	/* Checks the first avail (< 16 possible) header bytes field by field,
	 * so a stream that is not ours fails on its first wrong byte. */
	checkHeader(h, avail) {
		for (let i = 0; i < 4 && i < avail; i++) {
			if (h[i] !== MAGIC[i]) {
				throw this.setError('EPROTO_MAGIC', `header byte ${i} ` +
					`is 0x${h[i].toString(16)}, not the magic "BCST" ` +
					`(message ${this.nmsgs + 1})`);
			}
		}
		if (avail < 5) {
			return;
		}
		if (h[4] !== VERSION) {
			throw this.setError('EPROTO_VERSION',
				`version ${h[4]} is not ${VERSION}`);
		}
		if (avail < 6) {
			return;
		}
		const t = typeInfo(h[5]);
		if (!t) {
			throw this.setError('EPROTO_TYPE',
				`message type ${h[5]} is unknown`);
		}
		if (!(t.from & this.want)) {
			throw this.setError('EPROTO_TYPE', `${t.name} is never sent ` +
				(this.want === FROM_CLIENT ? 'by clients' : 'by servers'));
		}
		if (this.preHello && h[5] !== MSG.HELLO && h[5] !== MSG.PING) {
			throw this.setError('ESTATE', `${t.name} before HELLO`);
		}
		if (avail < 8) {
			return;
		}
		const flags = h[6] | (h[7] << 8);
		try {
			checkFlags(t, flags);
		} catch (e) {
			throw this.setError(e.code, e.message);
		}
		if (avail < 12) {
			return;
		}
		const len = (h[8] | h[9] << 8 | h[10] << 16 | h[11] << 24) >>> 0;
		if (len > t.max) {
			throw this.setError('EPROTO_LENGTH', `${t.name} payload ` +
				`length ${len} is over its maximum ${t.max}`);
		}
		if (len > this.limit()) {
			throw this.setError('EPROTO_LENGTH', `${t.name} payload ` +
				`length ${len} is over the limit ${this.limit()}`);
		}
	}

	/* The next whole message, or null when more bytes are needed. Throws
	 * the (sticky) ProtoError of a bad stream; header errors are thrown as
	 * soon as the offending byte has arrived. */
	next() {
		if (this.err) {
			throw this.err;
		}
		const avail = this.len - this.pos;
		if (avail === 0) {
			return null;
		}
		const h = this.buf.subarray(this.pos,
			this.pos + Math.min(avail, HEADER_SIZE));
		this.checkHeader(h, h.length);
		if (h.length < HEADER_SIZE) {
			return null;
		}
		const dv = new DataView(h.buffer, h.byteOffset, HEADER_SIZE);
		const len = dv.getUint32(8, true);
		if (avail - HEADER_SIZE < len) {
			return null;
		}
		const type = h[5];
		const flags = dv.getUint16(6, true);
		const seq = dv.getUint32(12, true);
		const start = this.pos + HEADER_SIZE;
		let m;
		try {
			m = decBody(new Dec(this.buf.subarray(start, start + len),
				TYPES[type].name), { type, flags, seq });
		} catch (e) {
			this.err = e;
			throw e;
		}
		this.pos += HEADER_SIZE + len;
		this.nmsgs++;
		if (this.pos === this.len) {
			this.pos = this.len = 0;
		}
		return m;
	}

	/* The stream has ended: throws EPROTO_TRUNCATED (sticky) when a partial
	 * message is buffered. */
	eof() {
		if (this.err) {
			throw this.err;
		}
		const left = this.len - this.pos;
		if (left) {
			throw this.setError('EPROTO_TRUNCATED', `stream ended ${left} ` +
				`bytes into message ${this.nmsgs + 1}`);
		}
	}
}

/* ---- Encoding -------------------------------------------------------------- */

/* A growable little-endian writer. Values that do not fit their wire width
 * are refused here; everything else is judged by the decoder afterwards. */
class Enc {
	constructor() {
		this.b = new Uint8Array(256);
		this.dv = new DataView(this.b.buffer);
		this.n = 0;
	}

	room(k) {
		if (this.n + k <= this.b.length) {
			return;
		}
		let cap = this.b.length * 2;
		while (cap < this.n + k) {
			cap *= 2;
		}
		const grown = new Uint8Array(cap);
		grown.set(this.b.subarray(0, this.n));
		this.b = grown;
		this.dv = new DataView(grown.buffer);
	}

	int(what, v, max, code = 'ERANGE') {
		if (!Number.isInteger(v) || v < 0 || v > max) {
			throw new ProtoError(code, `encode: ${what} = ${v} does not ` +
				`fit 0..${max}`);
		}
		return v;
	}

	u8(what, v, code) {
		this.int(what, v, 0xff, code);
		this.room(1);
		this.b[this.n++] = v;
	}

	u16(what, v, code) {
		this.int(what, v, 0xffff, code);
		this.room(2);
		this.dv.setUint16(this.n, v, true);
		this.n += 2;
	}

	u32(what, v, code) {
		this.int(what, v, 0xffffffff, code);
		this.room(4);
		this.dv.setUint32(this.n, v, true);
		this.n += 4;
	}

	u64(what, v) {
		let big;
		try {
			big = BigInt(v ?? 0);
		} catch {
			throw new ProtoError('ERANGE', `encode: ${what} is not an integer`);
		}
		if (big < 0n || big > 0xffffffffffffffffn) {
			throw new ProtoError('ERANGE', `encode: ${what} does not fit u64`);
		}
		this.room(8);
		this.dv.setBigUint64(this.n, big, true);
		this.n += 8;
	}

	f32(what, v) {
		if (typeof v !== 'number') {
			throw new ProtoError('EINVAL', `encode: ${what} is not a number`);
		}
		this.room(4);
		this.dv.setFloat32(this.n, v, true);
		this.n += 4;
	}

	f32v(what, arr, n) {
		if (!Array.isArray(arr) && !ArrayBuffer.isView(arr)) {
			throw new ProtoError('EINVAL', `encode: ${what} is not an array`);
		}
		if (arr.length !== n) {
			throw new ProtoError('EPROTO_COUNT',
				`encode: ${what} has ${arr.length} values, not ${n}`);
		}
		for (let i = 0; i < n; i++) {
			this.f32(what, arr[i]);
		}
	}

	raw(b) {
		this.room(b.length);
		this.b.set(b, this.n);
		this.n += b.length;
	}

	str(what, s) {
		const b = utf8enc.encode(s ?? '');
		if (b.length > 0xffff) {
			throw new ProtoError('EPROTO_LENGTH',
				`encode: ${what} length ${b.length} is over 65535`);
		}
		this.u16(what, b.length);
		this.raw(b);
	}

	blob(what, bytes) {
		const b = toU8(bytes ?? new Uint8Array(0));
		this.u32(what, b.length);
		this.raw(b);
	}

	count(what, arr, max) {
		const n = Array.isArray(arr) ? arr.length : -1;
		if (n < 0) {
			throw new ProtoError('EINVAL', `encode: ${what} is not an array`);
		}
		if (n > max) {
			throw new ProtoError('EPROTO_COUNT',
				`encode: ${what} ${n} is over ${max}`);
		}
		return n;
	}

	bytes() {
		return this.b.slice(0, this.n);
	}
}

function encOps(w, ops) {
	w.u16('op_count', w.count('op_count', ops, L.MAX_EDIT_OPS));
	for (const op of ops) {
		w.u8('op.kind', op.kind, 'EENUM');
		switch (op.kind) {
		case EDIT.SET:
			w.u32('op.node', op.node);
			w.u8('op.field_count',
				w.count('op.field_count', op.fields, L.MAX_SET_FIELDS));
			for (const f of op.fields) {
				w.u8('field', f.field, 'EENUM');
				const n = w.count('field.values', f.values,
					L.MAX_FIELD_VALUES);
				w.u8('field.count', n);
				w.f32v('field.values', f.values, n);
			}
			break;
		case EDIT.INSERT:
			w.u32('op.parent', op.parent);
			w.u32('op.position', op.position);
			w.blob('op.subtree', op.subtree);
			break;
		case EDIT.REMOVE:
			w.u32('op.node', op.node);
			break;
		case EDIT.REPLACE:
			w.u32('op.node', op.node);
			w.blob('op.subtree', op.subtree);
			break;
		case EDIT.NAME:
			w.u32('op.node', op.node);
			w.str('op.name', op.name);
			break;
		default:
			throw new ProtoError('EENUM', `encode: op kind ${op.kind}`);
		}
	}
}

function encCamera(w, m) {
	w.f32v('eye', m.eye, 3);
	w.f32v('target', m.target, 3);
	w.f32v('up', m.up, 3);
	w.f32('fov_y_deg', m.fov_y_deg);
}

function encBody(w, m) {
	switch (m.type) {
	case MSG.HELLO:
		w.u16('version_min', m.version_min);
		w.u16('version_max', m.version_max);
		w.u8('encodings', m.encodings, 'EPROTO_FLAGS');
		w.u32('max_frame_bytes', m.max_frame_bytes);
		w.str('client_name', m.client_name);
		w.str('token', m.token);
		if (m.features !== undefined) {
			w.u32('features', m.features);
		}
		break;
	case MSG.WELCOME:
		w.u16('version', m.version);
		w.u32('connection_id', m.connection_id);
		w.u32('max_payload', m.max_payload);
		w.u32('max_frame_bytes', m.max_frame_bytes);
		w.u32('max_nodes', m.max_nodes);
		w.u16('max_dim', m.max_dim);
		w.u16('max_members', m.max_members);
		w.u16('max_edit_ops', m.max_edit_ops);
		w.str('server_id', m.server_id);
		if (m.features !== undefined) {
			w.u32('features', m.features);
		}
		break;
	case MSG.ERROR:
		w.u16('code', m.code);
		w.str('text', m.text);
		break;
	case MSG.PING:
	case MSG.PONG:
		w.u64('stamp', m.stamp);
		break;
	case MSG.GET_STATS:
		/* Left out when 0: the first version's empty GET_STATS. */
		if (m.parts) {
			w.u8('parts', m.parts);
		}
		break;
	case MSG.OK:
	case MSG.SESSION_LEAVE:
	case MSG.SESSION_LIST:
	case MSG.HISTORY_GET:
		break;
	case MSG.UNDO:
	case MSG.REDO:
		/* Left out when absent: the first text's empty UNDO. */
		if (m.scope !== undefined) {
			w.u8('scope', m.scope, 'EENUM');
		}
		break;
	case MSG.HISTORY:
		w.u64('order', m.order);
		w.u16('entry_count', w.count('entries', m.entries,
			L.MAX_HISTORY));
		for (const e of m.entries) {
			w.u64('entry.order', e.order);
			w.u64('entry.time_ms', e.time_ms);
			w.u64('entry.built_on', e.built_on);
			w.u8('entry.state', e.state, 'EENUM');
			w.u8('entry.flags', e.flags, 'EPROTO_FLAGS');
			w.str('entry.author', e.author);
			w.str('entry.what', e.what);
		}
		break;
	case MSG.SESSION_CREATE:
	case MSG.SESSION_JOIN:
		w.u8('role', m.role, 'EENUM');
		w.str('name', m.name);
		break;
	case MSG.SESSION_DELETE:
		w.str('name', m.name);
		break;
	case MSG.SESSION_INFO:
		w.u32('session_id', m.session_id);
		w.u32('member_id', m.member_id);
		w.u8('role', m.role, 'EENUM');
		w.str('name', m.name);
		w.u16('member_count', w.count('members', m.members,
			L.MAX_MEMBERS));
		for (const mb of m.members) {
			w.u32('member.id', mb.id);
			w.u8('member.role', mb.role, 'EENUM');
			w.str('member.name', mb.name);
		}
		break;
	case MSG.SESSIONS:
		w.u16('session_count', w.count('sessions', m.sessions,
			L.MAX_SESSIONS_LISTED));
		for (const e of m.sessions) {
			w.str('session.name', e.name);
			w.u16('session.members', e.members);
			w.u32('session.prims', e.prims);
			w.u64('session.order', e.order);
			w.u64('session.last_edit_ms', e.last_edit_ms);
			w.u8('session.flags', e.flags);
		}
		break;
	case MSG.SCENE_LOAD:
		w.blob('scene', m.scene);
		break;
	case MSG.SCENE_STATE:
		w.u64('order', m.order);
		w.u32('author', m.author);
		w.u32('author_seq', m.author_seq);
		w.blob('scene', m.scene);
		break;
	case MSG.EDIT:
		encOps(w, m.ops);
		break;
	case MSG.EDIT_APPLIED:
		w.u64('order', m.order);
		w.u32('author', m.author);
		w.u32('author_seq', m.author_seq);
		encOps(w, m.ops);
		if ((m.flags ?? 0) & (FLAG.UNDO | FLAG.REDO)) {
			w.u64('target_order', m.target_order);
			w.str('target_author', m.target_author);
		}
		break;
	case MSG.CAMERA:
	case MSG.SESSION_CAMERA:
		encCamera(w, m);
		break;
	case MSG.PRESENT:
	case MSG.FOLLOW:
		w.u8('on', m.on);
		break;
	case MSG.PRESENTER:
		w.u32('presenter', m.presenter);
		w.u8('following', m.following);
		break;
	case MSG.FOLLOW_CAMERA:
		w.u32('presenter', m.presenter);
		encCamera(w, m);
		break;
	case MSG.SESSION_CAMERA_SET:
		w.u64('order', m.order);
		w.u32('author', m.author);
		w.u32('author_seq', m.author_seq);
		encCamera(w, m);
		break;
	case MSG.VIEW:
		w.u16('width', m.width);
		w.u16('height', m.height);
		w.u8('encoding', m.encoding, 'EENUM');
		w.u8('quality_interactive', m.quality_interactive);
		w.u8('quality_still', m.quality_still);
		w.u8('downscale', m.downscale);
		if (m.still_encoding) {
			w.u8('still_encoding', m.still_encoding, 'EENUM');
		}
		break;
	case MSG.FRAME_ACK:
		w.u32('frame_no', m.frame_no);
		break;
	case MSG.FRAME:
		w.u32('frame_no', m.frame_no);
		w.u64('order', m.order);
		w.u32('camera_seq', m.camera_seq);
		w.u8('encoding', m.encoding, 'EENUM');
		w.u16('width', m.width);
		w.u16('height', m.height);
		w.u16('image_width', m.image_width);
		w.u16('image_height', m.image_height);
		w.u16('rect_count', w.count('rects', m.rects, L.MAX_RECTS),
			'EPROTO_COUNT');
		for (const r of m.rects) {
			w.u16('rect.x', r.x);
			w.u16('rect.y', r.y);
			w.u16('rect.w', r.w);
			w.u16('rect.h', r.h);
			w.blob('rect.data', r.data);
		}
		break;
	case MSG.MESH:
	case MSG.MESH_DATA:
		w.u8('format', m.format, 'EENUM');
		w.u8('options', m.options, 'EPROTO_FLAGS');
		w.u16('resolution', m.resolution);
		if (m.type === MSG.MESH_DATA) {
			w.u64('order', m.order);
			w.u32('vertices', m.vertices);
			w.u32('triangles', m.triangles);
			w.blob('file', m.file);
		}
		break;
	case MSG.PICK:
		w.u16('x', m.x);
		w.u16('y', m.y);
		break;
	case MSG.PICK_RESULT:
		w.u16('x', m.x);
		w.u16('y', m.y);
		w.u32('node', m.node);
		w.f32v('position', m.position, 3);
		w.f32('depth', m.depth);
		break;
	case MSG.SNAPSHOT:
		w.u8('encoding', m.encoding, 'EENUM');
		/* Left out when 0: the one-byte SNAPSHOT of colour only;
		 * the tile form always has it. */
		if (m.planes || m.full_width !== undefined) {
			w.u8('planes', m.planes);
		}
		if (m.full_width !== undefined) {
			for (const k of ['full_width', 'full_height', 'tile_x',
				'tile_y', 'tile_width', 'tile_height']) {
				w.u16(k, m[k]);
			}
		}
		break;
	case MSG.STATS:
		for (const k of ['uptime_ms', 'frames', 'bytes', 'order']) {
			w.u64(k, m[k]);
		}
		w.u32('sessions', m.sessions);
		w.u32('clients', m.clients);
		for (const k of STATS_FLOATS) {
			w.f32(k, m[k]);
		}
		if (m.has_load) {
			for (const k of LOAD_F32) {
				w.f32(k, m[k]);
			}
			for (const k of LOAD_U32) {
				w.u32(k, m[k]);
			}
			for (const k of LOAD_U64) {
				w.u64(k, m[k]);
			}
		}
		if (m.has_tls) {
			w.u64('tls_not_after_ms', m.tls_not_after_ms);
			w.u8('tls_expiring', m.tls_expiring);
		}
		if (m.has_link) {
			w.u32('rtt_us', m.rtt_us);
			w.u32('min_rtt_us', m.min_rtt_us);
			w.u64('delivery_bps', m.delivery_bps);
			w.u32('unacked_bytes', m.unacked_bytes);
			w.u32('frames_paced', m.frames_paced);
			w.u64('frames_spoiled', m.frames_spoiled);
		}
		if (m.has_memory) {
			for (const k of MEMORY_U64) {
				w.u64(k, m[k]);
			}
			w.u32('sessions_loaded', m.sessions_loaded);
		}
		break;
	default:
		throw new ProtoError('EPROTO_TYPE', `encode: type ${m.type}`);
	}
}

/* UNDO (or REDO with redo) as bytes, for Ctrl+Z (Ctrl+Shift+Z):
 * encodeUndo({ mine: true }) takes back the sender's own newest change,
 * encodeUndo({ session: true }) the session's newest (the owner or
 * presenter only; others get ERROR EPERM), encodeUndo() the first text's
 * empty UNDO. A scope needs FEATURE.HISTORY granted in WELCOME. */
export function encodeUndo({ redo = false, mine = false, session = false,
	seq = 0 } = {}) {
	const m = { type: redo ? MSG.REDO : MSG.UNDO, seq };
	if (mine && session) {
		throw new ProtoError('EINVAL', 'encodeUndo: mine or session');
	}
	if (mine || session) {
		m.scope = mine ? UNDO_SCOPE.MINE : UNDO_SCOPE.SESSION;
	}
	return encode(m);
}

/* HISTORY_GET as bytes (PROTOCOL.md 7.26; FEATURE.HISTORY granted). */
export function encodeHistoryGet({ seq = 0 } = {}) {
	return encode({ type: MSG.HISTORY_GET, seq });
}

/* FRAME_ACK as bytes (PROTOCOL.md 7.27; FEATURE.ACKS granted): every FRAME
 * up to frame_no is shown. */
export function encodeFrameAck({ seq = 0, frame_no }) {
	return encode({ type: MSG.FRAME_ACK, seq, frame_no });
}

/* A decoded HISTORY message as rows for a history panel, newest first:
 * { order, time (a Date, or null), author, what, undone, yours, next,
 * builtOn } -- order and builtOn as BigInt (builtOn 0n: nothing built on
 * it; while not 0n its author's own undo skips it). */
export function decodeHistory(m) {
	if (m.type !== MSG.HISTORY) {
		throw new ProtoError('EPROTO_TYPE', 'decodeHistory: not HISTORY');
	}
	return m.entries.map((e) => ({
		order: e.order,
		time: e.time_ms ? new Date(Number(e.time_ms)) : null,
		author: e.author,
		what: e.what,
		undone: e.state === HISTORY_STATE.UNDONE,
		yours: (e.flags & HISTORY_FLAG.YOURS) !== 0,
		next: (e.flags & HISTORY_FLAG.NEXT) !== 0,
		builtOn: e.built_on,
	}));
}

/* Encodes one message, header included. Returns a new Uint8Array; throws a
 * ProtoError with the code the decoder would give for an invalid field
 * (ENONFINITE, ERANGE, EENUM, EPROTO_COUNT, ...), EPROTO_TYPE, EPROTO_FLAGS
 * or EPROTO_LENGTH (payload over the type's maximum). */
export function encode(m) {
	const t = typeInfo(m.type);
	if (!t) {
		throw new ProtoError('EPROTO_TYPE', `encode: type ${m.type}`);
	}
	const flags = m.flags ?? 0;
	const seq = m.seq ?? 0;
	const w = new Enc();
	/* The header first, its length patched in below. */
	w.raw(MAGIC);
	w.u8('version', VERSION);
	w.u8('type', t.type);
	w.u16('flags', flags, 'EPROTO_FLAGS');
	w.u32('length', 0);
	w.u32('seq', seq);
	checkFlags(t, flags, 'encode: ');
	encBody(w, m);
	const len = w.n - HEADER_SIZE;
	if (len > t.max) {
		throw new ProtoError('EPROTO_LENGTH', `encode: ${t.name} payload ` +
			`${len} is over its maximum ${t.max}`);
	}
	w.dv.setUint32(8, len, true);
	const out = w.bytes();
	/* Only what the decoder accepts goes out. */
	decBody(new Dec(out.subarray(HEADER_SIZE), t.name), { type: t.type,
		flags, seq });
	return out;
}

/* ---- The scene encoding (PROTOCOL.md section 8, owned by blobtree) ------ */

/*
 * u8 flags (bit 0: a camera follows; bit 1: a names table follows the
 * tree), [10 f32 camera: eye, target, up, fov_y_deg], u32 node_count,
 * then the nodes in pre-order:
 *   primitive: u8 kind (1..32), u32 id, 3 f32 translate, 4 f32 rotate
 *              (quaternion x y z w), u8 has_color, [3 f32 color],
 *              u8 nfloats (the kind's count, at most 8), nfloats f32
 *   operator:  u8 0x80 | kind (1..6), u32 id, f32 blend, f32 range,
 *              u32 child_count (>= 2)
 *   unary:     u8 0x80 | kind (7..14: offset, onion, elongate, twist,
 *              bend, mirror, repeat, scale), u32 id, u8 nfloats (at most
 *              6), nfloats f32; exactly one child follows
 * then, with flags bit 1, the names table: u32 name_count (1..node_count),
 * (u32 id, str(64) name) x name_count, ids strictly increasing, each name
 * 1..64 bytes of strict UTF-8 without NUL.
 * The checks and their order are those of bc_proto_scene_scan: what the
 * bytes alone decide. Each kind's exact float count, parameter ranges,
 * camera geometry and unique ids are the server's to check; that a name's
 * id is a node of the scene is parseScene's (ENONODE).
 */
export const SCENE_FLAG = Object.freeze({ CAMERA: 0x01, NAMES: 0x02,
	ALL: 0x03 });
const NODE_MIN = 5; /* tag and id: the least any node takes */
const NAME_ENTRY_MIN = 7; /* u32 id, u16 length, a one-byte name */
const OP_TAG = 0x80;

class SceneCur {
	constructor(bytes) {
		this.b = toU8(bytes);
		this.dv = new DataView(this.b.buffer, this.b.byteOffset,
			this.b.byteLength);
		this.pos = 0;
		this.node = 0;
		this.where = null; /* "name 3" once in the names table */
		this.kids = 0; /* the child count of the operator scanned last */
	}

	left() {
		return this.b.length - this.pos;
	}

	fail(code, reason) {
		throw new ProtoError(code, `scene: ${this.where ??
			`node ${this.node}`}: ${reason} (byte ${this.pos})`);
	}

	need(n, what) {
		if (n > this.left()) {
			this.fail('EPROTO_TRUNCATED',
				`${what} needs ${n} bytes, ${this.left()} left`);
		}
	}

	u8(what) {
		this.need(1, what);
		return this.b[this.pos++];
	}

	u16(what) {
		this.need(2, what);
		const v = this.dv.getUint16(this.pos, true);
		this.pos += 2;
		return v;
	}

	u32(what) {
		this.need(4, what);
		const v = this.dv.getUint32(this.pos, true);
		this.pos += 4;
		return v;
	}

	/* Whether the next 16 bytes are the identity quaternion (0, 0, 0, 1),
	 * bit for bit (a -0 is not 0: the bytes must encode back the same);
	 * if so, they are passed over. */
	identity() {
		if (this.left() < 16) {
			return false;
		}
		const dv = this.dv, p = this.pos;
		if (dv.getUint32(p, true) || dv.getUint32(p + 4, true) ||
			dv.getUint32(p + 8, true) ||
			dv.getUint32(p + 12, true) !== 0x3f800000) {
			return false;
		}
		this.pos += 16;
		return true;
	}

	/* A group of n floats: its length is checked as a whole first, then
	 * each float must be finite (a float32 is finite when the number it
	 * reads as is). The array is made at its size: one grown by push
	 * keeps room for 17, and a million-primitive mirror holds four such
	 * arrays a primitive (870 MiB of heap against 423). */
	floats(n, what) {
		this.need(4 * n, what);
		const out = new Array(n);
		for (let i = 0; i < n; i++) {
			const v = this.dv.getFloat32(this.pos, true);
			this.pos += 4;
			if (!Number.isFinite(v)) {
				this.fail('ENONFINITE', `${what}[${i}] is not finite`);
			}
			out[i] = v;
		}
		return out;
	}
}

function scanOp(s, tag, id, after) {
	const kind = tag & ~OP_TAG;
	if (kind === 0 || kind > L.OP_KIND_MAX) {
		s.fail('EENUM', `operator tag 0x${tag.toString(16)} is unknown`);
	}
	if (kind >= L.OP_KIND_FIRST_UNARY) {
		const nfloats = s.u8('nfloats');
		if (nfloats > L.MAX_UNARY_PARAMS) {
			s.fail('EPROTO_COUNT', `nfloats ${nfloats} is over ` +
				`${L.MAX_UNARY_PARAMS}`);
		}
		const params = s.floats(nfloats, 'params');
		if (after < 1) {
			s.fail('EPROTO_COUNT',
				'a unary node needs its child after it');
		}
		s.kids = 1;
		return { isOp: true, unary: true, kind, id, params, parent: null,
			children: null };
	}
	const [blend] = s.floats(1, 'blend');
	const [range] = s.floats(1, 'range');
	const children = s.u32('child_count');
	/* Each child is at least one more node of the encoding. */
	if (children < 2 || children > after) {
		s.fail('EPROTO_COUNT', `child_count ${children} is outside ` +
			`2..${after} (the nodes that follow)`);
	}
	/* Sharp operators (union, intersection, difference) have no blend. */
	if (kind <= 3 && (blend !== 0 || range !== 0)) {
		s.fail('ERANGE', 'a sharp operator has blend and range 0');
	}
	s.kids = children;
	return { isOp: true, kind, id, blend, range, parent: null,
		children: null };
}

/* The rotation of most primitives, shared by every node that has it (a
 * million-sphere mirror kept a million copies). Frozen: the model
 * replaces a node's rotate, never writes into it (applyOps). */
const IDENTITY_ROTATE = Object.freeze([0, 0, 0, 1]);

function scanPrim(s, tag, id) {
	if (tag === 0 || tag > L.PRIM_KIND_MAX) {
		s.fail('EENUM', `primitive tag 0x${tag.toString(16)} is unknown`);
	}
	const translate = s.floats(3, 'translate');
	const rotate = s.identity() ? IDENTITY_ROTATE : s.floats(4, 'rotate');
	const hasColor = s.u8('has_color');
	if (hasColor > 1) {
		s.fail('EPROTO_FLAGS', `has_color is ${hasColor}, not 0 or 1`);
	}
	const color = hasColor ? s.floats(3, 'color') : null;
	const nfloats = s.u8('nfloats');
	if (nfloats > L.MAX_PRIM_PARAMS) {
		s.fail('EPROTO_COUNT', `nfloats ${nfloats} is over ` +
			`${L.MAX_PRIM_PARAMS}`);
	}
	const params = s.floats(nfloats, 'params');
	return { isOp: false, kind: tag, id, translate, rotate, color, params,
		parent: null };
}

/* The names table after a tree of count nodes (PROTOCOL.md 8, check 6):
 * [[id, name], ...] in the table's order. */
function scanNames(s, count) {
	s.where = 'names';
	const n = s.u32('name_count');
	if (n === 0 || n > count) {
		s.fail('EPROTO_COUNT', `name_count ${n} is outside 1..${count} ` +
			'(the node count)');
	}
	if (n > Math.floor(s.left() / NAME_ENTRY_MIN)) {
		s.fail('EPROTO_COUNT', `name_count ${n} needs at least ` +
			`${n * NAME_ENTRY_MIN} bytes, ${s.left()} left`);
	}
	const out = [];
	let prev = 0;
	for (let i = 0; i < n; i++) {
		s.where = `name ${i}`;
		const id = s.u32('id');
		const len = s.u16('name length');
		if (id === 0) {
			s.fail('ERANGE', 'id 0 (a node to be numbered by the server ' +
				'cannot be named)');
		}
		if (id <= prev) {
			s.fail(id === prev ? 'EDUPID' : 'ERANGE', `id ${id} after ` +
				`${prev}: the ids must be strictly increasing`);
		}
		prev = id;
		if (len === 0 || len > L.MAX_NAME) {
			s.fail('EPROTO_LENGTH', `name length ${len} is outside ` +
				`1..${L.MAX_NAME}`);
		}
		s.need(len, 'name');
		const bad = utf8Check(s.b, s.pos, len);
		if (bad < len) {
			s.pos += bad;
			s.fail('ESTRING', `byte ${bad} of the name breaks UTF-8 or ` +
				'is NUL');
		}
		out.push([id, utf8dec.decode(s.b.subarray(s.pos, s.pos + len))]);
		s.pos += len;
	}
	s.where = null;
	return out;
}

/* Walks scene bytes, checking them, and calls visit(node) for each node in
 * pre-order when visit is given. Iterative, one pass, no recursion.
 * Returns { has_camera, camera, nodes, prims, ops, depth, names } (depth:
 * nodes on the deepest path, the root counting 1; names: the names table
 * as [[id, name], ...], null without one); throws a ProtoError. */
function walkScene(bytes, visit) {
	const s = new SceneCur(bytes);
	const out = { has_camera: false, camera: null, nodes: 0, prims: 0,
		ops: 0, depth: 0, names: null };
	const open = []; /* children still expected by each open operator */
	const flags = s.u8('flags');
	if (flags & ~SCENE_FLAG.ALL) {
		s.fail('EPROTO_FLAGS', `scene flags ${flags}`);
	}
	out.has_camera = (flags & SCENE_FLAG.CAMERA) !== 0;
	if (out.has_camera) {
		const c = s.floats(10, 'camera');
		out.camera = { eye: c.slice(0, 3), target: c.slice(3, 6),
			up: c.slice(6, 9), fov_y_deg: c[9] };
	}
	const count = s.u32('node_count');
	if (count === 0 || count > L.SCENE_MAX_NODES) {
		s.fail('EPROTO_COUNT', `node_count ${count} is outside ` +
			`1..${L.SCENE_MAX_NODES}`);
	}
	if (count > Math.floor(s.left() / NODE_MIN)) {
		s.fail('EPROTO_COUNT', `node_count ${count} needs at least ` +
			`${count * NODE_MIN} bytes, ${s.left()} left`);
	}
	for (s.node = 0; s.node < count; s.node++) {
		if (s.node > 0 && open.length === 0) {
			s.fail('EPROTO_COUNT', `the root's subtree ended after ` +
				`${s.node} of node_count ${count} nodes`);
		}
		/* This node would be number 129 on its path from the root. */
		if (open.length >= L.SCENE_MAX_DEPTH) {
			s.fail('EDEPTH', `nested deeper than ${L.SCENE_MAX_DEPTH}`);
		}
		const tag = s.u8('tag');
		const id = s.u32('id');
		if (open.length) {
			open[open.length - 1]--;
		}
		if (tag & OP_TAG) {
			const n = scanOp(s, tag, id, count - 1 - s.node);
			open.push(s.kids);
			if (visit) {
				visit(n, s.kids);
			}
			out.ops++;
			continue;
		}
		const n = scanPrim(s, tag, id);
		if (visit) {
			visit(n);
		}
		out.prims++;
		out.depth = Math.max(out.depth, open.length + 1);
		/* The last child of an operator completes it, which may
		 * complete its parent, and so on up. */
		while (open.length && open[open.length - 1] === 0) {
			open.pop();
		}
	}
	if (open.length) {
		s.fail('EPROTO_COUNT', `${open[open.length - 1]} children of an ` +
			'operator are missing after the last node');
	}
	if (flags & SCENE_FLAG.NAMES) {
		out.names = scanNames(s, count);
	}
	if (s.left()) {
		s.fail('EPROTO_TRAILING', `${s.left()} bytes after the ` +
			(out.names ? 'names table' : 'last node'));
	}
	out.nodes = count;
	return out;
}

/* Checks scene bytes; returns { has_camera, nodes, prims, ops, depth },
 * and names (the names table's count) when the scene has one. */
export function scanScene(bytes) {
	const r = walkScene(bytes, null);
	const out = { has_camera: r.has_camera, nodes: r.nodes, prims: r.prims,
		ops: r.ops, depth: r.depth };
	if (r.names) {
		out.names = r.names.length;
	}
	return out;
}

/* Builds a tree from scene bytes (checked as scanScene does): returns
 * { camera, root, byId } where every node has parent and, for operators,
 * children, and a named node its name. Node ids of 0 are kept (a subtree
 * may leave ids to the server) but are not indexed. A name for an id no
 * node has (or only a node of id 0) is ENONODE. Throws a ProtoError. */
export function parseScene(bytes) {
	const byId = new Map();
	let root = null;
	/* Open operators, each with the index of its next child. Nodes come
	 * in their final shape (scanPrim, scanOp) and each operator's
	 * children array at its size, so that a million-node mirror is not
	 * reshaped or regrown node by node. */
	const stack = [];
	const info = walkScene(bytes, (n, kids) => {
		if (stack.length) {
			const top = stack[stack.length - 1];
			n.parent = top.op;
			top.op.children[top.next++] = n;
		} else {
			root = n;
		}
		if (n.id) {
			byId.set(n.id, n);
		}
		if (n.isOp) {
			n.children = new Array(kids);
			stack.push({ op: n, next: 0 });
		}
		while (stack.length && stack[stack.length - 1].next ===
			stack[stack.length - 1].op.children.length) {
			stack.pop();
		}
	});
	for (const [id, name] of info.names ?? []) {
		const n = byId.get(id);
		if (!n) {
			throw new ProtoError('ENONODE', `scene: the names table names ` +
				`node ${id}, which the scene does not have`);
		}
		n.name = name;
	}
	return { camera: info.camera, root, byId };
}

/* Encodes a tree ({ camera?, root }, nodes shaped as parseScene makes them)
 * back to scene bytes, with the names table when a node has a name (a
 * non-empty n.name); the result is checked with scanScene. A name on a
 * node of id 0 is ENONODE, as the decoder would have it. */
export function encodeScene({ camera = null, root }) {
	const w = new Enc();
	w.u8('flags', camera ? SCENE_FLAG.CAMERA : 0);
	if (camera) {
		w.f32v('camera.eye', camera.eye, 3);
		w.f32v('camera.target', camera.target, 3);
		w.f32v('camera.up', camera.up, 3);
		w.f32('camera.fov_y_deg', camera.fov_y_deg);
	}
	const countAt = w.n;
	w.u32('node_count', 0);
	let count = 0;
	const named = [];
	const todo = [root];
	while (todo.length) {
		const n = todo.pop();
		count++;
		if (n.name) {
			if (!n.id) {
				throw new ProtoError('ENONODE', `encode: a node of id 0 ` +
					`is named "${n.name}"; only numbered nodes take names`);
			}
			named.push(n);
		}
		if (n.isOp && n.kind >= L.OP_KIND_FIRST_UNARY) {
			w.u8('tag', OP_TAG | n.kind, 'EENUM');
			w.u32('id', n.id);
			w.u8('nfloats', n.params.length, 'EPROTO_COUNT');
			w.f32v('params', n.params, n.params.length);
			todo.push(n.children[0]);
			continue;
		}
		if (n.isOp) {
			w.u8('tag', OP_TAG | n.kind, 'EENUM');
			w.u32('id', n.id);
			w.f32('blend', n.blend);
			w.f32('range', n.range);
			w.u32('child_count', n.children.length);
			for (let i = n.children.length - 1; i >= 0; i--) {
				todo.push(n.children[i]);
			}
			continue;
		}
		w.u8('tag', n.kind, 'EENUM');
		w.u32('id', n.id);
		w.f32v('translate', n.translate, 3);
		w.f32v('rotate', n.rotate, 4);
		w.u8('has_color', n.color ? 1 : 0);
		if (n.color) {
			w.f32v('color', n.color, 3);
		}
		w.u8('nfloats', n.params.length, 'EPROTO_COUNT');
		w.f32v('params', n.params, n.params.length);
	}
	w.dv.setUint32(countAt, count, true);
	if (named.length) {
		w.b[0] |= SCENE_FLAG.NAMES;
		named.sort((a, b) => a.id - b.id);
		w.u32('name_count', named.length);
		for (const n of named) {
			w.u32('id', n.id);
			w.str('name', n.name);
		}
	}
	const out = w.bytes();
	scanScene(out);
	return out;
}

/* ---- Binary scene files ------------------------------------------------------- */

let crcTable = null;

/* zlib's CRC-32 (the one gzip and PNG use) of bytes. */
export function crc32(bytes) {
	if (!crcTable) {
		crcTable = new Uint32Array(256);
		for (let i = 0; i < 256; i++) {
			let c = i;
			for (let k = 0; k < 8; k++) {
				c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
			}
			crcTable[i] = c >>> 0;
		}
	}
	let c = 0xffffffff;
	for (let i = 0; i < bytes.length; i++) {
		c = crcTable[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
	}
	return (c ^ 0xffffffff) >>> 0;
}

/* A binary scene file of a tree (docs/scene-format.md, "Binary scene
 * file"): "BCS1", the length and CRC-32 of the scene bytes, then
 * encodeScene's bytes, as `blobcast scene --binary` writes them. */
export function encodeSceneFile(scene) {
	const body = encodeScene(scene);
	const out = new Uint8Array(12 + body.length);
	const dv = new DataView(out.buffer);
	out.set([0x42, 0x43, 0x53, 0x31], 0);
	dv.setUint32(4, body.length, true);
	dv.setUint32(8, crc32(body), true);
	out.set(body, 12);
	return out;
}

/* ---- Applying edits to a parsed scene ----------------------------------------- */

/* Applies the operations of an EDIT_APPLIED (SET, INSERT, REMOVE, REPLACE,
 * NAME) to a tree from parseScene, the way the server applied them, so a client's model follows the session
 * without a new SCENE_STATE. layout(kind) gives a primitive kind's
 * parameters as [{ offset, count }] in field order (docs/primitives.md), or
 * null when the kind is unknown: a parameter edit of such a node marks it
 * stale instead. Returns the ids of the nodes touched. Throws ProtoError
 * ENONODE for an id the tree lacks (the caller then holds a stale model). */
export function applyOps(scene, ops, layout = () => null) {
	const touched = [];
	const get = (id) => {
		const n = scene.byId.get(id);
		if (!n) {
			throw new ProtoError('ENONODE', `no node with id ${id}`);
		}
		return n;
	};
	const forget = (n) => {
		const todo = [n];
		while (todo.length) {
			const k = todo.pop();
			if (k.id && scene.byId.get(k.id) === k) {
				scene.byId.delete(k.id);
			}
			if (k.isOp) {
				todo.push(...k.children);
			}
		}
	};
	const adopt = (sub, parent) => {
		const t = parseScene(sub);
		t.root.parent = parent;
		for (const [id, n] of t.byId) {
			scene.byId.set(id, n);
		}
		return t.root;
	};
	for (const op of ops) {
		switch (op.kind) {
		case EDIT.SET: {
			const n = get(op.node);
			for (const f of op.fields) {
				setField(n, f, layout);
			}
			touched.push(op.node);
			break;
		}
		case EDIT.INSERT: {
			const p = get(op.parent);
			if (!p.isOp) {
				throw new ProtoError('EINVAL',
					`node ${op.parent} is not an operator`);
			}
			const pos = Math.min(op.position, p.children.length);
			p.children.splice(pos, 0, adopt(op.subtree, p));
			touched.push(op.parent);
			break;
		}
		case EDIT.REMOVE: {
			let n = get(op.node);
			/* A unary node goes with its only child (and a chain
			 * of unary nodes above it). */
			while (n.parent && n.parent.unary) {
				n = n.parent;
			}
			const p = n.parent;
			if (p) {
				p.children.splice(p.children.indexOf(n), 1);
			} else {
				scene.root = null;
			}
			forget(n);
			/* An operator left with one child is replaced by that
			 * child, as blobtree does (bc_tree_remove). */
			if (p && p.children.length === 1) {
				const only = p.children[0];
				only.parent = p.parent;
				if (p.parent) {
					p.parent.children[
						p.parent.children.indexOf(p)] = only;
				} else {
					scene.root = only;
				}
				if (scene.byId.get(p.id) === p) {
					scene.byId.delete(p.id);
				}
			}
			touched.push(op.node);
			break;
		}
		case EDIT.REPLACE: {
			const n = get(op.node);
			/* Forget first: the new subtree may reuse the old ids. */
			forget(n);
			const r = adopt(op.subtree, n.parent);
			if (n.parent) {
				n.parent.children[n.parent.children.indexOf(n)] = r;
			} else {
				scene.root = r;
			}
			touched.push(op.node);
			break;
		}
		case EDIT.NAME: {
			/* Names live on the nodes: a REMOVE takes them along, a
			 * subtree brings its own (parseScene). */
			const n = get(op.node);
			if (op.name) {
				n.name = op.name;
			} else {
				delete n.name;
			}
			touched.push(op.node);
			break;
		}
		default:
			throw new ProtoError('EENUM', `op kind ${op.kind}`);
		}
	}
	return touched;
}

/* Parameters a unary kind starts from (blobtree's bc_unary_init). */
const UNARY_DEFAULTS = Object.freeze({
	7: [0.1], 8: [0.05], 9: [0.5, 0, 0], 10: [1], 11: [0.5], 12: [1],
	13: [2, 2, 2, 3, 1, 1], 14: [1],
});

function setField(n, f, layout) {
	const v = f.values;
	switch (f.field) {
	case FIELD.TRANSLATE:
		n.translate = v.slice();
		return;
	case FIELD.ROTATE:
		n.rotate = v.slice();
		return;
	case FIELD.COLOR:
		n.color = v.slice();
		return;
	case FIELD.BLEND:
		n.blend = v[0];
		return;
	case FIELD.RANGE:
		n.range = v[0];
		return;
	case FIELD.OP_KIND:
		if (n.unary && v[0] !== n.kind) {
			/* A new unary kind starts from its defaults. */
			n.params = (UNARY_DEFAULTS[v[0]] || []).slice();
		}
		n.kind = v[0];
		return;
	default: {
		if (n.unary) {
			/* PARAM0 the kind's parameter (repeat: spacing, then
			 * PARAM0 + 1 count, 3 each). */
			const k = f.field - FIELD.PARAM0;
			const at = n.kind === 13 ? 3 * k : 0;
			if ((n.kind === 13 ? k > 1 : k !== 0) ||
				at + v.length > n.params.length) {
				n.stale = true;
				return;
			}
			for (let i = 0; i < v.length; i++) {
				n.params[at + i] = v[i];
			}
			return;
		}
		const params = n.isOp ? null : layout(n.kind);
		const p = params ? params[f.field - FIELD.PARAM0] : null;
		if (!p || p.count !== v.length) {
			n.stale = true;
			return;
		}
		for (let i = 0; i < p.count; i++) {
			n.params[p.offset + i] = v[i];
		}
	}
	}
}
