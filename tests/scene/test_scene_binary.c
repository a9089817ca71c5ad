/*
 * The binary scene encoding: every generator's scene and random trees
 * survive encode/decode bit for bit; a table of malformed encodings written
 * byte by byte (empty, truncated at every field, counts over the bytes
 * left, unknown tags, bad flags, NaN, nesting over the limit, trailing
 * bytes, duplicate ids) each fails with its code and never crashes; random
 * corruption of valid encodings never crashes; ids 0 get fresh ids; and
 * every allocation failure in encode and decode is survived without leaks.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "scene_util.h"
#include "test.h"

/* ---- a byte writer independent of the encoder -----------------------------
 */

struct bw {
	uint8_t b[8192];
	size_t n;
};

static void w8(struct bw *w, uint32_t v)
{
	if (w->n < sizeof(w->b)) {
		w->b[w->n++] = (uint8_t)v;
	}
}

static void w32(struct bw *w, uint32_t v)
{
	w8(w, v & 0xffu);
	w8(w, (v >> 8) & 0xffu);
	w8(w, (v >> 16) & 0xffu);
	w8(w, v >> 24);
}

static void wf(struct bw *w, float f)
{
	uint32_t v;
	memcpy(&v, &f, 4);
	w32(w, v);
}

/* A sphere node: tag, id, translate, rotate, has_color, nfloats, radius. */
static void w_sphere(struct bw *w, uint32_t id, float r, float x)
{
	w8(w, BC_PRIM_SPHERE);
	w32(w, id);
	wf(w, x);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 1.0f);
	w8(w, 0);
	w8(w, 1);
	wf(w, r);
}

static void w_op(struct bw *w, enum bc_op kind, uint32_t id, float blend,
                 float range, uint32_t nchildren)
{
	w8(w, 0x80u | (uint32_t)kind);
	w32(w, id);
	wf(w, blend);
	wf(w, range);
	w32(w, nchildren);
}

static void w_camera(struct bw *w)
{
	w8(w, BC_SCENE_FLAG_CAMERA);
	wf(w, 1.0f);
	wf(w, 2.0f);
	wf(w, 5.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 1.0f);
	wf(w, 0.0f);
	wf(w, 45.0f);
}

/* A valid scene with every field kind: camera, a smooth operator, a
 * coloured box, plain spheres and a nested sharp operator. */
static void w_valid(struct bw *w)
{
	w_camera(w);
	w32(w, 6);
	w_op(w, BC_OP_SMOOTH_UNION, 10, 0.2f, 0.3f, 3);
	w8(w, BC_PRIM_BOX);
	w32(w, 11);
	wf(w, 0.5f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 0.0f);
	wf(w, 1.0f);
	w8(w, 1);
	wf(w, 1.0f);
	wf(w, 0.5f);
	wf(w, 0.25f);
	w8(w, bc_scene_prim_nfloats(BC_PRIM_BOX));
	for (uint32_t i = 0; i < bc_scene_prim_nfloats(BC_PRIM_BOX); i++) {
		wf(w, i < 3 ? 0.4f : 0.0f);
	}
	w_op(w, BC_OP_DIFFERENCE, 12, 0.0f, 0.0f, 2);
	w_sphere(w, 13, 0.5f, 1.0f);
	w_sphere(w, 14, 0.25f, 1.3f);
	w_sphere(w, 15, 0.3f, -1.0f);
}

/* ---- round trips ------------------------------------------------------------
 */

static void check_binary_round_trip(const struct bc_tree *t,
                                    const struct bc_camera *cam)
{
	struct bc_tree *u = bc_tree_create();
	struct bc_camera cu;
	struct bc_errinfo ei = {0};
	uint8_t *buf = NULL, *again = NULL;
	size_t len = 0, len2 = 0;
	bool has = !cam;
	REQUIRE(u);
	REQUIRE(bc_scene_encode(t, cam, &buf, &len) == 0);
	CHECK_EQ_INT(bc_scene_decode(buf, len, u, &cu, &has, &ei), 0);
	if (ei.code) {
		fprintf(stderr, "  decode: %s\n", ei.msg);
	}
	CHECK_EQ_INT(has, cam != NULL);
	if (cam) {
		CHECK(same_camera(cam, &cu));
	}
	CHECK_EQ_INT(tree_diff(t, u), 0);
	/* Encoding is a function of the scene: the same bytes again. */
	REQUIRE(bc_scene_encode(t, cam, &again, &len2) == 0);
	CHECK(len == len2 && memcmp(buf, again, len) == 0);
	bc_free(again);
	/* After a head of the caller's: zeros, then the same bytes. */
	REQUIRE(bc_scene_encode_after(t, cam, 37, &again, &len2) == 0);
	CHECK(len2 == 37 + len && memcmp(buf, again + 37, len) == 0);
	for (size_t i = 0; i < 37; i++) {
		CHECK_EQ_INT(again[i], 0);
	}
	bc_free(buf);
	bc_free(again);

	/* The bare tree form, as structural edits carry it. */
	REQUIRE(bc_tree_encode(t, &buf, &len) == 0);
	CHECK_EQ_INT(bc_tree_decode(buf, len, u, &ei), 0);
	CHECK_EQ_INT(tree_diff(t, u), 0);
	bc_free(buf);
	bc_tree_destroy(u);
}

static void every_generator_round_trips_through_binary(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
	} cases[] = {
	    {"fig16", {.level = 1}},
	    {"fig16", {.level = 3, .blend = BC_GEN_BLEND_SHARP}},
	    {"fig18", {.count = 64, .kind = BC_GEN_KIND_BOXES}},
	    {"fig18", {.count = 64, .kind = BC_GEN_KIND_SPHERES}},
	    {"fig18",
	     {.count = 30,
	      .kind = BC_GEN_KIND_LENSES,
	      .blend = BC_GEN_BLEND_SMOOTH}},
	    {"comb", {.count = 1000}},
	    {"random", {.count = 400, .seed = 9, .depth = 40}},
	    {"gears", {0}},
	    {"many-gears", {.count = 9}},
	    {"many-spheres", {.count = 300, .seed = 4}},
	};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bc_camera cam;
		REQUIRE(bc_gen(cases[i].name, &cases[i].o, t, &cam, NULL) == 0);
		check_binary_round_trip(t, &cam);
	}
	bc_tree_destroy(t);
}

static void random_trees_round_trip_through_binary(void)
{
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (uint64_t seed = 0; seed < 60; seed++) {
		struct bc_gen_opts o = {.count = 1 + (uint32_t)(seed * 7 % 61),
		                        .seed = seed,
		                        .depth = 2 + (uint32_t)(seed % 30)};
		struct bc_camera cam;
		REQUIRE(bc_gen("random", &o, t, &cam, NULL) == 0);
		check_binary_round_trip(t, seed % 2 ? &cam : NULL);
	}
	bc_tree_destroy(t);
}

static void hand_written_scene_decodes_to_its_fields(void)
{
	struct bw w = {0};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_prim_data p;
	struct bc_op_data op;
	bool has = false;
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	w_valid(&w);
	CHECK_EQ_INT(bc_scene_decode(w.b, w.n, t, &cam, &has, &ei), 0);
	if (ei.code) {
		fprintf(stderr, "  %s\n", ei.msg);
		bc_tree_destroy(t);
		return;
	}
	CHECK(has);
	CHECK(cam.eye[0] == 1.0f && cam.eye[2] == 5.0f &&
	      cam.fov_y_deg == 45.0f);
	CHECK_EQ_INT(bc_tree_root(t), 10);
	CHECK_EQ_INT(bc_tree_node_count(t), 6);
	CHECK_EQ_INT(bc_tree_child_count(t, 10), 3);
	CHECK_EQ_INT(bc_tree_child(t, 10, 1), 12);
	CHECK_EQ_INT(bc_tree_child(t, 10, 2), 15);
	CHECK_EQ_INT(bc_tree_parent(t, 14), 12);
	REQUIRE(bc_tree_get(t, 10, NULL, &op));
	CHECK(op.kind == BC_OP_SMOOTH_UNION && op.blend == 0.2f &&
	      op.range == 0.3f);
	REQUIRE(bc_tree_get(t, 11, &p, NULL));
	CHECK(p.kind == BC_PRIM_BOX && p.has_color && p.color[1] == 0.5f &&
	      p.translate[0] == 0.5f && p.params[2] == 0.4f);
	REQUIRE(bc_tree_get(t, 14, &p, NULL));
	CHECK(p.kind == BC_PRIM_SPHERE && !p.has_color &&
	      p.params[0] == 0.25f && p.translate[0] == 1.3f);
	bc_tree_destroy(t);
}

/* The example of docs/scene-format.md, byte for byte. */
static void documented_example_decodes(void)
{
	static const uint8_t doc[] = {
	    0x00, 0x03, 0x00, 0x00, 0x00, 0x81, 0x01, 0x00, 0x00, 0x00,
	    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x00,
	    0x00, 0x00, 0x01, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	    0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x01, 0x00, 0x00, 0x80,
	    0x3f, 0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f,
	    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	    0x00, 0x00, 0x80, 0x3f, 0x00, 0x01, 0x00, 0x00, 0x00, 0x3f};
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_errinfo ei = {0};
	uint8_t *again = NULL;
	size_t len = 0;
	bool has = true;
	REQUIRE(t);
	CHECK_EQ_INT(bc_scene_decode(doc, sizeof(doc), t, NULL, &has, &ei), 0);
	CHECK(!has);
	CHECK_EQ_INT(bc_tree_root(t), 1);
	CHECK_EQ_INT(bc_tree_child(t, 1, 1), 3);
	CHECK(bc_tree_get(t, 3, &p, NULL) && p.params[0] == 0.5f &&
	      p.translate[0] == 1.0f);
	/* And our encoder writes exactly those bytes. */
	CHECK_EQ_INT(bc_scene_encode(t, NULL, &again, &len), 0);
	CHECK(len == sizeof(doc) && memcmp(again, doc, len) == 0);
	bc_free(again);
	bc_tree_destroy(t);
}

/* Nodes with id 0 get ids that no node of the encoding names, even ids
 * named later in the stream. */
static void zero_ids_get_fresh_ids(void)
{
	struct bw w = {0};
	struct bc_tree *t = bc_tree_create();
	uint32_t root, c0, c1;
	REQUIRE(t);
	w8(&w, 0);
	w32(&w, 4);
	w_op(&w, BC_OP_UNION, 0, 0.0f, 0.0f, 3);
	w_sphere(&w, 0, 1.0f, 0.0f);
	w_sphere(&w, 1, 1.0f, 1.0f);
	w_sphere(&w, 2, 1.0f, 2.0f);
	REQUIRE(bc_scene_decode(w.b, w.n, t, NULL, NULL, NULL) == 0);
	root = bc_tree_root(t);
	c0 = bc_tree_child(t, root, 0);
	c1 = bc_tree_child(t, root, 1);
	CHECK(root != 0 && root != 1 && root != 2);
	CHECK(c0 != 0 && c0 != 1 && c0 != 2 && c0 != root);
	CHECK_EQ_INT(c1, 1);
	CHECK_EQ_INT(bc_tree_child(t, root, 2), 2);
	bc_tree_destroy(t);
}

/* ---- malformed encodings
 * ------------------------------------------------------ */

struct bad {
	const char *what;
	void (*write)(struct bw *w);
	int code;
	const char *reason;
};

static void b_empty(struct bw *w)
{
	(void)w;
}
static void b_flags(struct bw *w)
{
	w8(w, 0x06);
	w32(w, 1);
	w_sphere(w, 1, 1.0f, 0.0f);
}

/* ---- names tables (PROTOCOL.md 8, check 6; ENONODE from the meaning) ---- */

/* A union (id 1) of spheres 2 and 3, flags with the names bit, then the
 * names table's count. */
static void w_named_union(struct bw *w, uint32_t count)
{
	w8(w, BC_SCENE_FLAG_NAMES);
	w32(w, 3);
	w8(w, 0x81);
	w32(w, 1);
	wf(w, 0.0f);
	wf(w, 0.0f);
	w32(w, 2);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 1.0f);
	w32(w, count);
}
static void w_name(struct bw *w, uint32_t id, const char *s, size_t len)
{
	w32(w, id);
	w8(w, (uint32_t)(len & 0xffu));
	w8(w, (uint32_t)(len >> 8));
	for (size_t i = 0; i < len; i++) {
		w8(w, (uint8_t)s[i]);
	}
}
static void b_names_zero(struct bw *w)
{
	w_named_union(w, 0);
}
static void b_names_over_nodes(struct bw *w)
{
	w_named_union(w, 4);
	for (uint32_t i = 1; i <= 4; i++) {
		w_name(w, i, "abc", 3);
	}
}
static void b_names_over_bytes(struct bw *w)
{
	w_named_union(w, 3);
	w_name(w, 1, "a", 1);
}
static void b_name_cut(struct bw *w)
{
	w_named_union(w, 2);
	w_name(w, 2, "abcdefgh", 8);
	w8(w, 3);
	w8(w, 0);
	w8(w, 0);
}
static void b_name_id_zero(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 0, "wheel", 5);
}
static void b_name_ids_down(struct bw *w)
{
	w_named_union(w, 2);
	w_name(w, 3, "a", 1);
	w_name(w, 2, "b", 1);
}
static void b_name_id_twice(struct bw *w)
{
	w_named_union(w, 2);
	w_name(w, 2, "a", 1);
	w_name(w, 2, "b", 1);
}
static void b_name_empty(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 2, "", 0);
	w8(w, 0);
}
static void b_name_long(struct bw *w)
{
	char s[65];
	memset(s, 'x', sizeof(s));
	w_named_union(w, 1);
	w_name(w, 2, s, sizeof(s));
}
static void b_name_short(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 2, "wheel", 5);
	w->n -= 2;
}
static void b_name_utf8(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 2, "a\xc3(", 3);
}
static void b_name_nul(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 2, "a\0b", 3);
}
static void b_name_trailing(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 2, "wheel", 5);
	w8(w, 0);
}
static void b_name_unknown_id(struct bw *w)
{
	w_named_union(w, 1);
	w_name(w, 9, "wheel", 5);
}
/* A name may not reach a node sent with id 0: its id is the decoder's. */
static void b_name_of_zero_id(struct bw *w)
{
	w8(w, BC_SCENE_FLAG_NAMES);
	w32(w, 3);
	w8(w, 0x81);
	w32(w, 5);
	wf(w, 0.0f);
	wf(w, 0.0f);
	w32(w, 2);
	w_sphere(w, 0, 1.0f, 0.0f);
	w_sphere(w, 0, 1.0f, 1.0f);
	w32(w, 1);
	w_name(w, 1, "first", 5);
}
static void b_camera_short(struct bw *w)
{
	w8(w, BC_SCENE_FLAG_CAMERA);
	wf(w, 1.0f);
}
static void b_camera_nan(struct bw *w)
{
	w8(w, BC_SCENE_FLAG_CAMERA);
	for (int i = 0; i < 10; i++) {
		wf(w, i == 4 ? NAN : 1.0f);
	}
	w32(w, 1);
	w_sphere(w, 1, 1.0f, 0.0f);
}
static void b_camera_degenerate(struct bw *w)
{
	w8(w, BC_SCENE_FLAG_CAMERA);
	for (int i = 0; i < 10; i++) {
		wf(w, i == 9 ? 45.0f : 1.0f); /* eye == target */
	}
	w32(w, 1);
	w_sphere(w, 1, 1.0f, 0.0f);
}
static void b_count_short(struct bw *w)
{
	w8(w, 0);
	w8(w, 1);
	w8(w, 0);
}
static void b_count_zero(struct bw *w)
{
	w8(w, 0);
	w32(w, 0);
}
static void b_count_max(struct bw *w)
{
	w8(w, 0);
	w32(w, 0xffffffffu);
	w_sphere(w, 1, 1.0f, 0.0f);
}
static void b_count_over_bytes(struct bw *w)
{
	w8(w, 0);
	w32(w, 7); /* 7 x 5 bytes fit in the 39 of one sphere node */
	w_sphere(w, 1, 1.0f, 0.0f);
}
static void b_count_far_over_bytes(struct bw *w)
{
	w8(w, 0);
	w32(w, 1000000);
	w_sphere(w, 1, 1.0f, 0.0f);
}
static void b_tag_zero(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w8(w, 0);
	w32(w, 1);
	for (int i = 0; i < 8; i++) {
		wf(w, 0.0f);
	}
}
static void b_tag_prim_count(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w8(w, BC_PRIM_COUNT);
	w32(w, 1);
	for (int i = 0; i < 8; i++) {
		wf(w, 0.0f);
	}
}
static void b_tag_op_zero(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_INVALID, 1, 0.0f, 0.0f, 2);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_tag_op_count(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_COUNT, 1, 0.0f, 0.0f, 2);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_has_color(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w8(w, BC_PRIM_SPHERE);
	w32(w, 1);
	for (int i = 0; i < 7; i++) {
		wf(w, i == 6 ? 1.0f : 0.0f);
	}
	w8(w, 2);
	w8(w, 1);
	wf(w, 1.0f);
}
static void b_nfloats(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w8(w, BC_PRIM_SPHERE);
	w32(w, 1);
	for (int i = 0; i < 7; i++) {
		wf(w, i == 6 ? 1.0f : 0.0f);
	}
	w8(w, 0);
	w8(w, 2);
	wf(w, 1.0f);
	wf(w, 1.0f);
}
static void b_nan_translate(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w_sphere(w, 1, 1.0f, NAN);
}
static void b_inf_radius(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w_sphere(w, 1, INFINITY, 0.0f);
}
static void b_nan_blend(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_SMOOTH_UNION, 1, NAN, 0.0f, 2);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_child_count_one(struct bw *w)
{
	w8(w, 0);
	w32(w, 2);
	w_op(w, BC_OP_UNION, 1, 0.0f, 0.0f, 1);
	w_sphere(w, 2, 1.0f, 0.0f);
}
static void b_child_count_over(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_UNION, 1, 0.0f, 0.0f, 3);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_child_count_max(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_UNION, 1, 0.0f, 0.0f, 0xffffffffu);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_children_missing(struct bw *w)
{
	/* union(union(a, b), <missing>) with node_count 4 */
	w8(w, 0);
	w32(w, 4);
	w_op(w, BC_OP_UNION, 1, 0.0f, 0.0f, 2);
	w_op(w, BC_OP_UNION, 2, 0.0f, 0.0f, 2);
	w_sphere(w, 3, 1.0f, 0.0f);
	w_sphere(w, 4, 1.0f, 0.0f);
}
static void b_beyond_root(struct bw *w)
{
	w8(w, 0);
	w32(w, 2);
	w_sphere(w, 1, 1.0f, 0.0f);
	w_sphere(w, 2, 1.0f, 0.0f);
}
/* BC_EVAL_STACK unions nested in right operands: within the depth limit,
 * but their evaluation needs one stack entry more than evaluators keep
 * (left-nested chains are tested at any depth in test_scene_deep.c). */
static void b_too_deep(struct bw *w)
{
	uint32_t n = BC_EVAL_STACK;
	w8(w, 0);
	w32(w, 2 * n + 1);
	for (uint32_t i = 0; i < n; i++) {
		w_op(w, BC_OP_UNION, 1000 + i, 0.0f, 0.0f, 2);
		w_sphere(w, 1 + i, 1.0f, 0.0f);
	}
	w_sphere(w, 999, 1.0f, 0.0f);
}
static void b_trailing(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w_sphere(w, 1, 1.0f, 0.0f);
	w8(w, 0);
}
static void b_dup_id(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_UNION, 1, 0.0f, 0.0f, 2);
	w_sphere(w, 7, 1.0f, 0.0f);
	w_sphere(w, 7, 1.0f, 0.0f);
}
static void b_sharp_with_blend(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_UNION, 1, 0.1f, 0.0f, 2);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_smooth_zero_blend(struct bw *w)
{
	w8(w, 0);
	w32(w, 3);
	w_op(w, BC_OP_SMOOTH_UNION, 1, 0.0f, 0.0f, 2);
	w_sphere(w, 2, 1.0f, 0.0f);
	w_sphere(w, 3, 1.0f, 0.0f);
}
static void b_negative_radius(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w_sphere(w, 1, -1.0f, 0.0f);
}
static void b_bad_quaternion(struct bw *w)
{
	w8(w, 0);
	w32(w, 1);
	w8(w, BC_PRIM_SPHERE);
	w32(w, 1);
	for (int i = 0; i < 7; i++) {
		wf(w, i == 6 ? 2.0f : 0.0f);
	}
	w8(w, 0);
	w8(w, 1);
	wf(w, 1.0f);
}

static void malformed_encodings_fail_with_their_code(void)
{
	static const struct bad cases[] = {
	    {"empty", b_empty, BC_EPROTO_TRUNCATED, "empty"},
	    {"reserved flags", b_flags, BC_EPROTO_FLAGS, "0x04"},
	    {"name_count 0", b_names_zero, BC_EPROTO_COUNT, "name_count 0"},
	    {"name_count over the nodes", b_names_over_nodes, BC_EPROTO_COUNT,
	     "name_count 4"},
	    {"name_count over the bytes", b_names_over_bytes, BC_EPROTO_COUNT,
	     "name_count 3"},
	    {"name cut", b_name_cut, BC_EPROTO_TRUNCATED, "name 1"},
	    {"name id 0", b_name_id_zero, BC_ERANGE, "id 0"},
	    {"name ids down", b_name_ids_down, BC_ERANGE, "id 2 after id 3"},
	    {"name id twice", b_name_id_twice, BC_EDUPID, "id 2 after id 2"},
	    {"name empty", b_name_empty, BC_EPROTO_LENGTH, "length 0"},
	    {"name of 65 bytes", b_name_long, BC_EPROTO_LENGTH, "length 65"},
	    {"name short", b_name_short, BC_EPROTO_TRUNCATED, "needs 5 bytes"},
	    {"name not UTF-8", b_name_utf8, BC_ESTRING, "UTF-8"},
	    {"name with NUL", b_name_nul, BC_ESTRING, "NUL"},
	    {"bytes after the names", b_name_trailing, BC_EPROTO_TRAILING,
	     "after the names"},
	    {"name of no node", b_name_unknown_id, BC_ENONODE, "id 9"},
	    {"name of an id-0 node", b_name_of_zero_id, BC_ENONODE, "id 1"},
	    {"camera cut", b_camera_short, BC_EPROTO_TRUNCATED, "camera"},
	    {"camera NaN", b_camera_nan, BC_ENONFINITE, "camera"},
	    {"camera eye == target", b_camera_degenerate, BC_ERANGE, "camera"},
	    {"node_count cut", b_count_short, BC_EPROTO_TRUNCATED,
	     "node_count"},
	    {"node_count 0", b_count_zero, BC_EPROTO_COUNT, "node_count 0"},
	    {"node_count 2^32-1", b_count_max, BC_EPROTO_COUNT,
	     "node_count 4294967295"},
	    {"node_count over the bytes left", b_count_far_over_bytes,
	     BC_EPROTO_COUNT, "left"},
	    {"node_count beyond the nodes", b_count_over_bytes, BC_EPROTO_COUNT,
	     "node 1"},
	    {"tag 0", b_tag_zero, BC_EENUM, "node 0: unknown primitive tag"},
	    {"tag past the kinds", b_tag_prim_count, BC_EENUM,
	     "unknown primitive tag"},
	    {"operator tag 0x80", b_tag_op_zero, BC_EENUM,
	     "node 0: unknown operator tag 0x80"},
	    {"operator tag past the kinds", b_tag_op_count, BC_EENUM,
	     "unknown operator tag"},
	    {"has_color 2", b_has_color, BC_EPROTO_FLAGS, "has_color"},
	    {"nfloats mismatch", b_nfloats, BC_EPROTO_COUNT, "nfloats is 2"},
	    {"NaN translate", b_nan_translate, BC_ENONFINITE,
	     "node 0: translate[0] is not finite"},
	    {"inf radius", b_inf_radius, BC_ENONFINITE, "params[0]"},
	    {"NaN blend", b_nan_blend, BC_ENONFINITE, "node 0: blend"},
	    {"child_count 1", b_child_count_one, BC_EPROTO_COUNT,
	     "child_count 1"},
	    {"child_count over the nodes", b_child_count_over, BC_EPROTO_COUNT,
	     "child_count 3"},
	    {"child_count 2^32-1", b_child_count_max, BC_EPROTO_COUNT,
	     "child_count 4294967295"},
	    {"children missing", b_children_missing, BC_EPROTO_COUNT,
	     "node 0: 1 of its children are missing"},
	    {"nodes beyond the root", b_beyond_root, BC_EPROTO_COUNT,
	     "node 1: the root's subtree ended"},
	    {"too deep", b_too_deep, BC_EDEPTH, "needs a stack of 131"},
	    {"trailing byte", b_trailing, BC_EPROTO_TRAILING, "1 bytes after"},
	    {"duplicate id", b_dup_id, BC_EDUPID, "node 2 (id 7)"},
	    {"sharp operator with a blend", b_sharp_with_blend, BC_ERANGE,
	     "node 0: union takes no blend"},
	    {"smooth operator without blend", b_smooth_zero_blend, BC_ERANGE,
	     "node 0 (id 1)"},
	    {"negative radius", b_negative_radius, BC_ERANGE, "node 0 (id 1)"},
	    {"non-unit quaternion", b_bad_quaternion, BC_ERANGE,
	     "node 0 (id 1)"},
	};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bw w = {0};
		struct bc_errinfo ei = {0};
		bool has = true;
		int rc;
		cases[i].write(&w);
		rc = bc_scene_decode(w.b, w.n, t, NULL, &has, &ei);
		bool ok = rc == cases[i].code && ei.code == rc &&
		          strstr(ei.msg, cases[i].reason) != NULL;
		if (!ok) {
			fprintf(stderr, "  %s: got %s \"%s\", want %s \"%s\"\n",
			        cases[i].what, bc_err_name(rc), ei.msg,
			        bc_err_name(cases[i].code), cases[i].reason);
		}
		CHECK(ok);
		CHECK(!has);
		CHECK(tree_is_empty(t));
	}
	bc_tree_destroy(t);
}

static void depth_at_the_limit_is_accepted(void)
{
	uint32_t n = BC_EVAL_STACK - 1;
	struct bw w = {0};
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	REQUIRE(t);
	w8(&w, 0);
	w32(&w, 2 * n + 1);
	for (uint32_t i = 0; i < n; i++) {
		w_op(&w, BC_OP_UNION, 1000 + i, 0.0f, 0.0f, 2);
		w_sphere(&w, 1 + i, 1.0f, 0.0f);
	}
	w_sphere(&w, 999, 1.0f, 0.0f);
	REQUIRE(w.n < sizeof(w.b));
	CHECK_EQ_INT(bc_scene_decode(w.b, w.n, t, NULL, NULL, &ei), 0);
	CHECK_EQ_INT(bc_tree_node_count(t), 2 * n + 1);
	bc_tree_destroy(t);
}

/* Every proper prefix of a valid encoding fails -- truncated inside some
 * field, or with a count the remaining bytes cannot hold -- and names what
 * was cut. */
static void every_truncation_fails(void)
{
	struct bw w = {0};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	w_valid(&w);
	REQUIRE(bc_scene_decode(w.b, w.n, t, NULL, NULL, NULL) == 0);
	for (size_t len = 0; len < w.n; len++) {
		struct bc_errinfo ei = {0};
		int rc = bc_scene_decode(w.b, len, t, NULL, NULL, &ei);
		CHECK(rc == BC_EPROTO_TRUNCATED || rc == BC_EPROTO_COUNT);
		CHECK(ei.msg[0] != '\0');
		CHECK(tree_is_empty(t));
	}
	bc_tree_destroy(t);
}

static uint64_t mix_state;

static uint64_t mix_next(void)
{
	uint64_t z = (mix_state += 0x9e3779b97f4a7c15ull);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

/* Random byte flips, insertions and cuts of valid encodings: the decoder
 * returns 0 or a code (ASan and UBSan watch for the rest), and whatever it
 * accepts encodes and decodes again. */
static void corrupted_encodings_never_crash(void)
{
	struct bc_tree *src = bc_tree_create(), *t = bc_tree_create(),
	               *u = bc_tree_create();
	struct bc_gen_opts o = {.count = 25, .seed = 77};
	struct bc_camera cam;
	uint8_t *orig = NULL, *buf;
	size_t len = 0;
	int accepted = 0;
	REQUIRE(src && t && u);
	REQUIRE(bc_gen("random", &o, src, &cam, NULL) == 0);
	REQUIRE(bc_scene_encode(src, &cam, &orig, &len) == 0);
	buf = bc_malloc(len + 16);
	REQUIRE(buf);
	mix_state = 1234;
	for (int iter = 0; iter < 3000; iter++) {
		size_t n = len;
		int edits = 1 + (int)(mix_next() % 4);
		int rc;
		memcpy(buf, orig, len);
		for (int e = 0; e < edits; e++) {
			size_t at = (size_t)(mix_next() % n);
			switch (mix_next() % 4) {
			case 0:
				buf[at] ^= (uint8_t)(1u << (mix_next() % 8));
				break;
			case 1:
				buf[at] = (uint8_t)mix_next();
				break;
			case 2:
				n = at;
				break;
			default:
				if (n < len + 16) {
					memmove(buf + at + 1, buf + at, n - at);
					buf[at] = (uint8_t)mix_next();
					n++;
				}
				break;
			}
			if (n == 0) {
				break;
			}
		}
		rc = bc_scene_decode(buf, n, t, NULL, NULL, NULL);
		CHECK(rc <= 0 && rc > -BC_ERR_COUNT);
		if (rc == 0) {
			uint8_t *re = NULL;
			size_t relen = 0;
			accepted++;
			CHECK_EQ_INT(bc_scene_encode(t, NULL, &re, &relen), 0);
			CHECK_EQ_INT(
			    bc_scene_decode(re, relen, u, NULL, NULL, NULL), 0);
			CHECK_EQ_INT(tree_diff(t, u), 0);
			bc_free(re);
		} else {
			CHECK(tree_is_empty(t));
		}
	}
	/* Flips inside float payloads keep some encodings valid. */
	CHECK(accepted > 0);
	bc_free(buf);
	bc_free(orig);
	bc_tree_destroy(src);
	bc_tree_destroy(t);
	bc_tree_destroy(u);
}

static void empty_trees_do_not_encode(void)
{
	struct bc_tree *t = bc_tree_create();
	uint8_t *buf = (uint8_t *)1;
	size_t len = 7;
	REQUIRE(t);
	CHECK_EQ_INT(bc_scene_encode(t, NULL, &buf, &len), BC_EINVAL);
	CHECK(buf == NULL && len == 0);
	CHECK_EQ_INT(bc_scene_prim_nfloats(BC_PRIM_SPHERE), 1);
	CHECK_EQ_INT(bc_scene_prim_nfloats(BC_PRIM_INVALID), 0);
	bc_tree_destroy(t);
}

/* What bc_scene_write_binary hands its sink. */
struct pieces_got {
	uint8_t *bytes;
	size_t len, biggest;
	int calls, fail_at; /* fail_at: the call that says BC_EIO, 0: none */
};

static int collect_piece(void *ctx, const void *p, size_t n)
{
	struct pieces_got *g = ctx;
	if (++g->calls == g->fail_at) {
		return BC_EIO;
	}
	if (!(g->bytes = bc_realloc(g->bytes, g->len + n))) {
		return BC_ENOMEM;
	}
	memcpy(g->bytes + g->len, p, n);
	g->len += n;
	g->biggest = n > g->biggest ? n : g->biggest;
	return 0;
}

static void allocation_failures_are_survived(void)
{
	struct bc_tree *ref = bc_tree_create(), *t = bc_tree_create();
	struct bc_gen_opts o = {.count = 30, .seed = 5};
	struct bc_camera cam;
	uint8_t *bytes = NULL;
	size_t len = 0;
	unsigned long n;
	int failures = 0;
	REQUIRE(ref && t);
	REQUIRE(bc_gen("random", &o, ref, &cam, NULL) == 0);
	for (n = 1; n < 100000; n++) {
		int rc;
		bc_alloc_fail_after(n);
		rc = bc_scene_encode(ref, &cam, &bytes, &len);
		bc_alloc_fail_after(0);
		if (rc == 0) {
			break;
		}
		CHECK_EQ_INT(rc, BC_ENOMEM);
		CHECK(bytes == NULL);
		failures++;
	}
	REQUIRE(bytes);
	for (n = 1; n < 100000; n++) {
		struct bc_errinfo ei = {0};
		int rc;
		bc_alloc_fail_after(n);
		rc = bc_scene_decode(bytes, len, t, NULL, NULL, &ei);
		bc_alloc_fail_after(0);
		if (rc == 0) {
			break;
		}
		CHECK_EQ_INT(rc, BC_ENOMEM);
		CHECK(tree_is_empty(t));
		failures++;
	}
	CHECK(failures > 5);
	CHECK_EQ_INT(tree_diff(ref, t), 0);
	bc_free(bytes);
	/* A scene file: encoded, streamed and decoded. */
	for (int step = 0; step < 3; step++) {
		struct bc_camera got;
		uint8_t *file = NULL;
		size_t flen = 0;
		if (step == 2) {
			REQUIRE(bc_scene_file_encode(ref, &cam, &file, &flen) ==
			        0);
		}
		for (n = 1; n < 100000; n++) {
			struct bc_errinfo ei = {0};
			struct pieces_got g = {0};
			int rc;
			bc_alloc_fail_after(n);
			rc = step == 0
			         ? bc_scene_file_encode(ref, &cam, &bytes, &len)
			     : step == 1 ? bc_scene_write_binary(
			                       ref, &cam, collect_piece, &g)
			                 : bc_scene_file_decode(file, flen, t,
			                                        &got, &ei);
			bc_alloc_fail_after(0);
			bc_free(g.bytes);
			if (rc == 0) {
				break;
			}
			CHECK_EQ_INT(rc, BC_ENOMEM);
			CHECK(step != 0 || bytes == NULL);
			CHECK(step != 2 || tree_is_empty(t));
		}
		CHECK(n > 1);
		bc_free(bytes);
		bytes = NULL;
		bc_free(file);
	}
	CHECK_EQ_INT(tree_diff(ref, t), 0);
	bc_tree_destroy(ref);
	bc_tree_destroy(t);
}

/* A binary scene file: the scene and camera back, byte for byte, through
 * bytes and through a file saved atomically; bc_scene_load_file takes it
 * and a JSON file alike. */
static void a_scene_file_round_trips(void)
{
	struct bc_tree *ref = bc_tree_create(), *t = bc_tree_create();
	struct bc_gen_opts o = {.count = 40, .seed = 9};
	struct bc_camera cam, got;
	struct bc_errinfo ei = {0};
	uint8_t *file = NULL, *a = NULL, *b = NULL;
	size_t flen = 0, alen = 0, blen = 0;
	char dir[] = "/tmp/bc-scenefile-XXXXXX", path[64], json[64];
	REQUIRE(ref && t && mkdtemp(dir));
	REQUIRE(bc_gen("random", &o, ref, &cam, NULL) == 0);
	REQUIRE(bc_scene_file_encode(ref, &cam, &file, &flen) == 0);
	REQUIRE(bc_scene_encode(ref, &cam, &a, &alen) == 0);
	CHECK(flen == alen + BC_SCENE_FILE_HEADER);
	CHECK(memcmp(file, BC_SCENE_FILE_MAGIC, 4) == 0);
	CHECK(memcmp(file + BC_SCENE_FILE_HEADER, a, alen) == 0);
	REQUIRE(bc_scene_file_decode(file, flen, t, &got, &ei) == 0);
	CHECK_EQ_INT(tree_diff(ref, t), 0);
	CHECK(memcmp(&got, &cam, sizeof(cam)) == 0);

	snprintf(path, sizeof(path), "%s/s.bin", dir);
	snprintf(json, sizeof(json), "%s/s.json", dir);
	REQUIRE(bc_scene_save_binary(path, ref, &cam, &ei) == 0);
	REQUIRE(bc_scene_save_json(json, ref, &cam, &ei) == 0);
	for (int k = 0; k < 3; k++) {
		const char *p = k == 2 ? json : path;
		int rc = k == 0 ? bc_scene_load_binary(p, t, &got, &ei)
		                : bc_scene_load_file(p, t, &got, &ei);
		REQUIRE(rc == 0);
		REQUIRE(bc_scene_encode(t, &got, &b, &blen) == 0);
		CHECK(blen == alen && memcmp(a, b, alen) == 0);
		bc_free(b);
		b = NULL;
	}
	/* A JSON file is no binary one; a missing file says so. */
	CHECK_EQ_INT(bc_scene_load_binary(json, t, &got, &ei), BC_EPARSE);
	CHECK(strstr(ei.msg, "not a binary scene file") != NULL);
	CHECK(tree_is_empty(t));
	unlink(json);
	CHECK_EQ_INT(bc_scene_load_binary(json, t, &got, &ei), BC_ENOTFOUND);
	CHECK_EQ_INT(bc_scene_load_file(json, t, &got, &ei), BC_ENOTFOUND);
	unlink(path);
	rmdir(dir);
	bc_free(file);
	bc_free(a);
	bc_tree_destroy(ref);
	bc_tree_destroy(t);
}

/* Every byte of a scene file changed, and every length short of it, is
 * refused (the checksum, the header's length or its magic), leaving the
 * tree empty. */
static void every_damaged_scene_file_is_refused(void)
{
	struct bc_tree *ref = bc_tree_create(), *t = bc_tree_create();
	struct bc_gen_opts o = {.count = 12, .seed = 3};
	struct bc_camera cam;
	uint8_t *file = NULL;
	size_t flen = 0;
	REQUIRE(ref && t);
	REQUIRE(bc_gen("random", &o, ref, &cam, NULL) == 0);
	REQUIRE(bc_scene_file_encode(ref, &cam, &file, &flen) == 0);
	for (size_t i = 0; i < flen; i++) {
		for (int bit = 0; bit < 8; bit += 3) {
			struct bc_errinfo ei = {0};
			file[i] ^= (uint8_t)(1u << bit);
			CHECK_EQ_INT(
			    bc_scene_file_decode(file, flen, t, NULL, &ei),
			    BC_EPARSE);
			CHECK(tree_is_empty(t));
			file[i] ^= (uint8_t)(1u << bit);
		}
	}
	for (size_t n = 0; n < flen; n++) {
		struct bc_errinfo ei = {0};
		CHECK_EQ_INT(bc_scene_file_decode(file, n, t, NULL, &ei),
		             BC_EPARSE);
	}
	CHECK_EQ_INT(bc_scene_file_decode(file, flen, t, NULL, NULL), 0);
	bc_free(file);
	bc_tree_destroy(ref);
	bc_tree_destroy(t);
}

/* The streamed encoding is bc_scene_encode's bytes in pieces of about
 * 256 KiB; a sink's error stops it at once; a file written through a
 * descriptor is bc_scene_file_encode's bytes. */
static void a_streamed_encoding_is_the_same_bytes(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_gen_opts o = {.count = 20000};
	struct bc_camera cam;
	struct pieces_got g = {0}, stop = {.fail_at = 2};
	uint8_t *whole = NULL, *file = NULL, *back = NULL;
	size_t wlen = 0, flen = 0;
	char path[] = "/tmp/bc-scenefile-XXXXXX";
	int fd;
	REQUIRE(t);
	REQUIRE(bc_gen("fig18", &o, t, &cam, NULL) == 0);
	REQUIRE(bc_tree_set_name(t, bc_tree_lin(t)->node_id[3], "third", 5,
	                         NULL) == 0);
	REQUIRE(bc_scene_encode(t, &cam, &whole, &wlen) == 0);
	REQUIRE(wlen > 2u * 256u * 1024u);
	CHECK_EQ_INT(bc_scene_write_binary(t, &cam, collect_piece, &g), 0);
	CHECK(g.len == wlen && memcmp(g.bytes, whole, wlen) == 0);
	CHECK(g.calls >= 3);
	CHECK(g.biggest < 256u * 1024u + 2048u);
	CHECK_EQ_INT(bc_scene_write_binary(t, &cam, collect_piece, &stop),
	             BC_EIO);
	CHECK_EQ_INT(stop.calls, 2);

	REQUIRE((fd = mkstemp(path)) >= 0);
	CHECK_EQ_INT(bc_scene_file_write_fd(fd, t, &cam), 0);
	REQUIRE(bc_scene_file_encode(t, &cam, &file, &flen) == 0);
	REQUIRE((back = bc_malloc(flen + 1)));
	CHECK(pread(fd, back, flen + 1, 0) == (ssize_t)flen);
	CHECK(memcmp(back, file, flen) == 0);
	close(fd);
	unlink(path);
	bc_free(back);
	bc_free(file);
	bc_free(whole);
	bc_free(g.bytes);
	bc_free(stop.bytes);
	bc_tree_destroy(t);
}

/* bc_scene_head_count, which the daemon sizes a scene by before decoding
 * it (also from the first part of a scene in parts), reads the count the
 * decoder builds, with the camera or without, from the head alone, and
 * gives 0 where the decoder refuses the count for the bytes. */
static void the_head_count_is_what_the_decoder_builds(void)
{
	static const struct {
		void (*make)(struct bw *w);
		const char *what;
	} bad[] = {
	    {b_empty, "empty"},
	    {b_camera_short, "camera cut"},
	    {b_count_short, "node_count cut"},
	    {b_count_zero, "node_count 0"},
	    {b_count_max, "node_count 2^32-1"},
	    {b_count_far_over_bytes, "node_count over the bytes left"},
	};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	REQUIRE(t);
	REQUIRE(bc_gen("comb", &(struct bc_gen_opts){.count = 1000}, t, &cam,
	               NULL) == 0);
	for (int with = 0; with < 2; with++) {
		uint8_t *buf = NULL;
		size_t len = 0, head = with ? BC_SCENE_HEAD_MAX_BYTES : 5u;
		uint32_t n = bc_tree_node_count(t);
		REQUIRE(bc_scene_encode(t, with ? &cam : NULL, &buf, &len) ==
		        0);
		CHECK_EQ_INT(bc_scene_head_count(buf, len, len), n);
		CHECK_EQ_INT(bc_scene_head_count(buf, head, len), n);
		CHECK_EQ_INT(bc_scene_head_count(buf, head - 1u, len), 0);
		/* Fewer bytes than n nodes of the smallest size. */
		CHECK_EQ_INT(
		    bc_scene_head_count(
		        buf, head, head + BC_SCENE_NODE_MIN_BYTES * n - 1u),
		    0);
		CHECK_EQ_INT(bc_scene_head_count(
		                 buf, head, head + BC_SCENE_NODE_MIN_BYTES * n),
		             n);
		bc_free(buf);
	}
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct bw w = {0};
		bad[i].make(&w);
		if (bc_scene_head_count(w.b, w.n, w.n) != 0) {
			printf("  %s: counted\n", bad[i].what);
			CHECK(0 && "a count the decoder refuses was read");
		}
	}
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"every_generator_round_trips_through_binary",
     every_generator_round_trips_through_binary},
    {"random_trees_round_trip_through_binary",
     random_trees_round_trip_through_binary},
    {"hand_written_scene_decodes_to_its_fields",
     hand_written_scene_decodes_to_its_fields},
    {"documented_example_decodes", documented_example_decodes},
    {"zero_ids_get_fresh_ids", zero_ids_get_fresh_ids},
    {"malformed_encodings_fail_with_their_code",
     malformed_encodings_fail_with_their_code},
    {"depth_at_the_limit_is_accepted", depth_at_the_limit_is_accepted},
    {"every_truncation_fails", every_truncation_fails},
    {"corrupted_encodings_never_crash", corrupted_encodings_never_crash},
    {"empty_trees_do_not_encode", empty_trees_do_not_encode},
    {"allocation_failures_are_survived", allocation_failures_are_survived},
    {"a_scene_file_round_trips", a_scene_file_round_trips},
    {"every_damaged_scene_file_is_refused",
     every_damaged_scene_file_is_refused},
    {"a_streamed_encoding_is_the_same_bytes",
     a_streamed_encoding_is_the_same_bytes},
    {"the_head_count_is_what_the_decoder_builds",
     the_head_count_is_what_the_decoder_builds},
};

BC_TEST_MAIN(tests)
