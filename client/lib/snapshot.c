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

struct bc_client_big {
	struct bc_client *c;
	struct bc_client_big_opts o;
	struct bc_client_image *out;
	struct bc_client_image t; /* the tile being decoded */
	uint32_t tile, across, total, in_flight, busy;
	uint8_t *state;   /* per tile: 0 to ask, 1 asked, 2 arrived */
	uint32_t *seq;    /* per tile, while asked */
	uint64_t *order;  /* per tile, once arrived */
	uint32_t *camera; /* per tile, once arrived */
	uint32_t arrived;
	int rounds;
};

/* Tile k's place in the picture: row-major, the last column and row
 * ragged. */
static void tile_rect(const struct bc_client_big *b, uint32_t k, uint32_t *x,
                      uint32_t *y, uint32_t *w, uint32_t *h)
{
	*x = (k % b->across) * b->tile;
	*y = (k / b->across) * b->tile;
	*w = b->o.width - *x < b->tile ? b->o.width - *x : b->tile;
	*h = b->o.height - *y < b->tile ? b->o.height - *y : b->tile;
}

static int ask(struct bc_client_big *b, uint32_t k, struct bc_errinfo *ei)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	uint32_t x, y, w, h;
	int rc;
	tile_rect(b, k, &x, &y, &w, &h);
	m.snapshot.encoding = b->o.encoding;
	m.snapshot.planes = (uint8_t)b->o.planes;
	m.snapshot.has_tile = true;
	m.snapshot.full_width = (uint16_t)b->o.width;
	m.snapshot.full_height = (uint16_t)b->o.height;
	m.snapshot.tile_x = (uint16_t)x;
	m.snapshot.tile_y = (uint16_t)y;
	m.snapshot.tile_width = (uint16_t)w;
	m.snapshot.tile_height = (uint16_t)h;
	b->state[k] = 1;
	if ((rc = bc_client_send(b->c, &m, &b->seq[k])) &&
	    !bc_client_error(b->c, ei)) {
		/* Not sticky: the encoder refused the message. */
		return bc_errinfo_set(ei, rc, "cannot encode SNAPSHOT");
	}
	return rc;
}

/* Copies the decoded tile k into the picture. */
static void place(struct bc_client_big *b, uint32_t k,
                  const struct bc_client_image *t)
{
	struct bc_client_image *out = b->out;
	uint32_t x0, y0, w, h;
	tile_rect(b, k, &x0, &y0, &w, &h);
	for (uint32_t y = 0; y < t->height; y++) {
		size_t at = ((size_t)y0 + y) * out->width + x0,
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

/* Tile k's FRAME m: decoded and placed. */
static int arrive(struct bc_client_big *b, uint32_t k, const struct bc_msg *m,
                  struct bc_errinfo *ei)
{
	struct bc_client_image *t = &b->t;
	uint32_t x, y, w, h;
	int rc;
	tile_rect(b, k, &x, &y, &w, &h);
	bc_client_image_finish(t);
	bc_client_image_init(t);
	if ((rc = bc_client_image_apply(t, m, ei))) {
		return rc;
	}
	if (((b->o.planes & BC_PROTO_PLANE_DEPTH) && !t->depth) ||
	    ((b->o.planes & BC_PROTO_PLANE_IDS) && !t->ids)) {
		return bc_errinfo_set(ei, BC_EIO,
		                      "a tile lacks a plane asked for");
	}
	if (!t->complete || t->width != w || t->height != h) {
		return bc_errinfo_set(ei, BC_EIO,
		                      "tile %u came as %ux%u, not %ux%u", k,
		                      t->width, t->height, w, h);
	}
	place(b, k, t);
	b->state[k] = 2;
	b->order[k] = m->frame.order;
	b->camera[k] = m->frame.camera_seq;
	b->out->flags |= m->flags & BC_PROTO_FLAG_INCOMPLETE;
	b->out->frame_no = m->frame.frame_no;
	b->arrived++;
	b->busy--;
	if (b->o.progress) {
		b->o.progress(b->o.ud, b->arrived, b->total);
	}
	return 0;
}

/* Asks for tiles not yet asked for, up to in_flight at once. */
static int fill(struct bc_client_big *b, struct bc_errinfo *ei)
{
	for (uint32_t k = 0; k < b->total && b->busy < b->in_flight; k++) {
		int rc;
		if (b->state[k] != 0) {
			continue;
		}
		if ((rc = ask(b, k, ei))) {
			return rc;
		}
		b->busy++;
	}
	return 0;
}

/* Tiles that show an older scene than the newest tile are asked for
 * again. Returns how many. */
static uint32_t overtaken(struct bc_client_big *b)
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

static int alloc_picture(struct bc_client_big *b)
{
	struct bc_client_image *out = b->out;
	size_t n = (size_t)b->o.width * b->o.height;
	bc_client_image_finish(out);
	bc_client_image_init(out);
	out->width = out->view_width = b->o.width;
	out->height = out->view_height = b->o.height;
	if (!(out->rgba = bc_malloc(4 * n)) ||
	    ((b->o.planes & BC_PROTO_PLANE_DEPTH) &&
	     !(out->depth = bc_malloc(n * sizeof(float)))) ||
	    ((b->o.planes & BC_PROTO_PLANE_IDS) &&
	     !(out->ids = bc_malloc(n * sizeof(uint32_t))))) {
		return BC_ENOMEM;
	}
	out->flags = BC_PROTO_FLAG_SNAPSHOT | BC_PROTO_FLAG_STILL;
	out->encoding = b->o.encoding;
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

void bc_client_big_free(struct bc_client_big *b)
{
	if (!b) {
		return;
	}
	bc_client_image_finish(&b->t);
	bc_free(b->state);
	bc_free(b->seq);
	bc_free(b->order);
	bc_free(b->camera);
	bc_free(b);
}

int bc_client_big_start(struct bc_client *c,
                        const struct bc_client_big_opts *opts,
                        struct bc_client_image *out, struct bc_client_big **big,
                        struct bc_errinfo *ei)
{
	struct bc_client_big *b;
	uint32_t tile;
	int rc;
	struct bc_client_big_opts o = *opts;
	*big = NULL;
	if (o.encoding == BC_PROTO_ENC_INVALID) {
		o.encoding = BC_PROTO_ENC_PNG;
	}
	if ((rc = check_opts(c, &o, &tile, ei))) {
		return rc;
	}
	if (!(b = bc_calloc(1, sizeof(*b)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	b->c = c;
	b->o = o;
	b->out = out;
	b->in_flight = o.in_flight ? o.in_flight : 2u;
	if (b->in_flight > BIG_MAX_IN_FLIGHT) {
		b->in_flight = BIG_MAX_IN_FLIGHT;
	}
	b->tile = tile;
	b->across = (o.width + tile - 1) / tile;
	b->total = b->across * ((o.height + tile - 1) / tile);
	bc_client_image_init(&b->t);
	if (!(b->state = bc_calloc(b->total, 1)) ||
	    !(b->seq = bc_calloc(b->total, sizeof(*b->seq))) ||
	    !(b->order = bc_calloc(b->total, sizeof(*b->order))) ||
	    !(b->camera = bc_calloc(b->total, sizeof(*b->camera))) ||
	    alloc_picture(b)) {
		bc_client_big_free(b);
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "no memory for a %ux%u picture", o.width,
		                      o.height);
	}
	if ((rc = fill(b, ei))) {
		bc_client_big_free(b);
		return rc;
	}
	*big = b;
	return 0;
}

/* After the last tile: tiles an edit overtook are asked for again, or
 * the picture is whole. */
static int last_tile(struct bc_client_big *b, struct bc_errinfo *ei)
{
	int rc;
	if (overtaken(b)) {
		if (++b->rounds >= BIG_MAX_ROUNDS) {
			return bc_errinfo_set(
			    ei, BC_EBUSY,
			    "the scene kept changing while the tiles were "
			    "rendered (%d rounds); try again when edits pause",
			    b->rounds);
		}
		return (rc = fill(b, ei)) ? rc : BC_CLIENT_BIG_MORE;
	}
	for (uint32_t k = 1; k < b->total; k++) {
		if (b->camera[k] != b->camera[0]) {
			return bc_errinfo_set(
			    ei, BC_EBUSY,
			    "the camera changed while the tiles "
			    "were rendered; try again");
		}
	}
	b->out->camera_seq = b->camera[0];
	b->out->complete = true;
	return BC_CLIENT_BIG_DONE;
}

int bc_client_big_take(struct bc_client_big *b, const struct bc_msg *m,
                       struct bc_errinfo *ei)
{
	uint32_t k;
	int rc;
	if (m->seq == 0 ||
	    (m->type != BC_MSG_FRAME && m->type != BC_MSG_ERROR)) {
		return BC_CLIENT_BIG_NOT_OURS;
	}
	for (k = 0; k < b->total; k++) {
		if (b->state[k] == 1 && b->seq[k] == m->seq) {
			break;
		}
	}
	if (k == b->total) {
		return BC_CLIENT_BIG_NOT_OURS;
	}
	if (m->type == BC_MSG_ERROR) {
		return bc_errinfo_set(
		    ei, m->error.code ? -(int)m->error.code : BC_EINVAL, "%.*s",
		    (int)m->error.text.len, m->error.text.ptr);
	}
	if (!(m->flags & BC_PROTO_FLAG_SNAPSHOT)) {
		return BC_CLIENT_BIG_NOT_OURS;
	}
	if ((rc = arrive(b, k, m, ei))) {
		return rc;
	}
	if (b->arrived < b->total) {
		return (rc = fill(b, ei)) ? rc : BC_CLIENT_BIG_MORE;
	}
	return last_tile(b, ei);
}

void bc_client_big_progress(const struct bc_client_big *b, uint32_t *done,
                            uint32_t *total)
{
	*done = b->arrived;
	*total = b->total;
}

int bc_client_snapshot_big(struct bc_client *c,
                           const struct bc_client_big_opts *opts,
                           struct bc_client_image *out, struct bc_errinfo *ei)
{
	struct bc_client_big *b;
	int rc = bc_client_big_start(c, opts, out, &b, ei);
	int wait = opts->timeout_ms ? opts->timeout_ms : c->timeout_ms;
	while (rc == 0) {
		struct bc_msg m;
		int got = bc_client_recv(c, &m, wait);
		if (got < 0) {
			rc = bc_client_error(c, ei);
		} else if (got == 0) {
			rc = bc_errinfo_set(
			    ei, BC_ETIMEOUT,
			    "no tile from the server in time (%u of %u "
			    "arrived); a longer --timeout gives it more",
			    b->arrived, b->total);
		} else if ((rc = bc_client_big_take(b, &m, ei)) ==
		           BC_CLIENT_BIG_DONE) {
			rc = 0;
			break;
		} else if (rc > 0) {
			rc = 0; /* not ours, or more to come */
		}
	}
	bc_client_big_free(b);
	return rc;
}
