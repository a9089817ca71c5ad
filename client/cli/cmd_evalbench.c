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

#include <jansson.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"
#include "blobcast/svo.h"
#include "cli.h"

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

static const struct bc_opt_name range_names[] = {{"ia", BC_RANGE_IA},
                                                 {"aa", BC_RANGE_AA},
                                                 {"revaa", BC_RANGE_REVAA},
                                                 {NULL, 0}};

/* Returns 0 to go on, or the exit status (0 after --help, 2 on a bad
 * argument) with *done set. */
static int parse(int argc, char **argv, struct args *a, bool *done)
{
	int arith = BC_SVO_DEFAULT_ARITH;
	/* Defaults first: the help prints them from the table. */
	memset(a, 0, sizeof(*a));
	a->points = EB_DEFAULT_POINTS;
	a->seed = 1;
	a->threshold = BC_SVO_DEFAULT_THRESHOLD;
	a->max_depth = BC_SVO_DEFAULT_MAX_DEPTH;
	const struct bc_opt opts[] = {
	    {.name = "range",
	     .kind = BC_OPT_ENUM,
	     .dst = &arith,
	     .arg = "A",
	     .help = "{choices}: the range arithmetic that\n"
	             "prunes (default {default})",
	     .names = range_names},
	    {.name = "grid",
	     .kind = BC_OPT_U32,
	     .dst = &a->grid,
	     .lo = 1,
	     .hi = BC_SVO_MAX_GRID,
	     .arg = "N",
	     .help = "prune a uniform N^3 grid over the scene's box,\n"
	             "each voxel from the whole tree, {range}"},
	    {.name = "threshold",
	     .kind = BC_OPT_U32,
	     .dst = &a->threshold,
	     .lo = 1,
	     .hi = UINT32_MAX,
	     .arg = "T",
	     .help = "build the adaptive octree with node-count\n"
	             "threshold T, {range} (default {default};\n"
	             "the default mode)"},
	    {.name = "max-depth",
	     .kind = BC_OPT_U32,
	     .dst = &a->max_depth,
	     .lo = 1,
	     .hi = BC_SVO_MAX_DEPTH,
	     .arg = "D",
	     .help = "octree depth limit, {range} (default {default})"},
	    {.name = "points",
	     .kind = BC_OPT_U32,
	     .dst = &a->points,
	     .lo = 1,
	     .hi = EB_MAX_POINTS,
	     .arg = "N",
	     .help = "random points timed, {range}\n(default {default})"},
	    {.name = "seed",
	     .kind = BC_OPT_U64,
	     .dst = &a->seed,
	     .arg = "S",
	     .help = "seed of the points (default {default})"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args p = {
	    .prog = "blobcast eval-bench",
	    .usage = "blobcast eval-bench SCENE [options]",
	    .about = "Measures interval pruning and pruned evaluation "
	             "(render/svo,\nafter Chulkov 2025) on SCENE -- a scene "
	             "file (JSON or binary),\n'-' for stdin, or "
	             "'default' -- and "
	             "prints the results as JSON.",
	    .footer = "Times are on one thread. Output fields: terms (RPN "
	              "length),\nprune_ms_per_voxel / prune_ms_per_node, "
	              "eval_ns_pruned (finding\nthe variant and evaluating "
	              "it), eval_ns_locate, eval_ns_full\n(the whole tree), "
	              "speedup = full / pruned, avg_depth and\navg_terms "
	              "(over volume: a random point's leaf), max_terms,\n"
	              "build_ms, bytes, sign_mismatches (always 0).",
	    .opts = opts};
	*done = true;
	if (bc_cli_args_parse(&p, argc, argv)) {
		return p.status;
	}
	a->arith = (enum bc_range_arith)arith;
	if (p.npos == 0) {
		return bc_args_error(&p, "which scene?");
	}
	if (p.npos > 1) {
		return bc_args_error(&p, "one scene only ('%s' and '%s')",
		                     p.pos[0], p.pos[1]);
	}
	a->scene = p.pos[0];
	if (a->grid && (bc_args_given(&p, "threshold") ||
	                bc_args_given(&p, "max-depth"))) {
		return bc_args_error(&p, "--grid measures a uniform grid; "
		                         "--threshold and --max-depth are for "
		                         "the octree");
	}
	*done = false;
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
	int status = 1;
	bool done;
	if ((status = parse(argc, argv, &a, &done)) || done) {
		return status;
	}
	status = 1;
	if (!(t = bc_tree_create()) || !(o = json_object())) {
		fprintf(stderr, "blobcast eval-bench: out of memory\n");
		goto cleanup;
	}
	if (bc_cli_load_scene(a.scene, t, &cam, &ei)) {
		bc_cli_explain(stderr, "blobcast eval-bench", ei.msg);
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
