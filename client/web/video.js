/*
 * H.264 frames (PROTOCOL.md 7.15, encoding 4) through WebCodecs, and the
 * acknowledgements of frames (7.27, feature ACKS).
 *
 *  - h264Decodable(): whether this browser has VideoDecoder and it takes
 *    an H.264 stream; the page announces encoding 4 in HELLO only then.
 *  - avcCodec(): WebCodecs' codec string `avc1.PPCCLL` from the SPS of an
 *    Annex B access unit (profile_idc, the constraint flags, level_idc:
 *    the three bytes after the SPS's NAL header byte).
 *  - VideoStream: one VideoDecoder for the view's stream, configured from
 *    the first KEY frame (no `description`: the chunks stay Annex B) with
 *    optimizeForLatency. Each FRAME's access unit is one EncodedVideoChunk
 *    (type 'key' with FLAG.KEY, else 'delta'; increasing timestamps); the
 *    stream has no B-frames, so each chunk's picture comes out before the
 *    next goes in and decode() resolves once it was drawn. A delta with no
 *    KEY before it (at the start, after an error or a stuck decoder) is
 *    not fed: needKey() asks the page to send its VIEW again, which starts
 *    the stream over with a KEY. A decoder error closes the decoder and
 *    calls failed(text): the page says so and asks for JPEG.
 *  - FrameAcks: which FRAMEs of a connection are handled (drawn, skipped
 *    as moot, dropped, or a snapshot's answer taken); FRAME_ACK names the
 *    newest one below which every FRAME is handled, so an acknowledgement
 *    never runs ahead of a frame still being decoded.
 */
import * as P from './protocol.js';

/* Codec strings tried for support: High, Main and Constrained Baseline at
 * level 4.2 (1080p at 60 frames per second). */
const PROBE_CODECS = ['avc1.64002a', 'avc1.4d002a', 'avc1.42e02a'];

/* A frame whose picture has not come out of the decoder after this long
 * is given up: the decoder is reset and the stream restarted from a KEY. */
const STUCK_MS = 2000;

/* Whether this browser decodes H.264 with WebCodecs (resolves, never
 * rejects). */
export async function h264Decodable() {
	if (typeof globalThis.VideoDecoder !== 'function' ||
		typeof globalThis.EncodedVideoChunk !== 'function') {
		return false;
	}
	for (const codec of PROBE_CODECS) {
		try {
			const r = await globalThis.VideoDecoder.isConfigSupported({
				codec, optimizeForLatency: true });
			if (r.supported) {
				return true;
			}
		} catch {
			/* A browser that throws for a string does not take it. */
		}
	}
	return false;
}

const hex2 = (b) => b.toString(16).padStart(2, '0');

/* 'avc1.PPCCLL' from the first SPS (NAL type 7) of an Annex B access unit
 * (a Uint8Array), or null when it has none. */
export function avcCodec(data) {
	for (let i = 0; i + 2 < data.length; i++) {
		if (data[i] !== 0 || data[i + 1] !== 0 || data[i + 2] !== 1) {
			continue;
		}
		const h = i + 3; /* the NAL header byte */
		if (h + 3 < data.length && (data[h] & 0x1f) === 7) {
			return `avc1.${hex2(data[h + 1])}${hex2(data[h + 2])}` +
				`${hex2(data[h + 3])}`;
		}
		i = h - 1;
	}
	return null;
}

export class VideoStream {
	/* needKey(): send the VIEW again (the stream restarts with a KEY);
	 * failed(text): the decoder broke, the page goes back to images. */
	constructor({ needKey, failed }) {
		this.needKey = needKey;
		this.failed = failed;
		this.decoder = null;
		this.codec = '';
		this.keyWanted = true;
		this.ts = 0;
		this.pending = null; /* { resolve, draw, timer } */
		this.error = '';
		this.counts = { chunks: 0, keys: 0, drawn: 0, dropped: 0,
			keyAsks: 0, errors: 0, stuck: 0 };
	}

	/* What the page shows of the decoder, for tests and the console. */
	state() {
		return { ...this.counts, codec: this.codec, error: this.error,
			decoder: this.decoder ? this.decoder.state : 'none' };
	}

	/* Decodes m, an encoding-4 FRAME, and calls draw(videoFrame) with its
	 * picture (the frame is closed after); resolves with true once drawn,
	 * false when dropped. Never rejects. */
	decode(m, draw) {
		const data = m.rects[0].data;
		const key = (m.flags & P.FLAG.KEY) !== 0;
		if (key) {
			const codec = avcCodec(data);
			if (!codec) {
				return Promise.resolve(this.broke('a KEY frame without ' +
					'a sequence parameter set'));
			}
			if (!this.configure(codec)) {
				return Promise.resolve(false);
			}
			this.keyWanted = false;
			this.counts.keys++;
		} else if (this.keyWanted || this.decoder?.state !== 'configured') {
			/* The decoder cannot start here: ask for a KEY instead. */
			this.keyWanted = true;
			this.counts.dropped++;
			this.counts.keyAsks++;
			this.needKey();
			return Promise.resolve(false);
		}
		return new Promise((resolve) => {
			const timer = setTimeout(() => this.stuck(), STUCK_MS);
			this.pending = { resolve, draw, timer };
			try {
				this.decoder.decode(new EncodedVideoChunk({
					type: key ? 'key' : 'delta', timestamp: this.ts, data }));
				this.ts += 1000;
				this.counts.chunks++;
			} catch (e) {
				this.broke(`${e.name}: ${e.message}`);
			}
		});
	}

	/* A decoder for codec, made or configured anew when needed; false
	 * when that failed (said through failed()). */
	configure(codec) {
		if (this.decoder && this.decoder.state === 'configured' &&
			codec === this.codec) {
			return true;
		}
		try {
			if (!this.decoder || this.decoder.state === 'closed') {
				const d = new VideoDecoder({
					output: (f) => this.output(f),
					error: (e) => {
						if (this.decoder === d) {
							this.broke(`${e.name}: ${e.message}`);
						}
					},
				});
				this.decoder = d;
			}
			/* No description: the chunks are Annex B, SPS and PPS in
			 * band. */
			this.decoder.configure({ codec, optimizeForLatency: true });
			this.codec = codec;
			return true;
		} catch (e) {
			this.broke(`${e.name}: ${e.message} (codec ${codec})`);
			return false;
		}
	}

	output(frame) {
		const p = this.settle();
		try {
			if (p) {
				p.draw(frame);
				this.counts.drawn++;
			}
		} finally {
			frame.close();
		}
		p?.resolve(true);
	}

	/* Takes the frame waiting for its picture, or null. */
	settle() {
		const p = this.pending;
		this.pending = null;
		if (p) {
			clearTimeout(p.timer);
		}
		return p;
	}

	/* No picture came: start over from a KEY rather than wait forever
	 * (the frame counts as handled). */
	stuck() {
		const p = this.settle();
		this.counts.stuck++;
		this.counts.dropped++;
		this.keyWanted = true;
		try {
			this.decoder?.reset();
		} catch {
			/* closed already: the next KEY makes a new one */
		}
		p?.resolve(false);
		this.counts.keyAsks++;
		this.needKey();
	}

	/* The decoder failed: drop it, let the page fall back; returns
	 * false. */
	broke(text) {
		const d = this.decoder;
		this.decoder = null;
		this.codec = '';
		this.keyWanted = true;
		this.error = text;
		this.counts.errors++;
		if (d && d.state !== 'closed') {
			try {
				d.close();
			} catch {
				/* closing a decoder that is closing */
			}
		}
		const p = this.settle();
		if (p) {
			this.counts.dropped++;
			p.resolve(false);
		}
		this.failed(text);
		return false;
	}

	/* The connection is gone: the next stream starts with a KEY. */
	reset() {
		const p = this.settle();
		p?.resolve(false);
		this.keyWanted = true;
		if (this.decoder && this.decoder.state === 'configured') {
			try {
				this.decoder.reset();
			} catch {
				/* nothing to reset */
			}
		}
	}
}

/* The FRAMEs of one connection, in the order they came, until handled;
 * send(frame_no) sends FRAME_ACK. */
export class FrameAcks {
	constructor(send) {
		this.send = send;
		this.waiting = []; /* frame_no, oldest first */
		this.handled = new Set(); /* of those, the ones handled */
		this.since = new Map(); /* frame_no -> when it came (ms) */
		this.last = 0; /* the newest acknowledged */
		this.sent = 0; /* FRAME_ACKs sent */
		this.forced = 0; /* frames let go by let() */
	}

	got(frameNo, now = 0) {
		this.waiting.push(frameNo);
		this.since.set(frameNo, now);
	}

	/* Frame frameNo is handled: acknowledges what that completes. */
	done(frameNo) {
		if (!this.since.has(frameNo)) {
			return;
		}
		this.handled.add(frameNo);
		let newest = 0;
		while (this.waiting.length && this.handled.has(this.waiting[0])) {
			newest = this.waiting.shift();
			this.handled.delete(newest);
			this.since.delete(newest);
		}
		if (newest > this.last) {
			this.last = newest;
			this.sent++;
			this.send(newest);
		}
	}

	/* A frame that no part of the page has handled after ms is counted
	 * as handled, so that a lost one cannot stop the frames. */
	let(now, ms) {
		const first = this.waiting[0];
		if (first !== undefined && now - this.since.get(first) > ms) {
			this.forced++;
			this.done(first);
		}
	}

	state() {
		return { last: this.last, sent: this.sent, forced: this.forced,
			waiting: this.waiting.length };
	}
}
