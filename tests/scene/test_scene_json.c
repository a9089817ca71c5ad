/*
 * JSON scene files: writing then reading reproduces every generator's scene
 * and random trees bit for bit; a table of bad files each fails with its
 * code and a message naming the JSON path; ids are assigned without
 * colliding with later explicit ones; saving is atomic and loading bounded;
 * the built-in scene is valid and framed by its camera; and every
 * allocation failure during parse and write is survived without leaks.
 */
#include <dirent.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "scene_util.h"
#include "test.h"

/* Writes t, parses the text, writes and parses again: every tree and
 * camera must be identical to the first. */
static void check_json_round_trip(const struct bc_tree *t,
                                  const struct bc_camera *cam)
{
	struct bc_tree *u = bc_tree_create(), *w = bc_tree_create();
	struct bc_camera cu, cw;
	struct bc_errinfo ei = {0};
	char *text = bc_scene_to_json(t, cam), *again = NULL;
	int rc;
	REQUIRE(u && w && text);
	rc = bc_scene_parse_json(text, strlen(text), u, &cu, &ei);
	if (rc) {
		fprintf(stderr, "  parse: %s\n", ei.msg);
	}
	CHECK_EQ_INT(rc, 0);
	CHECK_EQ_INT(tree_diff(t, u), 0);
	if (cam) {
		CHECK(same_camera(cam, &cu));
	}
	again = bc_scene_to_json(u, &cu);
	REQUIRE(again != NULL);
	CHECK_EQ_INT(bc_scene_parse_json(again, strlen(again), w, &cw, NULL),
	             0);
	CHECK_EQ_INT(tree_diff(u, w), 0);
	CHECK(same_camera(&cu, &cw));
	bc_free(text);
	bc_free(again);
	bc_tree_destroy(u);
	bc_tree_destroy(w);
}

static void every_generator_round_trips_through_json(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
	} cases[] = {
	    {"fig16", {.level = 1}},
	    {"fig16", {.level = 2, .blend = BC_GEN_BLEND_SHARP}},
	    {"fig16", {.level = 3, .seed = 5}},
	    {"fig18", {.count = 40, .kind = BC_GEN_KIND_BOXES}},
	    {"fig18",
	     {.count = 33,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SHARP}},
	    {"fig18", {.count = 20, .kind = BC_GEN_KIND_LENSES}},
	    {"comb", {.count = 100, .blend = BC_GEN_BLEND_SMOOTH}},
	    {"random", {.count = 300, .seed = 11}},
	    {"gears", {.teeth = 30}},
	    {"many-gears", {.count = 6, .seed = 2}},
	    {"many-spheres", {.count = 500}},
	};
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		int rc = bc_gen(cases[i].name, &cases[i].o, t, &cam, &ei);
		if (rc) {
			fprintf(stderr, "  %s: %s\n", cases[i].name, ei.msg);
		}
		CHECK_EQ_INT(rc, 0);
		if (!rc) {
			check_json_round_trip(t, &cam);
		}
	}
	bc_tree_destroy(t);
}

static void random_trees_round_trip_through_json(void)
{
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (uint64_t seed = 100; seed < 140; seed++) {
		struct bc_gen_opts o = {.count = 1 + (uint32_t)(seed % 37),
		                        .seed = seed,
		                        .depth = 2 + (uint32_t)(seed % 20)};
		struct bc_camera cam;
		REQUIRE(bc_gen("random", &o, t, &cam, NULL) == 0);
		check_json_round_trip(t, &cam);
		check_json_round_trip(t, NULL);
	}
	bc_tree_destroy(t);
}

/* Floats that printf-based writers get wrong: negative zero, subnormals,
 * values needing all nine digits, the largest allowed magnitudes. */
static void awkward_floats_round_trip_exactly(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_op_data u = {BC_OP_SMOOTH_UNION, 0.123456791f, 0.987654328f};
	struct bc_camera cam;
	REQUIRE(t);
	bc_camera_default(&cam);
	cam.eye[0] = -0.0f;
	cam.eye[1] = 1.00000012f;
	cam.fov_y_deg = 33.3333321f;
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 4294967295u, &u, NULL) == 0);
	bc_prim_data_init(&p, BC_PRIM_SPHERE);
	p.params[0] = 0.1f;
	p.translate[0] = -0.0f;
	p.translate[1] = 1.0e-40f; /* subnormal */
	p.translate[2] = 999999.938f;
	REQUIRE(bc_tree_put_prim(t, 1, &p, NULL) == 0);
	bc_prim_data_init(&p, BC_PRIM_BOX);
	p.params[0] = 1.23456791e-6f;
	p.params[1] = 16777217.0f / 33554432.0f;
	p.params[2] = 1.0e6f;
	p.translate[0] = -123456.789f;
	p.translate[1] = 7.0e-8f;
	p.translate[2] = 0.300000012f;
	p.has_color = true;
	p.color[0] = 0.0f;
	p.color[1] = 1.0f;
	p.color[2] = 0.333333343f;
	REQUIRE(bc_tree_put_prim(t, 2, &p, NULL) == 0);
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	check_json_round_trip(t, &cam);
	bc_tree_destroy(t);
}

/* The text each float is written as: six significant digits when they
 * read back, else nine (printf's %g forms), over magnitudes from 1e-25 to
 * 1e6 (a parameter's bound), exact halves and integers. */
static void floats_are_written_in_their_shortest_g_form(void)
{
	enum { SPHERES = 3000 };
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	static float want[SPHERES][3];
	uint64_t x = 88172645463325252ull;
	char *text, *at;
	REQUIRE(t);
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 0, &u, NULL) == 0);
	for (int i = 0; i < SPHERES; i++) {
		struct bc_prim_data p;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		for (int k = 0; k < 3; k++) {
			double m;
			x ^= x << 13;
			x ^= x >> 7;
			x ^= x << 17;
			m = (double)(x >> 11) / 9007199254740992.0;
			switch (i % 3) {
			case 0: /* any magnitude */
				want[i][k] =
				    (float)(m *
				            pow(10.0, (double)(x % 31) - 25.0));
				break;
			case 1: /* exact halves and quarters near a million */
				want[i][k] =
				    (float)((double)(x % 8000000) / 8.0);
				break;
			default: /* typed by hand */
				want[i][k] =
				    (float)((double)(x % 2000001) / 1000.0 -
				            1000.0);
			}
			if (x & 1u) {
				want[i][k] = -want[i][k];
			}
			p.translate[k] = want[i][k];
		}
		REQUIRE(bc_tree_put_prim(t, 0, &p, NULL) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	REQUIRE((text = bc_scene_to_json(t, NULL)));
	at = text;
	for (int i = 0; i < SPHERES; i++) {
		REQUIRE((at = strstr(at, "\"translate\": [")));
		at += strlen("\"translate\": [");
		for (int k = 0; k < 3; k++) {
			char ref[40];
			size_t n;
			snprintf(ref, sizeof(ref), "%.6g", (double)want[i][k]);
			if ((float)strtod(ref, NULL) != want[i][k]) {
				snprintf(ref, sizeof(ref), "%.9g",
				         (double)want[i][k]);
			}
			n = strlen(ref);
			CHECK(strncmp(at, ref, n) == 0 &&
			      (at[n] == ',' || at[n] == ']'));
			at += n + (k < 2 ? 2 : 1);
		}
	}
	bc_free(text);
	bc_tree_destroy(t);
}

/* A file with every optional field left out gets the documented defaults;
 * ids are assigned where missing without taking an id named later. */
static void defaults_and_assigned_ids(void)
{
	static const char text[] =
	    "{\"blobcast\": 1, \"root\": {\"type\": \"smooth_union\", "
	    "\"blend\": 0.2, \"children\": [\n"
	    "  {\"type\": \"sphere\", \"radius\": 1},\n"
	    "  {\"type\": \"box\", \"id\": 1, \"half_extents\": [1, 2, 3]},\n"
	    "  {\"type\": \"sphere\", \"id\": 3, \"radius\": 0.5}]}}";
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam, def;
	struct bc_prim_data p;
	struct bc_op_data op;
	uint32_t root, c0;
	REQUIRE(t);
	REQUIRE(bc_scene_parse_json(text, sizeof(text) - 1, t, &cam, NULL) ==
	        0);
	bc_camera_default(&def);
	CHECK(same_camera(&cam, &def));
	CHECK_EQ_INT(bc_tree_node_count(t), 4);
	root = bc_tree_root(t);
	CHECK(root != 0 && root != 1 && root != 3);
	REQUIRE(bc_tree_get(t, root, NULL, &op));
	CHECK_EQ_INT(op.kind, BC_OP_SMOOTH_UNION);
	CHECK(op.range == bc_op_default_range(0.2f));
	c0 = bc_tree_child(t, root, 0);
	CHECK(c0 != 0 && c0 != 1 && c0 != 3 && c0 != root);
	CHECK_EQ_INT(bc_tree_child(t, root, 1), 1);
	CHECK_EQ_INT(bc_tree_child(t, root, 2), 3);
	REQUIRE(bc_tree_get(t, 1, &p, NULL));
	CHECK_EQ_INT(p.kind, BC_PRIM_BOX);
	CHECK(p.params[0] == 1.0f && p.params[1] == 2.0f &&
	      p.params[2] == 3.0f);
	CHECK(p.translate[0] == 0.0f && p.translate[1] == 0.0f &&
	      p.translate[2] == 0.0f);
	CHECK(p.rotate[0] == 0.0f && p.rotate[3] == 1.0f);
	CHECK(!p.has_color);
	bc_tree_destroy(t);
}

struct bad_case {
	const char *text;
	int code;
	const char *reason; /* substring of the message */
};

/* A chain of n nested unions, each with a sphere beside the next level. */
static char *nested_unions(uint32_t n)
{
	size_t cap = 64 + (size_t)n * 120;
	char *s = bc_malloc(cap);
	size_t len = 0;
	if (!s) {
		return NULL;
	}
	len += (size_t)snprintf(s + len, cap - len,
	                        "{\"blobcast\": 1, \"root\": ");
	for (uint32_t i = 0; i < n; i++) {
		len += (size_t)snprintf(
		    s + len, cap - len,
		    "{\"type\": \"union\", \"children\": [{\"type\": "
		    "\"sphere\", \"radius\": 1}, ");
	}
	len += (size_t)snprintf(s + len, cap - len,
	                        "{\"type\": \"sphere\", \"radius\": 1}");
	for (uint32_t i = 0; i < n; i++) {
		len += (size_t)snprintf(s + len, cap - len, "]}");
	}
	snprintf(s + len, cap - len, "}");
	return s;
}

static void bad_files_fail_with_path_and_reason(void)
{
#define DOC(root) "{\"blobcast\": 1, \"root\": " root "}"
#define S1 "{\"type\": \"sphere\", \"radius\": 1}"
	static const struct bad_case cases[] = {
	    {"", BC_EPARSE, "line 1"},
	    {"{\"blobcast\": 1, \"root\": " S1, BC_EPARSE, "line"},
	    {DOC(S1) " trailing", BC_EPARSE, "line"},
	    {"[1, 2]", BC_EPARSE, "expected an object, got array"},
	    {"{\"blobcast\": 2, \"root\": " S1 "}", BC_ENOTSUP,
	     "blobcast: version 2 is not supported"},
	    {"{\"root\": " S1 "}", BC_EPARSE, "missing key \"blobcast\""},
	    {"{\"blobcast\": \"1\", \"root\": " S1 "}", BC_EPARSE,
	     "blobcast: expected an integer, got string"},
	    {"{\"blobcast\": 1}", BC_EPARSE, "missing key \"root\""},
	    {"{\"blobcast\": 1, \"rooot\": " S1 "}", BC_EPARSE,
	     "unknown key \"rooot\""},
	    {"{\"blobcast\": 1, \"blobcast\": 1, \"root\": " S1 "}", BC_EPARSE,
	     "duplicate"},
	    {DOC("{\"type\": \"spher\", \"radius\": 1}"), BC_EENUM,
	     "root: unknown primitive type \"spher\""},
	    {DOC("{\"type\": \"unoin\", \"children\": [" S1 ", " S1 "]}"),
	     BC_EENUM, "root: unknown operator type \"unoin\""},
	    {DOC("{\"radius\": 1}"), BC_EPARSE, "root: missing key \"type\""},
	    {DOC("{\"type\": 7, \"radius\": 1}"), BC_EPARSE,
	     "root.type: expected a string, got integer"},
	    {DOC("[1]"), BC_EPARSE, "root: expected a node object, got array"},
	    {DOC("{\"type\": \"union\", \"children\": [" S1 ", " S1 ", "
	         "{\"type\": \"box\", \"half_extents\": [1, \"2\", 3]}]}"),
	     BC_EPARSE,
	     "root.children[2].half_extents[1]: expected a number, got "
	     "string"},
	    {DOC("{\"type\": \"box\", \"half_extents\": [1, 2]}"), BC_EPARSE,
	     "root.half_extents: expected an array of 3 numbers, got 2"},
	    {DOC("{\"type\": \"box\", \"half_extents\": 1}"), BC_EPARSE,
	     "root.half_extents: expected an array of 3 numbers, got "
	     "integer"},
	    {DOC("{\"type\": \"sphere\"}"), BC_EPARSE,
	     "root: missing key \"radius\""},
	    {DOC("{\"type\": \"sphere\", \"radius\": 1, \"radius2\": 1}"),
	     BC_EPARSE, "root: unknown key \"radius2\" for sphere"},
	    {DOC("{\"type\": \"sphere\", \"radius\": -1}"), BC_ERANGE,
	     "root: "},
	    {DOC("{\"type\": \"sphere\", \"radius\": true}"), BC_EPARSE,
	     "root.radius: expected a number, got true"},
	    {DOC("{\"type\": \"sphere\", \"radius\": 1, \"translate\": "
	         "[1e39, 0, 0]}"),
	     BC_ENONFINITE, "root.translate[0]: "},
	    {DOC("{\"type\": \"sphere\", \"radius\": 1e999}"), BC_ENONFINITE,
	     "overflow"},
	    {DOC("{\"type\": \"sphere\", \"radius\": NaN}"), BC_EPARSE,
	     "line 1"},
	    {DOC("{\"type\": \"sphere\", \"radius\": 1, \"color\": [\"red\", "
	         "0, 0]}"),
	     BC_EPARSE, "root.color[0]: expected a number, got string"},
	    {DOC("{\"type\": \"sphere\", \"radius\": 1, \"rotate\": [0, 0, "
	         "0, 2]}"),
	     BC_ERANGE, "root: "},
	    {DOC("{\"type\": \"sphere\", \"id\": 0, \"radius\": 1}"), BC_ERANGE,
	     "root.id: 0 is outside 1..4294967295"},
	    {DOC("{\"type\": \"sphere\", \"id\": 4294967296, \"radius\": 1}"),
	     BC_ERANGE, "root.id: 4294967296 is outside"},
	    {DOC("{\"type\": \"sphere\", \"id\": 1.5, \"radius\": 1}"),
	     BC_EPARSE, "root.id: expected an integer, got real number"},
	    {DOC("{\"type\": \"union\", \"children\": [{\"type\": "
	         "\"sphere\", \"id\": 5, \"radius\": 1}, {\"type\": "
	         "\"sphere\", \"id\": 5, \"radius\": 1}]}"),
	     BC_EDUPID, "root.children[1]: "},
	    {DOC("{\"type\": \"union\", \"children\": [" S1 "]}"), BC_EINVAL,
	     "root.children: an operator needs two or more children, got "
	     "1"},
	    {DOC("{\"type\": \"union\", \"children\": {}}"), BC_EPARSE,
	     "root.children: expected an array, got object"},
	    {DOC("{\"type\": \"union\"}"), BC_EPARSE,
	     "root: missing key \"children\""},
	    {DOC("{\"type\": \"union\", \"children\": [1, " S1 "]}"), BC_EPARSE,
	     "root.children[0]: expected a node object, got integer"},
	    {DOC("{\"type\": \"smooth_union\", \"children\": [" S1 ", " S1
	         "]}"),
	     BC_EPARSE, "root: missing key \"blend\""},
	    {DOC("{\"type\": \"union\", \"blend\": 0.1, \"children\": [" S1
	         ", " S1 "]}"),
	     BC_EPARSE, "root: \"blend\" is only for smooth operators"},
	    {DOC("{\"type\": \"smooth_union\", \"blend\": 0, \"children\": "
	         "[" S1 ", " S1 "]}"),
	     BC_ERANGE, "root: "},
	    {DOC("{\"type\": \"smooth_union\", \"blend\": 0.1, \"range\": 0, "
	         "\"children\": [" S1 ", " S1 "]}"),
	     BC_ERANGE, "root.range: 0 must be positive"},
	    {DOC("{\"type\": \"smooth_union\", \"blend\": 0.6, \"range\": "
	         "0.05, \"children\": [" S1 ", " S1 "]}"),
	     BC_ERANGE, "root: "},
	    {DOC("{\"type\": \"sphere\", \"radius\": \"a\\u0000b\"}"),
	     BC_EPARSE, "line 1"},
	    {"{\"blobcast\": 1, \"camera\": {\"fov\": 40}, \"root\": " S1 "}",
	     BC_EPARSE, "camera: unknown key \"fov\""},
	    {"{\"blobcast\": 1, \"camera\": [], \"root\": " S1 "}", BC_EPARSE,
	     "camera: expected an object, got array"},
	    {"{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, \"x\"]}, "
	     "\"root\": " S1 "}",
	     BC_EPARSE, "camera.eye[2]: expected a number, got string"},
	    {"{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 0]}, "
	     "\"root\": " S1 "}",
	     BC_ERANGE, "camera: "},
	    {"{\"blobcast\": 1, \"camera\": {\"fov_y_deg\": 180}, "
	     "\"root\": " S1 "}",
	     BC_ERANGE, "camera: "},
	};
#undef DOC
#undef S1
	struct bc_tree *t = bc_tree_create();
	REQUIRE(t);
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct bc_errinfo ei = {0};
		struct bc_camera cam, def;
		int rc = bc_scene_parse_json(
		    cases[i].text, strlen(cases[i].text), t, &cam, &ei);
		bool ok = rc == cases[i].code && ei.code == rc &&
		          strstr(ei.msg, cases[i].reason) != NULL;
		if (!ok) {
			fprintf(stderr,
			        "  case %zu: got %s \"%s\", want %s \"%s\"\n",
			        i, bc_err_name(rc), ei.msg,
			        bc_err_name(cases[i].code), cases[i].reason);
		}
		CHECK(ok);
		CHECK(tree_is_empty(t));
		bc_camera_default(&def);
		CHECK(same_camera(&cam, &def));
	}
	bc_tree_destroy(t);
}

static void nesting_is_limited_to_the_tree_depth(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	/* n nested unions put the innermost spheres at depth n + 1; these
	 * nest in right operands, so the evaluation stack bounds them. */
	char *fits = nested_unions(BC_EVAL_STACK - 1);
	char *stack = nested_unions(BC_EVAL_STACK);
	/* Past what jansson's parser holds (left chains up to that depth
	 * are read: tests/scene/test_scene_deep.c). */
	char *over = nested_unions(BC_SCENE_JSON_MAX_DEPTH);
	REQUIRE(t && fits && stack && over);
	CHECK_EQ_INT(bc_scene_parse_json(fits, strlen(fits), t, NULL, &ei), 0);
	CHECK_EQ_INT(bc_tree_node_count(t), 2 * (BC_EVAL_STACK - 1) + 1);
	CHECK_EQ_INT(bc_scene_parse_json(stack, strlen(stack), t, NULL, &ei),
	             BC_EDEPTH);
	CHECK(strstr(ei.msg, "stack") != NULL);
	CHECK(tree_is_empty(t));
	CHECK_EQ_INT(bc_scene_parse_json(over, strlen(over), t, NULL, &ei),
	             BC_EDEPTH);
	CHECK(strstr(ei.msg, "binary form") != NULL);
	CHECK(tree_is_empty(t));
	bc_free(fits);
	bc_free(stack);
	bc_free(over);
	bc_tree_destroy(t);
}

static void oversized_text_is_refused_before_parsing(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	static const char small[] = "{}";
	REQUIRE(t);
	/* The length is checked before a byte is read. */
	CHECK_EQ_INT(bc_scene_parse_json(small,
	                                 (size_t)BC_SCENE_JSON_MAX_BYTES + 1, t,
	                                 NULL, &ei),
	             BC_ELIMIT);
	CHECK(strstr(ei.msg, "limit") != NULL);
	bc_tree_destroy(t);
}

static void make_temp_dir(char *dir, size_t cap)
{
	snprintf(dir, cap, "/tmp/bc-scene-XXXXXX");
	if (!mkdtemp(dir)) {
		dir[0] = '\0';
	}
}

/* Number of entries in dir besides . and .. */
static int dir_entries(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	int n = 0;
	if (!d) {
		return -1;
	}
	while ((e = readdir(d))) {
		if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
			n++;
		}
	}
	closedir(d);
	return n;
}

static void save_is_atomic_and_load_reads_it_back(void)
{
	struct bc_tree *t = bc_tree_create(), *u = bc_tree_create();
	struct bc_gen_opts o = {.level = 2};
	struct bc_camera cam, cu;
	struct bc_errinfo ei = {0};
	char dir[64], path[128], big[128];
	int fd;
	REQUIRE(t && u);
	make_temp_dir(dir, sizeof(dir));
	REQUIRE(dir[0]);
	snprintf(path, sizeof(path), "%s/scene.json", dir);
	REQUIRE(bc_gen("fig16", &o, t, &cam, NULL) == 0);
	CHECK_EQ_INT(bc_scene_save_json(path, t, &cam, &ei), 0);
	/* Overwriting an existing file leaves exactly that one file. */
	CHECK_EQ_INT(bc_scene_save_json(path, t, &cam, &ei), 0);
	CHECK_EQ_INT(dir_entries(dir), 1);
	CHECK_EQ_INT(bc_scene_load_json(path, u, &cu, &ei), 0);
	CHECK_EQ_INT(tree_diff(t, u), 0);
	CHECK(same_camera(&cam, &cu));

	/* Missing files, directories and unwritable places. */
	snprintf(big, sizeof(big), "%s/missing.json", dir);
	CHECK_EQ_INT(bc_scene_load_json(big, u, NULL, &ei), BC_ENOTFOUND);
	CHECK(tree_is_empty(u));
	CHECK_EQ_INT(bc_scene_load_json(dir, u, NULL, &ei), BC_EIO);
	snprintf(big, sizeof(big), "%s/no/such/dir.json", dir);
	CHECK_EQ_INT(bc_scene_save_json(big, t, &cam, &ei), BC_EIO);
	bc_tree_begin(u);
	CHECK_EQ_INT(bc_scene_save_json(path, u, &cam, &ei), BC_EINVAL);

	/* A file over the limit is refused from its size alone (a sparse
	 * file: no disk space used). */
	snprintf(big, sizeof(big), "%s/big.json", dir);
	fd = open(big, O_WRONLY | O_CREAT | O_TRUNC, 0600);
	REQUIRE(fd >= 0);
	CHECK(ftruncate(fd, (off_t)BC_SCENE_JSON_MAX_BYTES + 1) == 0);
	close(fd);
	CHECK_EQ_INT(bc_scene_load_json(big, u, NULL, &ei), BC_ELIMIT);
	unlink(big);
	unlink(path);
	rmdir(dir);
	bc_tree_destroy(t);
	bc_tree_destroy(u);
}

/* Distance along the ray from eye in direction d to the first surface, by
 * sphere tracing the full field; negative when nothing is hit. */
static float trace(const struct bc_lin *l, const float eye[3], const float d[3],
                   float far)
{
	float t = 0.0f;
	for (int i = 0; i < 400 && t < far; i++) {
		float p[3] = {eye[0] + t * d[0], eye[1] + t * d[1],
		              eye[2] + t * d[2]};
		float f = bc_eval_full(l, p);
		if (f < 1e-3f) {
			return t;
		}
		t += fmaxf(f, 1e-3f);
	}
	return -1.0f;
}

static void default_scene_is_valid_and_framed(void)
{
	const char *text = bc_scene_default_json();
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	struct bc_scene_walk w;
	struct bc_scene_node n;
	struct bc_view_rays vr;
	bool kinds[BC_PRIM_COUNT] = {0}, ops[BC_OP_COUNT] = {0};
	int nkinds = 0, nops = 0, hits = 0, colored = 0;
	const struct bc_lin *l;
	REQUIRE(t);
	CHECK_EQ_INT(bc_scene_parse_json(text, strlen(text), t, &cam, &ei), 0);
	if (ei.code) {
		fprintf(stderr, "  %s\n", ei.msg);
	}
	REQUIRE(bc_tree_root(t) != 0);
	CHECK(bc_tree_prim_count(t) >= 10 && bc_tree_prim_count(t) <= 30);
	CHECK_EQ_INT(bc_camera_validate(&cam, NULL), 0);
	REQUIRE(bc_scene_walk_init(&w, t) == 0);
	while (bc_scene_walk_next(&w, &n)) {
		if (n.is_op) {
			nops += !ops[n.op.kind];
			ops[n.op.kind] = true;
		} else {
			nkinds += !kinds[n.prim.kind];
			kinds[n.prim.kind] = true;
			colored += n.prim.has_color;
		}
	}
	bc_scene_walk_finish(&w);
	CHECK(nkinds >= 4);
	CHECK(nops >= 4);
	CHECK(ops[BC_OP_UNION] && ops[BC_OP_SMOOTH_UNION]);
	CHECK_EQ_INT(colored, (int)bc_tree_prim_count(t));
	/* Seen from its camera the scene fills a good part of the view, and
	 * the view centre lands on it. */
	l = bc_tree_lin(t);
	REQUIRE(l);
	bc_view_rays_init(&vr, &cam, 24, 18);
	for (uint32_t j = 0; j < 18; j++) {
		for (uint32_t i = 0; i < 24; i++) {
			float d[3];
			bc_view_rays_dir(&vr, (float)i + 0.5f, (float)j + 0.5f,
			                 d);
			hits += trace(l, cam.eye, d, 30.0f) >= 0.0f;
		}
	}
	CHECK(hits > 24 * 18 / 4);
	CHECK(hits < 24 * 18);
	{
		float d[3];
		bc_view_rays_dir(&vr, 12.0f, 9.0f, d);
		CHECK(trace(l, cam.eye, d, 30.0f) > 0.0f);
	}
	check_json_round_trip(t, &cam);
	bc_tree_destroy(t);
}

/* What a sink saw: the pieces' text joined, the longest piece, and the
 * piece after which it fails (0: never). */
struct pieces {
	char *text;
	size_t len, cap, longest;
	int n, fail_at;
};

static int collect(void *ctx, const void *bytes, size_t len)
{
	struct pieces *p = ctx;
	if (p->fail_at && p->n + 1 == p->fail_at) {
		return BC_EIO;
	}
	if (p->len + len + 1 > p->cap) {
		char *grown = bc_realloc(p->text, 2 * (p->len + len + 1));
		if (!grown) {
			return BC_ENOMEM;
		}
		p->text = grown;
		p->cap = 2 * (p->len + len + 1);
	}
	memcpy(p->text + p->len, bytes, len);
	p->len += len;
	p->text[p->len] = '\0';
	p->longest = len > p->longest ? len : p->longest;
	p->n++;
	return 0;
}

/* bc_scene_write_json hands the very text of bc_scene_to_json to its sink
 * in bounded pieces (a snapshot of a million primitives is never whole
 * in memory), stops at the sink's error, and refuses an empty tree. */
static void streamed_text_is_the_whole_text_in_pieces(void)
{
	struct bc_tree *t = bc_tree_create(), *empty = bc_tree_create();
	struct bc_gen_opts o = {.count = 20000,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SMOOTH};
	struct bc_camera cam;
	struct pieces p = {0}, q = {.fail_at = 3};
	char *whole;
	REQUIRE(t && empty);
	REQUIRE(bc_gen("fig18", &o, t, &cam, NULL) == 0);
	REQUIRE((whole = bc_scene_to_json(t, &cam)) != NULL);
	CHECK_EQ_INT(bc_scene_write_json(t, &cam, collect, &p), 0);
	printf("  %zu bytes in %d pieces, the longest %zu\n", p.len, p.n,
	       p.longest);
	REQUIRE(p.text != NULL);
	CHECK(strcmp(p.text, whole) == 0);
	CHECK(p.n > 4);
	CHECK(p.longest <= 256u * 1024u + 4096u);
	CHECK_EQ_INT(bc_scene_write_json(t, &cam, collect, &q), BC_EIO);
	CHECK_EQ_INT(q.n, 2);
	CHECK_EQ_INT(bc_scene_write_json(empty, NULL, collect, &p), BC_EINVAL);
	bc_free(whole);
	bc_free(p.text);
	bc_free(q.text);
	bc_tree_destroy(t);
	bc_tree_destroy(empty);
}

/* Every allocation during parse (jansson's included) and write may fail:
 * each failure must come back as BC_ENOMEM (or NULL) with everything
 * freed -- ASan's leak checker watches -- until the run that succeeds. */
static void allocation_failures_are_survived(void)
{
	struct bc_tree *t = bc_tree_create(), *ref = bc_tree_create();
	struct bc_gen_opts o = {.count = 12, .seed = 3};
	struct bc_camera cam;
	char *text;
	unsigned long n;
	int failures = 0;
	REQUIRE(t && ref);
	REQUIRE(bc_gen("random", &o, ref, &cam, NULL) == 0);
	text = bc_scene_to_json(ref, &cam);
	REQUIRE(text);
	for (n = 1; n < 100000; n++) {
		struct bc_errinfo ei = {0};
		int rc;
		bc_alloc_fail_after(n);
		rc = bc_scene_parse_json(text, strlen(text), t, NULL, &ei);
		bc_alloc_fail_after(0);
		if (rc == 0) {
			break;
		}
		failures++;
		if (rc != BC_ENOMEM) {
			fprintf(stderr, "  n=%lu: %s %s\n", n, bc_err_name(rc),
			        ei.msg);
		}
		CHECK_EQ_INT(rc, BC_ENOMEM);
		CHECK(tree_is_empty(t));
	}
	CHECK(failures > 10);
	CHECK_EQ_INT(tree_diff(ref, t), 0);
	for (n = 1; n < 100000; n++) {
		char *out;
		bc_alloc_fail_after(n);
		out = bc_scene_to_json(ref, &cam);
		bc_alloc_fail_after(0);
		if (out) {
			CHECK(strcmp(out, text) == 0);
			bc_free(out);
			break;
		}
	}
	CHECK(n > 1);
	bc_free(text);
	bc_tree_destroy(t);
	bc_tree_destroy(ref);
}

/* A document is read in an arena of 4 MiB blocks, where a request over
 * a quarter of a block gets one of its own: a 3 MB string and a 200 000
 * item array (1.6 MB of item pointers, grown by doubling) take that path,
 * the first refused by its meaning, the second read whole; what was read
 * before does not change what is read after. */
static void big_pieces_of_a_document_are_read(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	size_t n = 3u << 20, len = 0, cap = 64u + 32u * 200000u;
	char *text = bc_malloc(n + 128u), *arr = bc_malloc(cap);
	REQUIRE(t && text && arr);
	len = (size_t)snprintf(text, 128u,
	                       "{\"blobcast\": 1, \"root\": {\"type\": \"");
	memset(text + len, 'q', n);
	len += n;
	len += (size_t)snprintf(text + len, 32u, "\", \"radius\": 1}}");
	CHECK_EQ_INT(bc_scene_parse_json(text, len, t, NULL, &ei), BC_EENUM);
	CHECK(strstr(ei.msg, "type") != NULL);
	CHECK(tree_is_empty(t));
	/* A union of 200 000 spheres, radius 0.5 at x = i. */
	len = (size_t)snprintf(arr, cap,
	                       "{\"blobcast\": 1, \"root\": {\"type\": "
	                       "\"union\", \"children\": [");
	for (uint32_t i = 0; i < 200000u; i++) {
		len += (size_t)snprintf(
		    arr + len, cap - len,
		    "%s{\"type\":\"sphere\",\"radius\":0.5}", i ? "," : "");
	}
	len += (size_t)snprintf(arr + len, cap - len, "]}}");
	REQUIRE(len < cap);
	CHECK_EQ_INT(bc_scene_parse_json(arr, len, t, NULL, &ei), 0);
	CHECK_EQ_INT(bc_tree_node_count(t), 200001);
	CHECK_EQ_INT(bc_tree_child_count(t, bc_tree_root(t)), 200000);
	bc_free(text);
	bc_free(arr);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"every_generator_round_trips_through_json",
     every_generator_round_trips_through_json},
    {"random_trees_round_trip_through_json",
     random_trees_round_trip_through_json},
    {"awkward_floats_round_trip_exactly", awkward_floats_round_trip_exactly},
    {"floats_are_written_in_their_shortest_g_form",
     floats_are_written_in_their_shortest_g_form},
    {"defaults_and_assigned_ids", defaults_and_assigned_ids},
    {"bad_files_fail_with_path_and_reason",
     bad_files_fail_with_path_and_reason},
    {"nesting_is_limited_to_the_tree_depth",
     nesting_is_limited_to_the_tree_depth},
    {"oversized_text_is_refused_before_parsing",
     oversized_text_is_refused_before_parsing},
    {"save_is_atomic_and_load_reads_it_back",
     save_is_atomic_and_load_reads_it_back},
    {"default_scene_is_valid_and_framed", default_scene_is_valid_and_framed},
    {"allocation_failures_are_survived", allocation_failures_are_survived},
    {"big_pieces_of_a_document_are_read", big_pieces_of_a_document_are_read},
    {"streamed_text_is_the_whole_text_in_pieces",
     streamed_text_is_the_whole_text_in_pieces},
};

BC_TEST_MAIN(tests)
