/*
 * Snapshots in tiles (PROTOCOL.md 7.17, feature TILES) against blobcastd:
 * a picture assembled from tiles by bc_client_snapshot_big() equals, bit
 * for bit in colour, depth and ids, the single SNAPSHOT of the same size,
 * on the CPU tracer and on GL (Mesa here); an edit that lands between
 * tiles makes the library ask again for the tiles that show the older
 * scene; the tile form is refused without the feature (ENOTSUP) and over
 * the server's max_dim (ERANGE), and a tile at the far corner of an
 * 8192 x 8192 picture is served.
 */
#include <string.h>

#include "blobcast/client.h"
#include "blobcast/log.h"
#include "test.h"
/* After test.h: daemon_tests_run needs it. */
#include "daemon.h"

static char dir[96];

#define W 200u
#define H 136u

static struct bc_client *open_client(const struct daemon *d,
                                     enum bc_proto_role role)
{
	char addr[128];
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	snprintf(addr, sizeof(addr), "unix:%s", d->sock);
	if (bc_client_connect(&c,
	                      &(struct bc_client_opts){.addr = addr,
	                                               .name = "test-tiles",
	                                               .timeout_ms = 120000},
	                      &ei) ||
	    bc_client_join(c, "default", role, BC_CLIENT_JOIN_EXISTING, &ei)) {
		fprintf(stderr, "  cannot join: %s\n", ei.msg);
		bc_client_destroy(c);
		return NULL;
	}
	return c;
}

static int view(struct bc_client *c, uint16_t w, uint16_t h)
{
	uint32_t seq;
	struct bc_errinfo ei = {0};
	return bc_client_view(
	    c,
	    &(struct bc_msg_view){.width = w,
	                          .height = h,
	                          .encoding = BC_PROTO_ENC_JPEG,
	                          .quality_interactive = 30,
	                          .quality_still = 30},
	    &seq, &ei);
}

/* Pixels (of n) where the planes of a and b differ. */
static size_t differ(const struct bc_client_image *a,
                     const struct bc_client_image *b, size_t n)
{
	size_t bad = 0;
	for (size_t i = 0; i < n; i++) {
		bad += memcmp(a->rgba + 4 * i, b->rgba + 4 * i, 4) != 0 ||
		       memcmp(&a->depth[i], &b->depth[i], 4) != 0 ||
		       a->ids[i] != b->ids[i];
	}
	return bad;
}

static void tiles_equal_whole_on(const char *backend)
{
	struct daemon d;
	struct bc_client *c;
	struct bc_errinfo ei = {0};
	struct bc_client_image whole, tiled;
	struct bc_msg_stats before = {0}, after = {0};
	char sub[128];
	const char *extra[] = {"--backend", backend, NULL};
	snprintf(sub, sizeof(sub), "%s/%s", dir, backend);
	REQUIRE(daemon_start_with(&d, sub, extra) == 0);
	c = open_client(&d, BC_PROTO_ROLE_VIEWER);
	REQUIRE(c != NULL);
	CHECK(bc_client_info(c)->features & BC_PROTO_FEATURE_TILES);
	bc_client_image_init(&whole);
	bc_client_image_init(&tiled);
	CHECK_EQ_INT(view(c, W, H), 0);
	CHECK_EQ_INT(bc_client_snapshot_planes(
	                 c, BC_PROTO_ENC_RAW, BC_PROTO_PLANES_ALL, &whole, &ei),
	             0);
	CHECK_EQ_INT(
	    bc_client_stats_parts(c, BC_PROTO_STATS_LOAD, &before, &ei), 0);
	/* Tiles of 64 (ragged at the right and bottom), four in flight;
	 * then 48, PNG, one at a time. */
	for (int round = 0; round < 2; round++) {
		size_t bad;
		CHECK_EQ_INT(bc_client_snapshot_big(
		                 c,
		                 &(struct bc_client_big_opts){
		                     .width = W,
		                     .height = H,
		                     .encoding = round ? BC_PROTO_ENC_PNG
		                                       : BC_PROTO_ENC_RAW,
		                     .planes = BC_PROTO_PLANES_ALL,
		                     .tile = round ? 48 : 64,
		                     .in_flight = round ? 1 : 4},
		                 &tiled, &ei),
		             0);
		REQUIRE(tiled.rgba && tiled.depth && tiled.ids);
		CHECK_EQ_INT(tiled.width, W);
		CHECK_EQ_INT(tiled.height, H);
		CHECK(tiled.complete);
		CHECK(tiled.order == whole.order);
		bad = differ(&whole, &tiled, (size_t)W * H);
		if (bad) {
			fprintf(stderr,
			        "  %s, round %d: %zu of %u pixels differ\n",
			        backend, round, bad, W * H);
		}
		CHECK(bad == 0);
	}
	/* A tile's view is freed with its job: the cache holds no more
	 * than before the tiles (the renderer's state for the whole view
	 * went when the first tile came). */
	CHECK_EQ_INT(bc_client_stats_parts(c, BC_PROTO_STATS_LOAD, &after, &ei),
	             0);
	CHECK(after.has_load &&
	      after.load.view_bytes <= before.load.view_bytes);
	bc_client_image_finish(&whole);
	bc_client_image_finish(&tiled);
	bc_client_destroy(c);
	daemon_stop(&d, SIGTERM);
}

static void tiles_equal_whole_tiled(void)
{
	tiles_equal_whole_on("tiled");
}

static void tiles_equal_whole_gl(void)
{
	tiles_equal_whole_on("gl");
}

/* After the first tile an editor moves a sphere: the tiles rendered
 * before are asked for again, and the picture is the new scene whole. */
struct overtake {
	struct bc_client *editor;
	int edits;
};

static void edit_after_first(void *ud, uint32_t done, uint32_t total)
{
	struct overtake *o = ud;
	const char *kv[1] = {"translate=0.3,0.1,0"};
	struct bc_errinfo ei = {0};
	uint32_t seq;
	(void)total;
	if (done == 1 && o->edits == 0) {
		const struct bc_tree *t = bc_client_scene(o->editor, NULL);
		uint32_t node = 0;
		REQUIRE(t != NULL);
		/* The first primitive of the default scene. */
		for (uint32_t id = 1; id < 64 && !node; id++) {
			struct bc_prim_data p;
			if (bc_tree_get(t, id, &p, NULL) &&
			    p.kind != BC_PRIM_INVALID) {
				node = id;
			}
		}
		REQUIRE(node != 0);
		if (bc_client_edit_kv(o->editor, node, kv, 1, false, &seq,
		                      &ei) ||
		    bc_client_wait_applied(o->editor, seq, NULL, &ei)) {
			fprintf(stderr, "  edit: %s\n", ei.msg);
			CHECK(false);
			return;
		}
		o->edits++;
	}
}

static void edit_between_tiles(void)
{
	struct daemon d;
	struct bc_client *c, *e;
	struct bc_errinfo ei = {0};
	struct bc_client_image whole, tiled;
	struct overtake o = {0};
	uint64_t before;
	char sub[128];
	snprintf(sub, sizeof(sub), "%s/overtake", dir);
	REQUIRE(daemon_start(&d, sub) == 0);
	c = open_client(&d, BC_PROTO_ROLE_VIEWER);
	e = open_client(&d, BC_PROTO_ROLE_EDITOR);
	REQUIRE(c && e);
	bc_client_image_init(&whole);
	bc_client_image_init(&tiled);
	o.editor = e;
	before = bc_client_info(c)->order;
	CHECK_EQ_INT(view(c, W, H), 0);
	CHECK_EQ_INT(bc_client_snapshot_big(c,
	                                    &(struct bc_client_big_opts){
	                                        .width = W,
	                                        .height = H,
	                                        .encoding = BC_PROTO_ENC_RAW,
	                                        .planes = BC_PROTO_PLANES_ALL,
	                                        .tile = 64,
	                                        .in_flight = 1,
	                                        .progress = edit_after_first,
	                                        .ud = &o},
	                                    &tiled, &ei),
	             0);
	CHECK_EQ_INT(o.edits, 1);
	CHECK(tiled.order > before);
	CHECK_EQ_INT(bc_client_snapshot_planes(
	                 c, BC_PROTO_ENC_RAW, BC_PROTO_PLANES_ALL, &whole, &ei),
	             0);
	CHECK(whole.order == tiled.order);
	if (whole.rgba && tiled.rgba && whole.ids && tiled.ids) {
		CHECK(differ(&whole, &tiled, (size_t)W * H) == 0);
	}
	bc_client_image_finish(&whole);
	bc_client_image_finish(&tiled);
	bc_client_destroy(c);
	bc_client_destroy(e);
	daemon_stop(&d, SIGTERM);
}

/* SNAPSHOT's tile form by hand: refused without TILES, refused over
 * max_dim, served at the far corner of the largest picture. */
static uint32_t tile_req(struct conn *c, uint16_t x, uint16_t y, uint16_t w,
                         uint16_t h)
{
	struct bc_msg m = {.type = BC_MSG_SNAPSHOT};
	m.snapshot.encoding = BC_PROTO_ENC_PNG;
	m.snapshot.has_tile = true;
	m.snapshot.full_width = 8192;
	m.snapshot.full_height = 8192;
	m.snapshot.tile_x = x;
	m.snapshot.tile_y = y;
	m.snapshot.tile_width = w;
	m.snapshot.tile_height = h;
	return conn_send(c, &m);
}

static int answer(struct conn *c, uint32_t seq)
{
	for (;;) {
		if (conn_recv(c, 60000) != 1) {
			return -1;
		}
		if (c->m.seq == seq &&
		    (c->m.type == BC_MSG_ERROR || c->m.type == BC_MSG_FRAME)) {
			return 0;
		}
	}
}

static void tile_form_rules(void)
{
	struct daemon d;
	struct conn c;
	uint32_t seq;
	char sub[128];
	snprintf(sub, sizeof(sub), "%s/rules", dir);
	REQUIRE(daemon_start(&d, sub) == 0);

	/* A client of this text without TILES. */
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_hello_as(&c, "no-tiles", BC_PROTO_ENCODINGS_ALL, true,
	                      BC_PROTO_FEATURES_READ &
	                          ~BC_PROTO_FEATURE_TILES) == 0);
	REQUIRE(conn_join(&c, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_view(&c, 64, 64, BC_PROTO_ENC_JPEG) != 0);
	seq = tile_req(&c, 0, 0, 64, 64);
	REQUIRE(seq != 0 && answer(&c, seq) == 0);
	CHECK_EQ_INT(c.m.type, BC_MSG_ERROR);
	CHECK_EQ_INT(-(int)c.m.error.code, BC_ENOTSUP);
	CHECK(!(c.m.flags & BC_PROTO_FLAG_FATAL));
	conn_close(&c);

	/* With TILES: over max_dim is ERANGE, the far corner is served. */
	REQUIRE(conn_open(&c, &d) == 0);
	REQUIRE(conn_hello(&c, "tiles") == 0);
	CHECK(c.m.welcome.features & BC_PROTO_FEATURE_TILES);
	REQUIRE(conn_join(&c, "default", BC_PROTO_ROLE_VIEWER, false) == 0);
	REQUIRE(conn_view(&c, 64, 64, BC_PROTO_ENC_JPEG) != 0);
	seq = tile_req(&c, 0, 0, 4097, 8);
	REQUIRE(seq != 0 && answer(&c, seq) == 0);
	CHECK_EQ_INT(c.m.type, BC_MSG_ERROR);
	CHECK_EQ_INT(-(int)c.m.error.code, BC_ERANGE);
	seq = tile_req(&c, 8192 - 40, 8192 - 24, 40, 24);
	REQUIRE(seq != 0 && answer(&c, seq) == 0);
	CHECK_EQ_INT(c.m.type, BC_MSG_FRAME);
	if (c.m.type == BC_MSG_FRAME) {
		CHECK(c.m.flags & BC_PROTO_FLAG_SNAPSHOT);
		CHECK_EQ_INT(c.m.frame.width, 40);
		CHECK_EQ_INT(c.m.frame.height, 24);
		CHECK_EQ_INT(c.m.frame.image_width, 40);
	}
	conn_close(&c);
	daemon_stop(&d, SIGTERM);
}

static const struct bc_test tests[] = {
    {"tiles_equal_whole_tiled", tiles_equal_whole_tiled},
    {"tiles_equal_whole_gl", tiles_equal_whole_gl},
    {"edit_between_tiles", edit_between_tiles},
    {"tile_form_rules", tile_form_rules},
};

int main(int argc, char **argv)
{
	bc_log_init(BC_LOG_ERROR);
	return daemon_tests_run("tiles", dir, sizeof(dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
