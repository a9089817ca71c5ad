/*
 * The browser's side of test_cluster: for each session named, opens the
 * WebSocket the page opens (wss://127.0.0.1:PORT/blobcast?session=NAME,
 * subprotocol "binary") and says HELLO with the page's own codec
 * (client/web/protocol.js), then prints "NAME SERVER_ID" from the WELCOME:
 * which daemon the front door routed the page to. Needs a WebSocket global
 * (node >= 22, or node 20 with --experimental-websocket) and the demo's
 * CA in NODE_EXTRA_CA_CERTS.
 *
 *   node --experimental-websocket browser_route.mjs PORT NAME...
 */
import * as P from '../../client/web/protocol.js';

const [port, ...names] = process.argv.slice(2);

function route(name) {
	return new Promise((resolve, reject) => {
		const url = `wss://127.0.0.1:${port}/blobcast?session=` +
			encodeURIComponent(name);
		const ws = new WebSocket(url, ['binary']);
		const reader = new P.Reader({ side: 'client' });
		const timer = setTimeout(() => {
			ws.close();
			reject(new Error(`${name}: no WELCOME within 10 s`));
		}, 10000);
		ws.binaryType = 'arraybuffer';
		ws.onopen = () => ws.send(P.encode({
			type: P.MSG.HELLO, seq: 1, version_min: 1, version_max: 1,
			encodings: P.ENCODINGS_ALL, max_frame_bytes: 0,
			client_name: 'browser-route', token: '' }));
		ws.onmessage = (ev) => {
			reader.feed(new Uint8Array(ev.data));
			for (let m = reader.next(); m; m = reader.next()) {
				if (m.type === P.MSG.WELCOME) {
					clearTimeout(timer);
					ws.close();
					resolve(m.server_id);
					return;
				}
			}
		};
		ws.onerror = (ev) => {
			clearTimeout(timer);
			reject(new Error(`${name}: ${ev.message || 'WebSocket error'}`));
		};
	});
}

for (const name of names) {
	console.log(`${name} ${await route(name)}`);
}
