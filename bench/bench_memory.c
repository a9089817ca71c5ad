/*
 * What a primitive costs resident, part by part, as blobcastd holds a
 * session someone looks at: the session's bare tree (the model), the
 * render copy (the model again, laid out for the renderers), and the
 * tiled renderer's view (its frame planes, and the tile lists and
 * per-primitive terms of the view). Each part is the growth of this
 * process's VmRSS while it is made, so it counts what the allocator
 * really took from the system; the render copy's layout arrays are also
 * counted from their sizes (struct bc_lin), array by array, so that the
 * rest of the copy (its pool, its nodes' layout places, its maps) is
 * their difference. bench_load measures the same daemon-wide (VmRSS of
 * blobcastd after a still frame); this says where the bytes go.
 *
 * Usage: bench_memory [--size WxH] [--threads T] [COUNT...]
 *   COUNT    fig18 smooth sphere counts (default 1000000); "fig16" for
 *            Fig. 16's level 6 (1 111 110 primitives)
 *   --size   the view (default 1024x768, bench_load's)
 *   --threads the renderer's threads (default 2)
 * Each COUNT runs in a process of its own.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"

/* This process's VmRSS in bytes (0 when /proc cannot be read). */
static double rss_bytes(void)
{
	FILE *f = fopen("/proc/self/status", "r");
	char line[256];
	double kb = 0.0;
	if (!f) {
		return 0.0;
	}
	while (fgets(line, sizeof(line), f)) {
		if (strncmp(line, "VmRSS:", 6) == 0) {
			kb = strtod(line + 6, NULL);
			break;
		}
	}
	fclose(f);
	return kb * 1024.0;
}

/* One row: a part's bytes, in MiB and per primitive. */
static void row(const char *part, double bytes, uint32_t prims)
{
	printf("  %-44s %8.1f MiB %8.1f B/prim\n", part, bytes / 1048576.0,
	       prims ? bytes / prims : 0.0);
}

/* The render copy's layout arrays (struct bc_lin), counted from their
 * lengths: rows per kind of array, and the sum. */
static double lin_rows(const struct bc_lin *l, uint32_t prims)
{
	double slot4 = 0.0, s = l->count, p = l->nprims, total;
	double slots, per_prim, records, unary;
	uint32_t *const four[] = {l->lead,  l->fast,    l->jump, l->kills,
	                          l->depth, l->node_id, l->wrap, l->wrap_top,
	                          l->dom,   l->ucount};
	for (size_t i = 0; i < sizeof(four) / sizeof(four[0]); i++) {
		slot4 += four[i] ? 4.0 : 0.0;
	}
	slot4 += l->roi_lo ? 4.0 : 0.0;
	slot4 += l->roi_hi ? 4.0 : 0.0;
	slots = s * (8.0 + slot4) + (double)((l->count + 63u) / 64u) * 8.0;
	per_prim = p * (4.0 + 12.0 + (l->sabv ? 16.0 : 0.0) +
	                (l->abv ? (double)sizeof(struct bc_abv) : 0.0));
	records = (double)l->nparam * 16.0;
	unary = (double)l->nunary * 4.0 * 8.0;
	total = slots + per_prim + records + unary;
	printf("    %u slots (%.2f a primitive), %.0f bytes a slot\n", l->count,
	       p > 0.0 ? s / p : 0.0, 8.0 + slot4);
	row("  per-slot arrays", slots, prims);
	row("  per-primitive arrays (slot, ABV, colour)", per_prim, prims);
	row("  parameter records", records, prims);
	if (l->nunary) {
		row("  unary nodes' arrays", unary, prims);
	}
	return total;
}

static int one(const char *what, uint32_t w, uint32_t h, uint32_t threads)
{
	struct bc_gen_opts o = {0};
	const char *gen = "fig18";
	struct bc_tree *session = bc_tree_create(), *copy = bc_tree_create();
	struct bc_renderer *r = NULL;
	struct bc_render_opts ro = {.threads = threads};
	struct bc_render_stats st;
	struct bc_frame f = {0};
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	double r0, r1, r2, r3, r4, lin_bytes;
	uint32_t prims;
	if (strcmp(what, "fig16") == 0) {
		gen = "fig16";
		o.level = 6;
		o.blend = BC_GEN_BLEND_SMOOTH;
	} else {
		char *end;
		unsigned long n = strtoul(what, &end, 10);
		if (*end || n == 0 || n > 2097151) {
			fprintf(stderr,
			        "bench_memory: '%s' is not a sphere count "
			        "(1..2097151) or fig16\n",
			        what);
			return 2;
		}
		o.count = (uint32_t)n;
		o.kind = BC_GEN_KIND_SPHERES;
		o.blend = BC_GEN_BLEND_SMOOTH;
	}
	if (!session || !copy || bc_tree_set_layout(session, false)) {
		fprintf(stderr, "bench_memory: out of memory\n");
		return 1;
	}
	r0 = rss_bytes();
	if (bc_gen(gen, &o, session, &cam, &ei)) {
		fprintf(stderr, "bench_memory: %s: %s\n", what, ei.msg);
		return 1;
	}
	r1 = rss_bytes();
	if (bc_tree_copy(copy, session, &ei)) {
		fprintf(stderr, "bench_memory: render copy: %s\n", ei.msg);
		return 1;
	}
	r2 = rss_bytes();
	if (bc_frame_init(&f, w, h)) {
		fprintf(stderr, "bench_memory: out of memory\n");
		return 1;
	}
	/* Written by every frame: the pages count from here. */
	memset(f.rgba, 0, (size_t)w * h * 4u);
	memset(f.depth, 0, (size_t)w * h * sizeof(*f.depth));
	memset(f.ids, 0, (size_t)w * h * sizeof(*f.ids));
	r3 = rss_bytes();
	if (bc_renderer_create(&r, BC_BACKEND_TILED, &ro, &ei) ||
	    bc_renderer_sync(r, copy, NULL, &ei) ||
	    bc_renderer_render(r, &cam, &f, &st, &ei)) {
		fprintf(stderr, "bench_memory: render: %s\n", ei.msg);
		return 1;
	}
	r4 = rss_bytes();
	prims = bc_tree_prim_count(session);
	printf("%s %s: %u primitives, %u nodes; view %ux%u, %u thread(s)\n",
	       gen, what, prims, bc_tree_node_count(session), w, h, threads);
	row("session's tree (bare model)", r1 - r0, prims);
	row("render copy (model laid out)", r2 - r1, prims);
	lin_bytes = lin_rows(bc_tree_lin(copy), prims);
	row("  the rest: pool, layout places, maps", r2 - r1 - lin_bytes,
	    prims);
	row("frame planes (colour, depth, ids)", r3 - r2, prims);
	row("renderer's view (tile lists, view terms)", r4 - r3, prims);
	row("all of it", r4 - r0, prims);
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	bc_tree_destroy(copy);
	bc_tree_destroy(session);
	return 0;
}

int main(int argc, char **argv)
{
	uint32_t size[2] = {1024, 768}, threads = 2;
	const struct bc_opt opts[] = {
	    {.name = "size",
	     .kind = BC_OPT_SIZE,
	     .dst = size,
	     .lo = 64,
	     .hi = BC_RENDER_MAX_DIM,
	     .arg = "WxH",
	     .help = "the view, each side {range} (default 1024x768)"},
	    {.name = "threads",
	     .kind = BC_OPT_U32,
	     .dst = &threads,
	     .lo = 1,
	     .hi = 64,
	     .arg = "T",
	     .help = "the renderer's threads, {range} (default "
	             "{default})"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args args = {
	    .prog = "bench_memory",
	    .usage = "bench_memory [options] [COUNT|fig16 ...]",
	    .about = "Bytes a primitive resident, part by part, of a session "
	             "someone looks at (fig18 smooth spheres, default a "
	             "million).",
	    .opts = opts};
	int rc = 0;
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (!args.npos) {
		return one("1000000", size[0], size[1], threads);
	}
	/* Each scene in a process of its own: memory the allocator kept from
	 * the one before would not count again. */
	for (int i = 0; i < args.npos && rc == 0; i++) {
		pid_t pid;
		int status;
		fflush(stdout);
		pid = fork();
		if (pid < 0) {
			perror("bench_memory: fork");
			return 1;
		}
		if (pid == 0) {
			int crc = one(args.pos[i], size[0], size[1], threads);
			fflush(stdout);
			_exit(crc);
		}
		if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) {
			fprintf(stderr, "bench_memory: %s did not finish\n",
			        args.pos[i]);
			return 1;
		}
		rc = WEXITSTATUS(status);
	}
	return rc;
}
