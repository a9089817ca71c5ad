/*
 * Scene encoding benchmarks: throughput of the JSON reader (jansson plus the
 * strict schema walk plus the builder) and of the binary decoder (two
 * bounded passes plus the builder), and of both writers, on scenes of about
 * 10^5 and 10^6 nodes. Two scene shapes: many-spheres (one n-ary union of
 * plain spheres: the smallest nodes) and fig16 (nested aggregates of
 * rotated, coloured primitives of four kinds). Each figure is the best of a
 * few runs, all measured side by side in one process.
 *
 * Usage: bench_scene [max_exponent]   (default 6: up to 10^6 nodes)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/clock.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"

static double now_s(void)
{
	return (double)bc_clock_ns() * 1e-9;
}

static void die(const char *what, const struct bc_errinfo *ei)
{
	fprintf(stderr, "bench_scene: %s failed: %s\n", what,
	        ei ? ei->msg : "");
	exit(1);
}

static void bench(const char *label, const char *gen,
                  const struct bc_gen_opts *o, int reps)
{
	struct bc_tree *t = bc_tree_create(), *u = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	double best[5] = {1e30, 1e30, 1e30, 1e30, 1e30};
	size_t jlen = 0, blen = 0;
	uint32_t nodes;
	double t0;

	if (!t || !u) {
		die("allocation", NULL);
	}
	t0 = now_s();
	if (bc_gen(gen, o, t, &cam, &ei)) {
		die(gen, &ei);
	}
	best[0] = now_s() - t0;
	nodes = bc_tree_node_count(t);
	for (int r = 0; r < reps; r++) {
		char *text;
		uint8_t *bytes;
		double a, b, c;
		a = now_s();
		text = bc_scene_to_json(t, &cam);
		b = now_s();
		if (!text) {
			die("bc_scene_to_json", NULL);
		}
		jlen = strlen(text);
		if (bc_scene_parse_json(text, jlen, u, NULL, &ei)) {
			die("bc_scene_parse_json", &ei);
		}
		c = now_s();
		bc_free(text);
		best[1] = b - a < best[1] ? b - a : best[1];
		best[2] = c - b < best[2] ? c - b : best[2];
		a = now_s();
		if (bc_scene_encode(t, &cam, &bytes, &blen)) {
			die("bc_scene_encode", NULL);
		}
		b = now_s();
		if (bc_scene_decode(bytes, blen, u, NULL, NULL, &ei)) {
			die("bc_scene_decode", &ei);
		}
		c = now_s();
		bc_free(bytes);
		best[3] = b - a < best[3] ? b - a : best[3];
		best[4] = c - b < best[4] ? c - b : best[4];
	}
	printf("%-22s %9u nodes  gen %7.3f s\n", label, nodes, best[0]);
	printf("  json    %8.1f MB (%5.1f B/node)  write %7.1f MB/s  parse "
	       "%7.1f MB/s (%6.3f s)\n",
	       (double)jlen / 1e6, (double)jlen / nodes,
	       (double)jlen / 1e6 / best[1], (double)jlen / 1e6 / best[2],
	       best[2]);
	printf("  binary  %8.1f MB (%5.1f B/node)  encode %6.1f MB/s  decode "
	       "%6.1f MB/s (%6.3f s)\n",
	       (double)blen / 1e6, (double)blen / nodes,
	       (double)blen / 1e6 / best[3], (double)blen / 1e6 / best[4],
	       best[4]);
	printf("  decode binary vs parse json: %.1fx faster per scene\n",
	       best[2] / best[4]);
	fflush(stdout);
	bc_tree_destroy(t);
	bc_tree_destroy(u);
}

int main(int argc, char **argv)
{
	int max_exp = argc > 1 ? atoi(argv[1]) : 6;
	if (max_exp < 5) {
		max_exp = 5;
	}
	for (int e = 5; e <= max_exp && e <= 6; e++) {
		char label[64];
		uint32_t n = e == 5 ? 100000u : 1000000u;
		/* n - 1 spheres and their union: exactly n nodes. */
		struct bc_gen_opts spheres = {.count = n - 1};
		/* fig16 level e: 10 (10^e - 1) / 9 primitives plus one
		 * operator per aggregate: 1.22 x 10^(e) nodes. */
		struct bc_gen_opts fig16 = {.level = (uint32_t)e};
		int reps = e == 5 ? 5 : 2;
		snprintf(label, sizeof(label), "many-spheres 10^%d", e);
		bench(label, "many-spheres", &spheres, reps);
		snprintf(label, sizeof(label), "fig16 level %d", e);
		bench(label, "fig16", &fig16, reps);
	}
	return 0;
}
