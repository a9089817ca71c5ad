/*
 * Big snapshots: a picture up to BC_PROTO_MAX_DIM square asked for tile by
 * tile with SNAPSHOT's tile form (PROTOCOL.md 7.17), a few tiles in flight
 * so that the server renders one while the client decodes another, and
 * assembled into one image. Every tile must show the same scene (edit
 * order) from the same camera: a tile rendered before an edit that others
 * show is asked for again.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "client_impl.h"

/* Tiles in flight at most (the server queues up to 8 requests a client). */
#define BIG_MAX_IN_FLIGHT 4u
/* Rounds of asking again for tiles an edit overtook. */
#define BIG_MAX_ROUNDS 4

struct big {
	struct bc_client *c;
	const struct bc_client_big_opts *o;
	struct bc_client_image *out;
	uint32_t tile, across, down, total;
	uint8_t *state;   /* per tile: 0 to ask, 1 asked, 2 arrived */
	uint32_t *seq;    /* per tile, while asked */
	uint64_t *order;  /* per tile, once arrived */
	uint32_t *camera; /* per tile, once arrived */
	uint32_t arrived, asked;
};

static int ask(struct big *b, uint32_t k, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	uint32_t tx = (k % b->across) * b->tile, ty = (k / b->across) * b->tile;
	int rc;
	m.snapshot.encoding = b->o->encoding;
	m.snapshot.planes = (uint8_t)b->o->planes;
	m.snapshot.has_tile = true;
	m.snapshot.full_width = (uint16_t)b->o->width;
	m.snapshot.full_height = (uint16_t)b->o->height;
	m.snapshot.tile_x = (uint16_t)tx;
	m.snapshot.tile_y = (uint16_t)ty;
	m.snapshot.tile_width =
	    (uint16_t)(b->o->width - tx < b->tile ? b->o->width - tx : b->tile);
	m.snapshot.tile_height =
	    (uint16_t)(b->o->height - ty < b->tile ? b->o->height - ty
	                                           : b->tile);
	b->state[k] = 1;
	b->asked++;
	if ((rc = bc_client_send(b->c, &m, &b->seq[k])) &&
	    !bc_client_error(b->c, ei)) {
		/* Not sticky: the encoder refused the message. */
		return bc_errinfo_set(ei, rc, "cannot encode SNAPSHOT");
	}
	return rc;
}

/* Copies the decoded tile k into the picture. */
static void place(struct big *b, uint32_t k, const struct bc_client_image *t)
{
	struct bc_client_image *out = b->out;
	size_t x0 = (k % b->across) * b->tile, y0 = (k / b->across) * b->tile;
	for (uint32_t y = 0; y < t->height; y++) {
		size_t at = (y0 + y) * out->width + x0,
		       from = (size_t)y * t->width;
		memcpy(out->rgba + 4 * at, t->rgba + 4 * from,
		       4 * (size_t)t->width);
		if (out->depth && t->depth) {
			memcpy(out->depth + at, t->depth + from,
			       sizeof(float) * t->width);
		}
		if (out->ids && t->ids) {
			memcpy(out->ids + at, t->ids + from,
			       sizeof(uint32_t) * t->width);
		}
	}
}

/* Receives one answer: a tile placed (or an error). */
static int receive(struct big *b, struct bc_client_image *t,
                   struct bc_errinfo *ei)
{
	struct bc_msg m;
	uint32_t k;
	int rc;
	for (;;) {
		int got = bc_client_recv(b->c, &m,
		                         b->o->timeout_ms ? b->o->timeout_ms
		                                          : b->c->timeout_ms);
		if (got < 0) {
			return bc_client_error(b->c, ei);
		}
		if (got == 0) {
			return bc_errinfo_set(
			    ei, BC_ETIMEOUT,
			    "no tile from the server in time (%u of %u "
			    "arrived); a longer --timeout gives it more",
			    b->arrived, b->total);
		}
		for (k = 0; k < b->total; k++) {
			if (b->state[k] == 1 && b->seq[k] == m.seq) {
				break;
			}
		}
		if (k == b->total || m.seq == 0) {
			continue; /* stream frames, broadcasts */
		}
		if (m.type == BC_MSG_ERROR) {
			return bc_errinfo_set(
			    ei, m.error.code ? -(int)m.error.code : BC_EINVAL,
			    "%.*s", (int)m.error.text.len, m.error.text.ptr);
		}
		if (m.type == BC_MSG_FRAME &&
		    (m.flags & BC_PROTO_FLAG_SNAPSHOT)) {
			break;
		}
	}
	bc_client_image_finish(t);
	bc_client_image_init(t);
	if ((rc = bc_client_image_apply(t, &m, ei))) {
		return rc;
	}
	if (((b->o->planes & BC_PROTO_PLANE_DEPTH) && !t->depth) ||
	    ((b->o->planes & BC_PROTO_PLANE_IDS) && !t->ids)) {
		return bc_errinfo_set(ei, BC_EIO,
		                      "a tile lacks a plane asked for");
	}
	{
		uint32_t tx = (k % b->across) * b->tile,
		         ty = (k / b->across) * b->tile;
		uint32_t w =
		    b->o->width - tx < b->tile ? b->o->width - tx : b->tile;
		uint32_t h =
		    b->o->height - ty < b->tile ? b->o->height - ty : b->tile;
		if (!t->complete || t->width != w || t->height != h) {
			return bc_errinfo_set(
			    ei, BC_EIO, "tile %u came as %ux%u, not %ux%u", k,
			    t->width, t->height, w, h);
		}
	}
	place(b, k, t);
	b->state[k] = 2;
	b->order[k] = m.frame.order;
	b->camera[k] = m.frame.camera_seq;
	b->out->flags |= m.flags & BC_PROTO_FLAG_INCOMPLETE;
	b->out->frame_no = m.frame.frame_no;
	b->arrived++;
	if (b->o->progress) {
		b->o->progress(b->o->ud, b->arrived, b->total);
	}
	return 0;
}

/* Tiles that show an older scene than the newest tile are asked for
 * again. Returns how many. */
static uint32_t overtaken(struct big *b)
{
	uint64_t newest = 0;
	uint32_t n = 0;
	for (uint32_t k = 0; k < b->total; k++) {
		newest = b->order[k] > newest ? b->order[k] : newest;
	}
	for (uint32_t k = 0; k < b->total; k++) {
		if (b->order[k] != newest) {
			b->state[k] = 0;
			b->arrived--;
			n++;
		}
	}
	b->out->order = newest;
	return n;
}

static int alloc_picture(struct big *b)
{
	struct bc_client_image *out = b->out;
	size_t n = (size_t)b->o->width * b->o->height;
	bc_client_image_finish(out);
	bc_client_image_init(out);
	out->width = out->view_width = b->o->width;
	out->height = out->view_height = b->o->height;
	if (!(out->rgba = bc_malloc(4 * n)) ||
	    ((b->o->planes & BC_PROTO_PLANE_DEPTH) &&
	     !(out->depth = bc_malloc(n * sizeof(float)))) ||
	    ((b->o->planes & BC_PROTO_PLANE_IDS) &&
	     !(out->ids = bc_malloc(n * sizeof(uint32_t))))) {
		return BC_ENOMEM;
	}
	out->flags = BC_PROTO_FLAG_SNAPSHOT | BC_PROTO_FLAG_STILL;
	out->encoding = b->o->encoding;
	return 0;
}

static int check_opts(const struct bc_client *c,
                      const struct bc_client_big_opts *o, uint32_t *tile,
                      struct bc_errinfo *ei)
{
	uint32_t max = c->info.max_dim;
	if (!(c->info.features & BC_PROTO_FEATURE_TILES)) {
		return bc_errinfo_set(
		    ei, BC_ENOTSUP,
		    "the server does not take snapshots in tiles (it did not "
		    "grant TILES); it serves snapshots up to its VIEW size, "
		    "%ux%u",
		    max, max);
	}
	if (o->width < 1 || o->height < 1 || o->width > BC_PROTO_MAX_DIM ||
	    o->height > BC_PROTO_MAX_DIM) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "a picture is 1..%u pixels each way, not "
		                      "%ux%u",
		                      BC_PROTO_MAX_DIM, o->width, o->height);
	}
	if (o->encoding != BC_PROTO_ENC_PNG &&
	    o->encoding != BC_PROTO_ENC_RAW) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "snapshots are PNG or raw");
	}
	if (o->planes & ~BC_PROTO_PLANES_ALL) {
		return bc_errinfo_set(ei, BC_EINVAL, "planes 0x%x", o->planes);
	}
	*tile = o->tile ? o->tile : BC_CLIENT_BIG_TILE;
	if (*tile > max) {
		*tile = max;
	}
	/* Origins on the renderers' 8-pixel grid render exactly as the
	 * whole picture would (PROTOCOL.md 7.17). */
	if (*tile >= 8) {
		*tile &= ~7u;
	}
	if (*tile == 0) {
		return bc_errinfo_set(ei, BC_ERANGE, "tile edge 0");
	}
	return 0;
}

int bc_client_snapshot_big(struct bc_client *c,
                           const struct bc_client_big_opts *opts,
                           struct bc_client_image *out, struct bc_errinfo *ei)
{
	struct bc_client_big_opts o = *opts;
	struct bc_client_image t;
	struct big b = {.c = c, .o = &o, .out = out};
	uint32_t in_flight, tile;
	int rc, round = 0;
	if (o.encoding == BC_PROTO_ENC_INVALID) {
		o.encoding = BC_PROTO_ENC_PNG;
	}
	if ((rc = check_opts(c, &o, &tile, ei))) {
		return rc;
	}
	in_flight = o.in_flight ? o.in_flight : 2u;
	if (in_flight > BIG_MAX_IN_FLIGHT) {
		in_flight = BIG_MAX_IN_FLIGHT;
	}
	b.tile = tile;
	b.across = (o.width + tile - 1) / tile;
	b.down = (o.height + tile - 1) / tile;
	b.total = b.across * b.down;
	bc_client_image_init(&t);
	if (!(b.state = bc_calloc(b.total, 1)) ||
	    !(b.seq = bc_calloc(b.total, sizeof(*b.seq))) ||
	    !(b.order = bc_calloc(b.total, sizeof(*b.order))) ||
	    !(b.camera = bc_calloc(b.total, sizeof(*b.camera))) ||
	    alloc_picture(&b)) {
		rc = bc_errinfo_set(ei, BC_ENOMEM,
		                    "no memory for a %ux%u picture", o.width,
		                    o.height);
		goto out;
	}
	for (;;) {
		uint32_t next = 0, busy = 0;
		while (b.arrived < b.total) {
			for (; busy < in_flight && next < b.total; next++) {
				if (b.state[next] == 0) {
					if ((rc = ask(&b, next, ei))) {
						goto out;
					}
					busy++;
				}
			}
			if ((rc = receive(&b, &t, ei))) {
				goto out;
			}
			busy--;
		}
		if (!overtaken(&b)) {
			break;
		}
		if (++round >= BIG_MAX_ROUNDS) {
			rc = bc_errinfo_set(
			    ei, BC_EBUSY,
			    "the scene kept changing while the tiles were "
			    "rendered (%d rounds); try again when edits pause",
			    round);
			goto out;
		}
	}
	for (uint32_t k = 1; k < b.total; k++) {
		if (b.camera[k] != b.camera[0]) {
			rc =
			    bc_errinfo_set(ei, BC_EBUSY,
			                   "the camera changed while the tiles "
			                   "were rendered; try again");
			goto out;
		}
	}
	out->camera_seq = b.camera[0];
	out->complete = true;
	rc = 0;
out:
	bc_client_image_finish(&t);
	bc_free(b.state);
	bc_free(b.seq);
	bc_free(b.order);
	bc_free(b.camera);
	return rc;
}
