/*
 * The `blobcast` program's render command, run as a child process: it writes
 * image files that read back with the right sizes and contents (from the
 * built-in scene, a scene file and stdin), names the problem and exits 2 on
 * bad arguments without writing anything, exits 1 on runtime failures, and
 * its help mentions every option it accepts.
 */
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/image.h"
#include "blobcast/scene.h"
#include "test.h"

#ifndef BLOBCAST_CLI_PATH
#error "BLOBCAST_CLI_PATH must name the blobcast program"
#endif

static char dir[64];
static char out[8192]; /* stdout + stderr of the last run */

static const char *path_in(const char *name)
{
	/* A few live at once (a command line's file names). */
	static char bufs[8][160];
	static int next;
	char *p = bufs[next++ % 8];
	snprintf(p, sizeof(bufs[0]), "%s/%s", dir, name);
	return p;
}

/* Runs blobcast with args (NULL-terminated, without argv[0]); stdin from
 * in_path when not NULL. Returns the exit status, -1 if it did not exit. */
static int run(const char *in_path, const char *const *args)
{
	const char *argv[32];
	char log[160];
	int n = 0, status;
	pid_t pid;
	snprintf(log, sizeof(log), "%s/run.log", dir);
	argv[n++] = BLOBCAST_CLI_PATH;
	while (args[n - 1] && n < 31) {
		argv[n] = args[n - 1];
		n++;
	}
	argv[n] = NULL;
	pid = fork();
	if (pid == 0) {
		int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
		int in = in_path ? open(in_path, O_RDONLY)
		                 : open("/dev/null", O_RDONLY);
		if (fd < 0 || in < 0) {
			_exit(127);
		}
		dup2(fd, 1);
		dup2(fd, 2);
		dup2(in, 0);
		execv(argv[0], (char *const *)argv);
		_exit(127);
	}
	if (pid < 0 || waitpid(pid, &status, 0) != pid) {
		return -1;
	}
	out[0] = '\0';
	{
		FILE *f = fopen(log, "rb");
		if (f) {
			size_t got = fread(out, 1, sizeof(out) - 1, f);
			out[got] = '\0';
			fclose(f);
		}
	}
	return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

static bool exists(const char *p)
{
	return access(p, F_OK) == 0;
}

static void setup(void)
{
	if (!dir[0]) {
		strcpy(dir, "/tmp/bc-test-cli-XXXXXX");
		if (!mkdtemp(dir)) {
			dir[0] = '\0';
		}
	}
}

/* Checks the three planes written for a w x h frame of a visible scene. */
static void check_planes(const char *png, const char *depth, const char *ids,
                         uint32_t w, uint32_t h)
{
	struct bc_image c, d, i;
	struct bc_errinfo ei = {0};
	uint32_t hits = 0, consistent = 0;
	REQUIRE(bc_image_read(png, BC_IMAGE_U8, &c, &ei) == 0);
	CHECK_EQ_INT(c.width, w);
	CHECK_EQ_INT(c.height, h);
	CHECK_EQ_INT(c.channels, 4);
	bc_image_finish(&c);
	if (!depth) {
		return;
	}
	REQUIRE(bc_image_read(depth, BC_IMAGE_F32, &d, &ei) == 0);
	REQUIRE(bc_image_read(ids, BC_IMAGE_U32, &i, &ei) == 0);
	CHECK(d.width == w && d.height == h && d.channels == 1);
	CHECK(i.width == w && i.height == h && i.channels == 1);
	for (size_t k = 0; k < (size_t)w * h && d.channels == 1 &&
	                   i.channels == 1 && d.width == w && i.width == w;
	     k++) {
		float z = ((float *)d.pixels)[k];
		uint32_t id = ((uint32_t *)i.pixels)[k];
		hits += id != 0;
		/* A pixel has an id exactly when it has a finite depth. */
		consistent += (id != 0) == (isfinite(z) && z > 0.0f);
	}
	CHECK(hits > w * h / 20);
	CHECK_EQ_INT(consistent, w * h);
	bc_image_finish(&d);
	bc_image_finish(&i);
}

static void test_render_default_scene_writes_three_planes(void)
{
	const char *png = path_in("d.png"), *exr = path_in("d.exr"),
	           *tif = path_in("d.tif");
	const char *args[] = {"render", "default", "--size",  "48x32",
	                      "--out",  png,       "--depth", exr,
	                      "--ids",  tif,       "--quiet", NULL};
	setup();
	REQUIRE(dir[0]);
	CHECK_EQ_INT(run(NULL, args), 0);
	if (out[0]) {
		fprintf(stderr, "  output: %s\n", out);
	}
	check_planes(png, exr, tif, 48, 32);
}

/* A scene written by bc_scene_to_json, rendered from a file with each CPU
 * backend and from stdin. */
static void test_render_scene_file_and_stdin(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_prim_data p;
	struct bc_op_data u = {BC_OP_SMOOTH_UNION, 0.3f, 0.3f};
	struct bc_camera cam;
	char json_path[160];
	char *json;
	FILE *f;
	setup();
	REQUIRE(t && dir[0]);
	snprintf(json_path, sizeof(json_path), "%s", path_in("s.json"));
	bc_tree_begin(t);
	REQUIRE(bc_tree_push_op(t, 10, &u, NULL) == 0);
	for (int i = 0; i < 3; i++) {
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		p.params[0] = 0.6f;
		p.translate[0] = -0.8f + 0.8f * (float)i;
		REQUIRE(bc_tree_put_prim(t, 11 + (uint32_t)i, &p, NULL) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, NULL) == 0);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	bc_camera_default(&cam);
	json = bc_scene_to_json(t, &cam);
	REQUIRE(json);
	f = fopen(json_path, "wb");
	REQUIRE(f);
	fputs(json, f);
	fclose(f);
	bc_free(json);
	for (int b = 0; b < 3; b++) {
		const char *png = path_in("f.png"), *exr = path_in("f.pfm"),
		           *tif = path_in("f.tiff");
		const char *backend = b == 1 ? "naive" : "tiled";
		const char *args[] = {"render",
		                      b == 2 ? "-" : json_path,
		                      "--size=40x24",
		                      "--backend",
		                      backend,
		                      "--out",
		                      png,
		                      "--depth",
		                      exr,
		                      "--ids",
		                      tif,
		                      "--threads",
		                      "2",
		                      NULL};
		unlink(png);
		CHECK_EQ_INT(run(b == 2 ? json_path : NULL, args), 0);
		/* Not --quiet: one summary line names the output. */
		CHECK(strstr(out, png) != NULL);
		check_planes(png, exr, tif, 40, 24);
	}
	unlink(json_path);
	bc_tree_destroy(t);
}

/* Whether two image files hold the same pixels, bit for bit. */
static bool same_pixels(const char *a, const char *b, enum bc_image_type type)
{
	struct bc_image x, y;
	bool same;
	if (bc_image_read(a, type, &x, NULL)) {
		return false;
	}
	if (bc_image_read(b, type, &y, NULL)) {
		bc_image_finish(&x);
		return false;
	}
	same = x.width == y.width && x.height == y.height &&
	       x.channels == y.channels &&
	       memcmp(x.pixels, y.pixels,
	              (size_t)x.width * x.height * x.channels *
	                  (type == BC_IMAGE_U8 ? 1u : 4u)) == 0;
	bc_image_finish(&x);
	bc_image_finish(&y);
	return same;
}

/* --bands N draws the frame in N windows of whole 8-row tiles (the last
 * band shorter, a height not a multiple of 8): the colour, depth and ids
 * are the whole frame's, bit for bit, and --stats counts the bands. */
static void test_bands_draw_the_same_pixels(void)
{
	static const char *const backends[] = {"tiled", "naive"};
	setup();
	REQUIRE(dir[0]);
	for (size_t b = 0; b < 2; b++) {
		const char *png1 = path_in("b1.png"), *exr1 = path_in("b1.exr"),
		           *tif1 = path_in("b1.tif"), *png5 = path_in("b5.png"),
		           *exr5 = path_in("b5.exr"), *tif5 = path_in("b5.tif");
		const char *whole[] = {
		    "render",  "default",   "--size",    "101x77", "--out",
		    png1,      "--depth",   exr1,        "--ids",  tif1,
		    "--quiet", "--backend", backends[b], NULL};
		const char *bands[] = {
		    "render",  "default",   "--size",    "101x77",
		    "--out",   png5,        "--depth",   exr5,
		    "--ids",   tif5,        "--bands",   "5",
		    "--stats", "--backend", backends[b], NULL};
		CHECK_EQ_INT(run(NULL, whole), 0);
		CHECK_EQ_INT(run(NULL, bands), 0);
		CHECK(strstr(out, "5 bands") != NULL);
		check_planes(png5, exr5, tif5, 101, 77);
		CHECK(same_pixels(png1, png5, BC_IMAGE_U8));
		CHECK(same_pixels(exr1, exr5, BC_IMAGE_F32));
		CHECK(same_pixels(tif1, tif5, BC_IMAGE_U32));
	}
}

struct bad {
	const char *args[12];
	const char *says; /* a substring of the message */
};

static void test_bad_arguments_exit_2_with_a_reason(void)
{
	static const struct bad cases[] = {
	    {{"render", "default", "--out", "@o.png", NULL}, "--size"},
	    {{"render", "default", "--size", "8x8", NULL}, "--out"},
	    {{"render", "--size", "8x8", "--out", "@o.png", NULL}, "scene"},
	    {{"render", "default", "x", "--size", "8x8", "--out", "@o.png",
	      NULL},
	     "more than one scene"},
	    {{"render", "default", "--size", "0x8", "--out", "@o.png", NULL},
	     "'0x8'"},
	    {{"render", "default", "--size", "8x", "--out", "@o.png", NULL},
	     "'8x'"},
	    {{"render", "default", "--size", "9000x8", "--out", "@o.png", NULL},
	     "9000x8"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--backend", "cpu", NULL},
	     "--backend 'cpu' is not one of naive, tiled, gl, svo"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--depth", "@d.png", NULL},
	     ".exr, .tif or .pfm"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png", "--ids",
	      "@i.pfm", NULL},
	     ".tif or .exr"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.nosuch", NULL},
	     "o.nosuch"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--debug", "steps", NULL},
	     "'steps'"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--threads", "-1", NULL},
	     "--threads"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--range", "xx", NULL},
	     "'xx'"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--gl-platform", "x11", NULL},
	     "'x11'"},
	    {{"render", "default", "--size", "8x8", "--out", "@o.png",
	      "--frobnicate", NULL},
	     "--frobnicate"},
	    {{"render", "default", "--size", "8x8", "--out", NULL},
	     "needs a value"},
	    {{"nosuchcommand", NULL}, "nosuchcommand"},
	    {{"--nosuchoption", "render", NULL}, "--nosuchoption"},
	    {{NULL}, "usage"},
	};
	setup();
	REQUIRE(dir[0]);
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		const char *args[12];
		int rc;
		for (int i = 0; i < 12; i++) {
			/* "@name" is a file in the test directory. */
			const char *a = cases[c].args[i];
			args[i] = a && a[0] == '@' ? path_in(a + 1) : a;
			if (!a) {
				break;
			}
		}
		unlink(path_in("o.png"));
		rc = run(NULL, args);
		if (rc != 2 || !strstr(out, cases[c].says)) {
			fprintf(stderr, "  case %zu: exit %d, output: %s", c,
			        rc, out);
		}
		CHECK_EQ_INT(rc, 2);
		CHECK(strstr(out, cases[c].says) != NULL);
		CHECK(!exists(path_in("o.png")));
	}
}

static void test_runtime_failures_exit_1(void)
{
	const char *missing[] = {
	    "render", "/nonexistent/scene.json", "--size", "8x8", "--out", NULL,
	    NULL};
	const char *unwritable[] = {"render", "default",
	                            "--size", "8x8",
	                            "--out",  "/nonexistent/dir/o.png",
	                            NULL};
	setup();
	REQUIRE(dir[0]);
	missing[5] = path_in("o.png");
	CHECK_EQ_INT(run(NULL, missing), 1);
	CHECK(strstr(out, "/nonexistent/scene.json") != NULL);
	CHECK(!exists(path_in("o.png")));
	CHECK_EQ_INT(run(NULL, unwritable), 1);
	CHECK(strstr(out, "/nonexistent/dir/o.png") != NULL);
	/* Not JSON at all, on stdin. */
	{
		const char *bad = path_in("bad.json");
		const char *args[] = {"render", "-",     "--size",
		                      "8x8",    "--out", path_in("o.png"),
		                      NULL};
		FILE *f = fopen(bad, "wb");
		REQUIRE(f);
		fputs("{ this is not json", f);
		fclose(f);
		CHECK_EQ_INT(run(bad, args), 1);
		CHECK(!exists(path_in("o.png")));
	}
}

static void test_help_tells_every_option(void)
{
	static const char *const options[] = {
	    "--size",    "--out",       "--depth",     "--ids",
	    "--backend", "--debug",     "--threads",   "--gl-platform",
	    "--range",   "--threshold", "--max-depth", "--stats",
	    "--quiet",   "--bands",     "evals",       "overlaps",
	    "naive",     "tiled",       "default",
	};
	const char *h1[] = {"render", "--help", NULL};
	const char *h2[] = {"help", "render", NULL};
	const char *h3[] = {"--help", NULL};
	char first[sizeof(out)];
	setup();
	REQUIRE(dir[0]);
	CHECK_EQ_INT(run(NULL, h1), 0);
	memcpy(first, out, sizeof(out));
	for (size_t i = 0; i < sizeof(options) / sizeof(options[0]); i++) {
		if (!strstr(out, options[i])) {
			fprintf(stderr, "  help lacks %s\n", options[i]);
		}
		CHECK(strstr(out, options[i]) != NULL);
	}
	CHECK_EQ_INT(run(NULL, h2), 0);
	CHECK_STREQ(first, out);
	CHECK_EQ_INT(run(NULL, h3), 0);
	CHECK(strstr(out, "render") != NULL);
}

static void test_cleanup(void)
{
	const char *names[] = {"d.png",  "d.exr",  "d.tif",    "f.png",
	                       "f.pfm",  "f.tiff", "bad.json", "run.log",
	                       "b1.png", "b1.exr", "b1.tif",   "b5.png",
	                       "b5.exr", "b5.tif"};
	for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
		unlink(path_in(names[i]));
	}
	CHECK(rmdir(dir) == 0);
}

static const struct bc_test tests[] = {
    {"render_default_scene_writes_three_planes",
     test_render_default_scene_writes_three_planes},
    {"render_scene_file_and_stdin", test_render_scene_file_and_stdin},
    {"bad_arguments_exit_2_with_a_reason",
     test_bad_arguments_exit_2_with_a_reason},
    {"runtime_failures_exit_1", test_runtime_failures_exit_1},
    {"help_tells_every_option", test_help_tells_every_option},
    {"bands_draw_the_same_pixels", test_bands_draw_the_same_pixels},
    {"cleanup", test_cleanup},
};

BC_TEST_MAIN(tests)
