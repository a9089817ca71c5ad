/*
 * The command line of the adaptive CSG evaluator: `blobcast eval-bench`
 * prints a JSON report whose numbers are consistent (terms, signs, times,
 * speedup) in both modes and every arithmetic, refuses bad options with
 * exit 2 and a missing scene with exit 1; `blobcast render --backend svo`
 * writes an image.
 */
#include <jansson.h>
#include <stdio.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test.h"

static char out[65536];

/* Runs the CLI with args (a shell-quoted string) and returns its exit
 * status; stdout and stderr are left in out. */
static int run(const char *args)
{
	char cmd[1024];
	FILE *p;
	size_t n = 0;
	int st;
	snprintf(cmd, sizeof(cmd), "'%s' %s 2>&1", BLOBCAST_CLI_PATH, args);
	p = popen(cmd, "r");
	if (!p) {
		return -1;
	}
	while (n + 1 < sizeof(out)) {
		size_t got = fread(out + n, 1, sizeof(out) - 1 - n, p);
		if (got == 0) {
			break;
		}
		n += got;
	}
	out[n] = '\0';
	st = pclose(p);
	return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static json_t *report(const char *args)
{
	json_error_t err;
	json_t *o;
	if (run(args) != 0) {
		fprintf(stderr, "  %s: %s\n", args, out);
		return NULL;
	}
	o = json_loads(out, 0, &err);
	if (!o) {
		fprintf(stderr, "  not JSON (%s): %s\n", err.text, out);
	}
	return o;
}

static double num(const json_t *o, const char *key)
{
	return json_number_value(json_object_get(o, key));
}

static void eval_bench_reports_a_grid(void)
{
	json_t *o =
	    report("eval-bench default --grid 6 --range ia --points 5000");
	REQUIRE(o);
	CHECK(strcmp(json_string_value(json_object_get(o, "mode")), "grid") ==
	      0);
	CHECK(strcmp(json_string_value(json_object_get(o, "range")), "ia") ==
	      0);
	CHECK(num(o, "terms") > 10);
	CHECK(num(o, "voxels") == 216);
	CHECK(num(o, "prune_ms_per_voxel") > 0.0);
	CHECK(num(o, "avg_terms") < num(o, "terms"));
	CHECK(num(o, "points") == 5000);
	CHECK(num(o, "full_points") >= 1 && num(o, "full_points") <= 5000);
	CHECK(num(o, "eval_ns_full") > 0.0 && num(o, "eval_ns_pruned") > 0.0);
	CHECK(fabs(num(o, "speedup") -
	           num(o, "eval_ns_full") / num(o, "eval_ns_pruned")) <
	      1e-3 * num(o, "speedup"));
	CHECK(num(o, "sign_mismatches") == 0);
	json_decref(o);
}

static void eval_bench_reports_an_octree(void)
{
	static const char *const ranges[] = {"ia", "aa", "revaa"};
	for (int i = 0; i < 3; i++) {
		char args[256];
		json_t *o;
		snprintf(args, sizeof(args),
		         "eval-bench default --threshold 4 --max-depth 6 "
		         "--range %s --points 5000 --seed 3",
		         ranges[i]);
		o = report(args);
		REQUIRE(o);
		CHECK(strcmp(json_string_value(json_object_get(o, "mode")),
		             "octree") == 0);
		CHECK(num(o, "threshold") == 4 && num(o, "max_depth") == 6);
		CHECK(num(o, "max_depth_reached") <= 6);
		CHECK(num(o, "leaves") == num(o, "leaves_empty") +
		                              num(o, "leaves_full") +
		                              num(o, "leaves_surface"));
		CHECK(num(o, "nodes") >= num(o, "leaves"));
		CHECK(num(o, "build_ms") > 0.0 && num(o, "bytes") > 0.0);
		CHECK(num(o, "avg_terms") <= num(o, "max_terms"));
		CHECK(num(o, "eval_ns_locate") > 0.0);
		CHECK(num(o, "sign_mismatches") == 0);
		json_decref(o);
	}
}

static void eval_bench_refuses_bad_arguments(void)
{
	static const char *const bad[] = {
	    "eval-bench",
	    "eval-bench default --range xa",
	    "eval-bench default --grid 0",
	    "eval-bench default --grid 100000",
	    "eval-bench default --grid 4 --threshold 3",
	    "eval-bench default --max-depth 16",
	    "eval-bench default --points 0",
	    "eval-bench default --frobnicate 1",
	    "eval-bench default other",
	    "eval-bench default --seed",
	};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		int rc = run(bad[i]);
		if (rc != 2) {
			fprintf(stderr, "  %s: exit %d: %s\n", bad[i], rc, out);
		}
		CHECK(rc == 2);
		CHECK(strstr(out, "eval-bench") != NULL);
	}
	CHECK(run("eval-bench /nonexistent/scene.json") == 1);
	CHECK(run("eval-bench --help") == 0);
	CHECK(strstr(out, "--threshold") != NULL);
}

static void render_draws_with_the_svo_backend(void)
{
	char path[64], args[256];
	snprintf(path, sizeof(path), "/tmp/bc_svo_cli_%d.png", (int)getpid());
	snprintf(args, sizeof(args),
	         "render default --backend svo --range aa --threshold 6 "
	         "--max-depth 7 --size 40x30 --out %s --quiet",
	         path);
	CHECK(run(args) == 0);
	CHECK(access(path, R_OK) == 0);
	unlink(path);
}

static const struct bc_test tests[] = {
    {"eval_bench_reports_a_grid", eval_bench_reports_a_grid},
    {"eval_bench_reports_an_octree", eval_bench_reports_an_octree},
    {"eval_bench_refuses_bad_arguments", eval_bench_refuses_bad_arguments},
    {"render_draws_with_the_svo_backend", render_draws_with_the_svo_backend},
};

BC_TEST_MAIN(tests)
