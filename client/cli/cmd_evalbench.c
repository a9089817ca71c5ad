/*
 * `blobcast eval-bench SCENE [--range ia|aa|revaa] [--grid N | --threshold T]
 * [--max-depth D] [--points N] [--seed S]`: the measurements of the
 * thesis's §6.1 (a uniform grid of pruned voxels: pruning time per voxel,
 * evaluation time per point pruned and unpruned) and §6.2-6.3 (the adaptive
 * octree: construction time, depth, RPN lengths, memory, traversal and
 * evaluation time) on one scene, printed as one JSON object (jansson). The
 * option parsing is strict: every bad value is named and exits 2 before
 * any work.
 */
#include "cmd_evalbench.h"
#include "cmd_render.h"

#include <errno.h>
#include <jansson.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "blobcast/svo.h"

#define EXIT_USAGE 2
/* Default and largest number of timed points: a million points take a
 * fraction of a second through pruned variants; 10^8 bounds the points'
 * memory (1.2 GB) and any run's length. */
#define EB_DEFAULT_POINTS 1000000u
#define EB_MAX_POINTS 100000000u

struct args {
	const char *scene;
	enum bc_range_arith arith;
	uint32_t grid, threshold, max_depth, points;
	uint64_t seed;
};

static void usage(FILE *f)
{
	fprintf(
	    f,
	    "usage: blobcast eval-bench SCENE [options]\n"
	    "\n"
	    "Measures interval pruning and pruned evaluation (render/svo,\n"
	    "after Chulkov 2025) on SCENE -- a JSON scene file, '-' for\n"
	    "stdin, or 'default' -- and prints the results as JSON.\n"
	    "\n"
	    "  --range A        ia | aa | revaa: the range arithmetic that\n"
	    "                   prunes (default ia)\n"
	    "  --grid N         prune a uniform N^3 grid over the scene's "
	    "box,\n"
	    "                   each voxel from the whole tree, 1..%u\n"
	    "  --threshold T    build the adaptive octree with node-count\n"
	    "                   threshold T (default %u; the default mode)\n"
	    "  --max-depth D    octree depth limit, 1..%u (default %u)\n"
	    "  --points N       random points timed, 1..%u (default %u)\n"
	    "  --seed S         seed of the points (default 1)\n"
	    "  --help           this text\n"
	    "\n"
	    "Times are on one thread. Output fields: terms (RPN length),\n"
	    "prune_ms_per_voxel / prune_ms_per_node, eval_ns_pruned (finding\n"
	    "the variant and evaluating it), eval_ns_locate, eval_ns_full\n"
	    "(the whole tree), speedup = full / pruned, avg_depth and\n"
	    "avg_terms (over volume: a random point's leaf), max_terms,\n"
	    "build_ms, bytes, sign_mismatches (always 0).\n",
	    BC_SVO_MAX_GRID, BC_SVO_DEFAULT_THRESHOLD, BC_SVO_MAX_DEPTH,
	    BC_SVO_DEFAULT_MAX_DEPTH, EB_MAX_POINTS, EB_DEFAULT_POINTS);
}

static bool parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
	char *end = NULL;
	unsigned long long v;
	if (!s || *s < '0' || *s > '9') {
		return false;
	}
	errno = 0;
	v = strtoull(s, &end, 10);
	if (errno || *end != '\0' || v < lo || v > hi) {
		return false;
	}
	*out = (uint64_t)v;
	return true;
}

static bool parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
	uint64_t v;
	if (!parse_u64(s, lo, hi, &v)) {
		return false;
	}
	*out = (uint32_t)v;
	return true;
}

/* Returns 0 to go on, -1 after --help, EXIT_USAGE on a bad argument. */
static int parse(int argc, char **argv, struct args *a)
{
	bool thr = false;
	memset(a, 0, sizeof(*a));
	a->arith = BC_SVO_DEFAULT_ARITH;
	a->points = EB_DEFAULT_POINTS;
	a->seed = 1;
	for (int i = 1; i < argc; i++) {
		const char *o = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : NULL;
		bool ok = true, takes = true;
		if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
			usage(stdout);
			return -1;
		}
		if (strcmp(o, "--range") == 0) {
			if (v && strcmp(v, "ia") == 0) {
				a->arith = BC_RANGE_IA;
			} else if (v && strcmp(v, "aa") == 0) {
				a->arith = BC_RANGE_AA;
			} else if (v && strcmp(v, "revaa") == 0) {
				a->arith = BC_RANGE_REVAA;
			} else {
				ok = false;
			}
		} else if (strcmp(o, "--grid") == 0) {
			ok = parse_u32(v, 1, BC_SVO_MAX_GRID, &a->grid);
		} else if (strcmp(o, "--threshold") == 0) {
			ok = parse_u32(v, 1, UINT32_MAX, &a->threshold);
			thr = true;
		} else if (strcmp(o, "--max-depth") == 0) {
			ok = parse_u32(v, 1, BC_SVO_MAX_DEPTH, &a->max_depth);
		} else if (strcmp(o, "--points") == 0) {
			ok = parse_u32(v, 1, EB_MAX_POINTS, &a->points);
		} else if (strcmp(o, "--seed") == 0) {
			ok = parse_u64(v, 0, UINT64_MAX, &a->seed);
		} else if (o[0] == '-' && o[1] != '\0') {
			fprintf(stderr,
			        "blobcast eval-bench: unknown option \"%s\" "
			        "(see --help)\n",
			        o);
			return EXIT_USAGE;
		} else {
			takes = false;
			if (a->scene) {
				fprintf(stderr,
				        "blobcast eval-bench: one scene "
				        "only (\"%s\" and \"%s\")\n",
				        a->scene, o);
				return EXIT_USAGE;
			}
			a->scene = o;
		}
		if (!ok) {
			fprintf(stderr,
			        "blobcast eval-bench: %s needs a valid value, "
			        "got \"%s\" (see --help)\n",
			        o, v ? v : "nothing");
			return EXIT_USAGE;
		}
		i += takes;
	}
	if (!a->scene) {
		fprintf(stderr, "blobcast eval-bench: which scene? (see "
		                "--help)\n");
		return EXIT_USAGE;
	}
	if (a->grid && (thr || a->max_depth)) {
		fprintf(stderr,
		        "blobcast eval-bench: --grid measures a uniform "
		        "grid; --threshold and --max-depth are for the "
		        "octree\n");
		return EXIT_USAGE;
	}
	return 0;
}

static const char *arith_name(enum bc_range_arith a)
{
	return a == BC_RANGE_IA ? "ia" : (a == BC_RANGE_AA ? "aa" : "revaa");
}

/* Adds the timing fields to o. */
static void put_timing(json_t *o, const struct bc_svo_timing *tm, bool octree)
{
	json_object_set_new(o, "points", json_integer(tm->points));
	json_object_set_new(o, "full_points", json_integer(tm->full_points));
	json_object_set_new(o, "eval_ns_full", json_real(tm->full_ns));
	json_object_set_new(o, "eval_ns_pruned", json_real(tm->pruned_ns));
	if (octree) {
		json_object_set_new(o, "eval_ns_locate",
		                    json_real(tm->locate_ns));
		json_object_set_new(o, "eval_ns_leaf",
		                    json_real(tm->pruned_ns - tm->locate_ns));
	}
	json_object_set_new(
	    o, "speedup",
	    json_real(tm->pruned_ns > 0.0 ? tm->full_ns / tm->pruned_ns : 0.0));
	json_object_set_new(o, "sign_mismatches",
	                    json_integer((json_int_t)tm->mismatches));
}

static int run(const struct args *a, const struct bc_lin *l, json_t *o,
               struct bc_errinfo *ei)
{
	struct bc_svo_rpn rpn;
	struct bc_svo_timing tm;
	int rc;
	if ((rc = bc_svo_rpn_init(&rpn, l))) {
		return bc_errinfo_set(ei, rc, "compiling the tree: %s",
		                      bc_strerror(rc));
	}
	json_object_set_new(o, "terms", json_integer(rpn.n));
	json_object_set_new(o, "primitives", json_integer(rpn.nprims));
	json_object_set_new(o, "range", json_string(arith_name(a->arith)));
	if (a->grid) {
		struct bc_svo_grid *g = NULL;
		double ms, avg;
		uint32_t most;
		uint64_t bytes;
		uint64_t nv = (uint64_t)a->grid * a->grid * a->grid;
		if ((rc =
		         bc_svo_grid_build(&g, &rpn, a->arith, a->grid, &ms))) {
			bc_svo_rpn_finish(&rpn);
			return bc_errinfo_set(ei, rc, "pruning the grid: %s",
			                      bc_strerror(rc));
		}
		bc_svo_grid_stats(g, &avg, &most, &bytes);
		json_object_set_new(o, "mode", json_string("grid"));
		json_object_set_new(o, "grid", json_integer(a->grid));
		json_object_set_new(o, "voxels", json_integer((json_int_t)nv));
		json_object_set_new(o, "prune_ms_per_voxel",
		                    json_real(ms / (double)nv));
		json_object_set_new(o, "avg_terms", json_real(avg));
		json_object_set_new(o, "max_terms", json_integer(most));
		json_object_set_new(o, "bytes",
		                    json_integer((json_int_t)bytes));
		rc = bc_svo_time_grid(g, l, a->points, a->seed, &tm);
		bc_svo_grid_destroy(g);
	} else {
		struct bc_svo *s = NULL;
		struct bc_svo_stats st;
		struct bc_svo_opts so = {.arith = a->arith,
		                         .threshold = a->threshold,
		                         .max_depth = a->max_depth};
		if ((rc = bc_svo_build(&s, &rpn, &so, ei))) {
			bc_svo_rpn_finish(&rpn);
			return rc;
		}
		bc_svo_get_stats(s, &st);
		json_object_set_new(o, "mode", json_string("octree"));
		json_object_set_new(
		    o, "threshold",
		    json_integer(a->threshold ? a->threshold
		                              : BC_SVO_DEFAULT_THRESHOLD));
		json_object_set_new(
		    o, "max_depth",
		    json_integer(a->max_depth ? a->max_depth
		                              : BC_SVO_DEFAULT_MAX_DEPTH));
		json_object_set_new(o, "build_ms", json_real(st.build_ms));
		json_object_set_new(
		    o, "prune_ms_per_node",
		    json_real(st.pruned ? st.build_ms / (double)st.pruned
		                        : 0.0));
		json_object_set_new(o, "nodes", json_integer(st.nodes));
		json_object_set_new(o, "leaves", json_integer(st.leaves));
		json_object_set_new(o, "leaves_empty", json_integer(st.empty));
		json_object_set_new(o, "leaves_full", json_integer(st.full));
		json_object_set_new(o, "leaves_surface",
		                    json_integer(st.active));
		json_object_set_new(o, "avg_depth", json_real(st.avg_depth));
		json_object_set_new(o, "max_depth_reached",
		                    json_integer(st.max_depth));
		json_object_set_new(o, "avg_terms", json_real(st.avg_terms));
		json_object_set_new(o, "avg_terms_surface_leaf",
		                    json_real(st.avg_terms_leaf));
		json_object_set_new(o, "max_terms", json_integer(st.max_terms));
		json_object_set_new(o, "stalled_leaves",
		                    json_integer(st.stalled));
		json_object_set_new(o, "truncated", json_boolean(st.truncated));
		json_object_set_new(o, "bytes",
		                    json_integer((json_int_t)st.bytes));
		rc = bc_svo_time_octree(s, l, a->points, a->seed, &tm);
		bc_svo_destroy(s);
	}
	bc_svo_rpn_finish(&rpn);
	if (rc) {
		return bc_errinfo_set(ei, rc, "timing: %s", bc_strerror(rc));
	}
	put_timing(o, &tm, a->grid == 0);
	return 0;
}

int bc_cli_eval_bench(int argc, char **argv)
{
	struct args a;
	struct bc_errinfo ei = {0};
	struct bc_tree *t = NULL;
	struct bc_camera cam; /* read with the scene, unused here */
	const struct bc_lin *l;
	json_t *o = NULL;
	char *text = NULL;
	int rc, status = 1;
	if ((rc = parse(argc, argv, &a))) {
		return rc < 0 ? 0 : rc;
	}
	if (!(t = bc_tree_create()) || !(o = json_object())) {
		fprintf(stderr, "blobcast eval-bench: out of memory\n");
		goto cleanup;
	}
	if (bc_cli_load_scene(a.scene, t, &cam, &ei)) {
		fprintf(stderr, "blobcast eval-bench: %s\n", ei.msg);
		goto cleanup;
	}
	if (!(l = bc_tree_lin(t))) {
		fprintf(stderr, "blobcast eval-bench: %s: the scene is empty\n",
		        a.scene);
		goto cleanup;
	}
	json_object_set_new(o, "scene", json_string(a.scene));
	if (run(&a, l, o, &ei)) {
		fprintf(stderr, "blobcast eval-bench: %s\n", ei.msg);
		goto cleanup;
	}
	text = json_dumps(o, JSON_INDENT(2) | JSON_PRESERVE_ORDER |
	                         JSON_REAL_PRECISION(6));
	if (!text || printf("%s\n", text) < 0 || fflush(stdout) != 0) {
		fprintf(stderr, "blobcast eval-bench: writing to stdout "
		                "failed\n");
		goto cleanup;
	}
	status = 0;
cleanup:
	free(text); /* jansson's allocator */
	json_decref(o);
	bc_tree_destroy(t);
	return status;
}
