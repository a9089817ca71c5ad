/*
 * Big pictures from the page: a lossless picture up to 8192 × 8192 of the
 * page's camera, asked for tile by tile with SNAPSHOT's tile form
 * (PROTOCOL.md 7.17, feature TILES), each tile a PNG that fits any frame
 * limit, drawn into one canvas and saved as a PNG download. Every tile
 * must show the same scene: tiles rendered before an edit that later tiles
 * show are asked for again, as libblobcast's bc_client_snapshot_big does.
 */
import * as P from './protocol.js';

/* Tile edge: 1024² PNGs are short jobs for the daemon and small frames. */
export const TILE = 1024;
/* Tiles asked for at once: the daemon renders one while we decode one. */
const IN_FLIGHT = 2;
/* Rounds of asking again for tiles an edit overtook. */
const MAX_ROUNDS = 4;

export class Picture {
	/* send(type, fields) sends a message and returns its seq; progress(
	 * done, total) is called after each tile. */
	constructor({ width, height, tile = TILE, send, progress }) {
		this.width = width;
		this.height = height;
		this.tile = Math.max(8, tile - (tile % 8));
		this.send = send;
		this.progress = progress ?? (() => {});
		this.across = Math.ceil(width / this.tile);
		this.down = Math.ceil(height / this.tile);
		this.total = this.across * this.down;
		this.canvas = document.createElement('canvas');
		this.canvas.width = width;
		this.canvas.height = height;
		this.ctx = this.canvas.getContext('2d');
		this.state = new Uint8Array(this.total); /* 0 ask, 1 asked, 2 here */
		this.order = new Array(this.total).fill(0n);
		this.seqs = new Map(); /* seq -> tile */
		this.arrived = 0;
		this.rounds = 0;
		this.busy = 0;
	}

	/* Resolves with { canvas, order } once every tile shows one scene. */
	start() {
		return new Promise((resolve, reject) => {
			this.resolve = resolve;
			this.reject = reject;
			this.fill();
		});
	}

	tileRect(k) {
		const x = (k % this.across) * this.tile;
		const y = Math.floor(k / this.across) * this.tile;
		return { x, y, w: Math.min(this.tile, this.width - x),
			h: Math.min(this.tile, this.height - y) };
	}

	fill() {
		for (let k = 0; k < this.total && this.busy < IN_FLIGHT; k++) {
			if (this.state[k] !== 0) {
				continue;
			}
			const r = this.tileRect(k);
			const seq = this.send(P.MSG.SNAPSHOT, { encoding: P.ENC.PNG,
				planes: 0, full_width: this.width,
				full_height: this.height, tile_x: r.x, tile_y: r.y,
				tile_width: r.w, tile_height: r.h });
			if (!seq) {
				this.fail('the connection is closed');
				return;
			}
			this.state[k] = 1;
			this.seqs.set(seq, k);
			this.busy++;
		}
	}

	fail(text) {
		this.seqs.clear();
		if (this.reject) {
			this.reject(new Error(text));
			this.reject = null;
		}
	}

	/* Takes the answers to our SNAPSHOTs (FRAME or ERROR with their
	 * seq); returns whether m was one. */
	handle(m) {
		const k = this.seqs.get(m.seq);
		if (m.seq === 0 || k === undefined) {
			return false;
		}
		this.seqs.delete(m.seq);
		if (m.type === P.MSG.ERROR) {
			this.fail(`${P.errName(m.code)}: ${m.text}`);
			return true;
		}
		if (m.type !== P.MSG.FRAME) {
			return false;
		}
		this.place(k, m).catch((e) => this.fail(`a tile did not decode ` +
			`(${e.message})`));
		return true;
	}

	async place(k, m) {
		const r = this.tileRect(k);
		const rect = m.rects[0];
		if (m.width !== r.w || m.height !== r.h || rect.w !== r.w ||
			rect.h !== r.h) {
			throw new Error(`tile ${k} came as ${m.width}x${m.height}`);
		}
		const bmp = await createImageBitmap(new Blob([rect.data],
			{ type: 'image/png' }), { premultiplyAlpha: 'none',
			colorSpaceConversion: 'none' });
		this.ctx.drawImage(bmp, r.x, r.y);
		bmp.close();
		this.state[k] = 2;
		this.order[k] = BigInt(m.order);
		this.arrived++;
		this.busy--;
		this.progress(this.arrived, this.total);
		if (this.arrived < this.total) {
			this.fill();
			return;
		}
		/* Every tile is here: those older than the newest are asked
		 * for again. */
		const newest = this.order.reduce((a, b) => (b > a ? b : a), 0n);
		let again = 0;
		this.order.forEach((o, i) => {
			if (o !== newest) {
				this.state[i] = 0;
				this.arrived--;
				again++;
			}
		});
		if (!again) {
			this.resolve?.({ canvas: this.canvas, order: newest });
			return;
		}
		if (++this.rounds >= MAX_ROUNDS) {
			this.fail('the scene kept changing while the tiles were ' +
				'rendered; try again when edits pause');
			return;
		}
		this.fill();
	}
}

/* "WxH" -> { w, h } within 1..max each, else null. */
export function parseSize(s, max = 8192) {
	const m = /^\s*(\d{1,5})\s*[x×]\s*(\d{1,5})\s*$/.exec(s ?? '');
	if (!m) {
		return null;
	}
	const w = Number(m[1]), h = Number(m[2]);
	return w >= 1 && h >= 1 && w <= max && h <= max ? { w, h } : null;
}
