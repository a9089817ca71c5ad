/*
 * An edit that moves a group of neighbouring primitives at once: the tiled
 * renderer patches the candidate lists of the tiles they cover where that
 * costs less than building every tile's (tiled.c, patch_pays; always for
 * up to BC_CPU_PATCH_PRIMS), else builds them all again and drops every
 * tile's list. fig18 with N smooth spheres at 1024x768 (2 threads): a
 * whole frame, then E edits that each move `moved` neighbouring spheres of
 * the root union a little, each drawn as the daemon draws an edit (the
 * tiles bc_renderer_damage marks for the spheres' ABVs before and after
 * it). Prints the whole frame's time, each edit's sync + render time (the
 * lists' and the tracing's parts), and the process's VmRSS / VmHWM after
 * the whole frame and after the edits, with the renderer's kept bytes.
 *
 * Usage: bench_relocate [spheres] [moved] [edits]
 * (default 1000000 spheres, 100 moved, 5 edits)
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../tests/server/daemon.h" /* latency.h needs it */
#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/clock.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"
#include "latency.h"
#include "../tests/render/group.h"

#define W 1024u
#define H 768u

static void print_mem(const char *when, const struct bc_renderer *r)
{
	long rss, hwm;
	latency_rss_of(getpid(), &rss, &hwm);
	printf("%s: VmRSS %ld MiB, VmHWM %ld MiB, renderer keeps %zu MiB\n",
	       when, rss / 1024, hwm / 1024,
	       bc_renderer_kept_bytes(r) / (1024u * 1024u));
}

int main(int argc, char **argv)
{
	uint32_t spheres = argc > 1 ? (uint32_t)atol(argv[1]) : 1000000u;
	uint32_t moved = argc > 2 ? (uint32_t)atol(argv[2]) : 100u;
	int edits = argc > 3 ? atoi(argv[3]) : 5;
	struct bc_gen_opts go = {.count = spheres,
	                         .kind = BC_GEN_KIND_SPHERES,
	                         .blend = BC_GEN_BLEND_SMOOTH};
	struct bc_render_opts ro = {.threads = 2};
	struct bc_tree *t = bc_tree_create();
	struct bc_renderer *r = NULL;
	struct bc_camera cam;
	struct bc_frame f = {0};
	struct bc_render_stats st;
	struct bc_dirty dirty;
	struct bc_errinfo ei = {0};
	size_t nt = (size_t)bc_render_tiles_x(W) * bc_render_tiles_y(H);
	uint8_t *tiles = bc_calloc(nt, 1);
	double t0;
	if (!t || !tiles || bc_gen("fig18", &go, t, &cam, NULL) || moved == 0 ||
	    moved > spheres || bc_frame_init(&f, W, H) ||
	    bc_renderer_create(&r, BC_BACKEND_TILED, &ro, &ei) ||
	    bc_renderer_sync(r, t, NULL, &ei)) {
		fprintf(stderr, "cannot set up %u spheres: %s\n", spheres,
		        ei.msg);
		return 1;
	}
	/* The build's changes are in the first sync: not the edits'. */
	bc_tree_take_dirty(t, &dirty);
	t0 = bc_clock_ms();
	/* As a region (all tiles), which keys the frame for the edits'. */
	if (bc_renderer_render_region(r, &cam, &f,
	                              &(struct bc_render_region){.tiles = NULL},
	                              &st, &ei)) {
		fprintf(stderr, "render: %s\n", ei.msg);
		return 1;
	}
	printf("%u spheres, %ux%u: whole frame %.1f ms\n", spheres, W, H,
	       bc_clock_ms() - t0);
	print_mem("after the whole frame", r);
	srand(1);
	for (int e = 0; e < edits; e++) {
		uint32_t first = (uint32_t)rand() % (spheres - moved + 1);
		uint32_t marked = 0;
		float size = bc_tree_lin(t)->size;
		memset(tiles, 0, nt);
		if (group_move(t, r, &cam, W, H, first, moved,
		               0.001f * bc_tree_lin(t)->size, tiles, &ei)) {
			fprintf(stderr, "edit %d: %s\n", e, ei.msg);
			return 1;
		}
		for (size_t k = 0; k < nt; k++) {
			marked += tiles[k] != 0;
		}
		t0 = bc_clock_ms();
		bc_tree_take_dirty(t, &dirty);
		if (bc_renderer_sync(r, t, &dirty, &ei) ||
		    bc_renderer_render_region(
		        r, &cam, &f, &(struct bc_render_region){.tiles = tiles},
		        &st, &ei)) {
			fprintf(stderr, "edit %d: %s\n", e, ei.msg);
			return 1;
		}
		printf("edit %d: %u spheres from %u moved, %u tiles drawn in "
		       "%.1f ms (lists %.1f, trace %.1f)%s\n",
		       e, moved, first, marked, bc_clock_ms() - t0,
		       st.ms_abuffer, st.ms_trace,
		       !st.whole ? ""
		       : size != bc_tree_lin(t)->size
		           ? " (the whole frame: the scene's bounds changed)"
		           : " (the whole frame)");
	}
	print_mem("after the edits", r);
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	bc_tree_destroy(t);
	bc_free(tiles);
	return 0;
}
