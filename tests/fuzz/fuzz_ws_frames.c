/*
 * libFuzzer harness for the WebSocket frame parser libblobcast runs on
 * what a ws:// or wss:// server sends (client/lib/ws_frames.c). The first
 * two bytes pick how the rest is cut into calls and how much output room
 * each call gets. Oracles besides the sanitizers: the payload bytes, the
 * control events and the refusal are the same whole as cut, and never
 * more payload than input.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../client/lib/ws_frames.c"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

struct result {
	uint8_t *out;
	size_t len;
	int events[64];
	size_t at[64]; /* payload length when each event came */
	size_t nev;
	const char *err;
};

static void die(const char *why)
{
	fprintf(stderr, "fuzz_ws_frames: %s\n", why);
	abort();
}

static void run(const uint8_t *d, size_t n, size_t chunk, size_t cap,
                struct result *res)
{
	struct bc_ws_rx r;
	size_t pos = 0;
	memset(&r, 0, sizeof(r));
	res->len = 0;
	res->nev = 0;
	res->err = NULL;
	while (pos < n) {
		size_t len = n - pos < chunk ? n - pos : chunk, off = 0;
		while (off < len) {
			size_t used, prod;
			size_t room = n - res->len < cap ? n - res->len : cap;
			enum bc_ws_event ev;
			int rc = bc_ws_rx_feed(&r, d + pos + off, len - off,
			                       &used, res->out + res->len, room,
			                       &prod, &ev);
			if (used > len - off || prod > room ||
			    r.ctl_len > sizeof(r.ctl)) {
				die("counts out of range");
			}
			res->len += prod;
			off += used;
			if (rc) {
				if (!r.err) {
					die("a refusal without a reason");
				}
				res->err = r.err;
				return;
			}
			if (ev != BC_WS_NONE && res->nev < 64) {
				res->events[res->nev] = (int)ev;
				res->at[res->nev++] = res->len;
			}
			if (r.closed) {
				return;
			}
			if (used == 0 && prod == 0 && ev == BC_WS_NONE) {
				if (room == 0) {
					die("no room although payload <= "
					    "input");
				}
				die("no progress");
			}
		}
		pos += len;
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct result whole, cut;
	size_t chunk, cap;
	if (size < 2) {
		return 0;
	}
	chunk = (size_t)data[0] % 17 + 1;
	cap = (size_t)data[1] % 33 + 1;
	data += 2;
	size -= 2;
	whole.out = malloc(size + 1);
	cut.out = malloc(size + 1);
	if (!whole.out || !cut.out) {
		die("out of memory");
	}
	run(data, size, size ? size : 1, size + 1, &whole);
	run(data, size, chunk, cap, &cut);
	if (whole.len != cut.len || memcmp(whole.out, cut.out, whole.len) ||
	    whole.nev != cut.nev ||
	    memcmp(whole.events, cut.events,
	           whole.nev * sizeof(whole.events[0])) ||
	    memcmp(whole.at, cut.at, whole.nev * sizeof(whole.at[0])) ||
	    (whole.err == NULL) != (cut.err == NULL) ||
	    (whole.err && strcmp(whole.err, cut.err) != 0)) {
		die("whole and cut parses differ");
	}
	if (whole.len > size) {
		die("more payload than input");
	}
	free(whole.out);
	free(cut.out);
	return 0;
}
