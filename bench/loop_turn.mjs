/*
 * Prints the longest event-loop turn of a blobcastd since the last time
 * this asked (STATS's load section, PROTOCOL.md 7.18: GET_STATS with LOAD
 * and RESET), in milliseconds, then closes. For the shell benches.
 *
 *   node bench/loop_turn.mjs unix:PATH | HOST:PORT
 */
import net from 'node:net';
import * as P from '../client/web/protocol.js';

const addr = process.argv[2] ?? '';
const m = /^unix:(.+)$/.exec(addr) ?? /^(.+):(\d+)$/.exec(addr);
if (!m) {
	console.error('usage: node bench/loop_turn.mjs unix:PATH | HOST:PORT');
	process.exit(2);
}
const s = addr.startsWith('unix:') ? net.createConnection(m[1])
	: net.createConnection(Number(m[2]), m[1]);
const r = new P.Reader({ side: 'client' });
let seq = 0;
const send = (type, f) => s.write(P.encode({ ...f, type, flags: 0,
	seq: ++seq }));
const fail = (text) => {
	console.error(`loop_turn: ${text}`);
	process.exit(1);
};
setTimeout(() => fail('no answer in 30 s'), 30000).unref();
s.on('error', (e) => fail(e.message));
s.on('connect', () => send(P.MSG.HELLO, { version_min: 1, version_max: 1,
	encodings: 0, max_frame_bytes: 0, client_name: 'loop_turn',
	token: process.env.BLOBCAST_TOKEN ?? '', features: 0 }));
s.on('data', (d) => {
	r.feed(new Uint8Array(d));
	for (let msg; (msg = r.next());) {
		if (msg.type === P.MSG.WELCOME) {
			send(P.MSG.GET_STATS, { parts: P.STATS_PARTS.LOAD |
				P.STATS_PARTS.RESET });
		} else if (msg.type === P.MSG.ERROR) {
			fail(msg.text);
		} else if (msg.type === P.MSG.STATS) {
			console.log(msg.loop_turn_max_ms.toFixed(1));
			s.end();
			process.exit(0);
		}
	}
});
