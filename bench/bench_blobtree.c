/*
 * Blobtree benchmarks: the cost of a parameter edit against tree size (it
 * must stay flat: nothing is re-processed), a full re-linearization per
 * thousand primitives (what a REPLACE of the root costs; other structural edits
 * splice the layout instead: bench_splice), and sparse evaluation of a long
 * left comb against a short one (jump pointers make the climb logarithmic).
 *
 * Usage: bench_blobtree [max_exponent]   (default 6: up to 10^6 primitives)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/clock.h"

static double now_s(void)
{
	return (double)bc_clock_ns() * 1e-9;
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

/* n spheres in a cube, one n-ary smooth union (the fig18 shape). */
static struct bc_tree *spheres(uint32_t n)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_SMOOTH_UNION, 0.05f, 0.0f};
	struct bc_prim_data s;
	uint64_t x = 88172645463325252ull;
	float side = cbrtf((float)n);
	bc_tree_begin(t);
	bc_tree_push_op(t, 0, &u, NULL);
	bc_prim_data_init(&s, BC_PRIM_SPHERE);
	s.params[0] = 0.4f;
	for (uint32_t i = 0; i < n; i++) {
		for (int c = 0; c < 3; c++) {
			x ^= x << 13;
			x ^= x >> 7;
			x ^= x << 17;
			s.translate[c] = side * (float)(x >> 40) / 16777216.0f;
		}
		bc_tree_put_prim(t, 0, &s, NULL);
	}
	bc_tree_pop_op(t, NULL);
	if (bc_tree_end(t, NULL)) {
		fprintf(stderr, "build failed\n");
		exit(1);
	}
	return t;
}

static void bench_param_edit(uint32_t n)
{
	struct bc_tree *t = spheres(n);
	enum { EDITS = 20000 };
	static double times[EDITS];
	uint64_t x = 12345;
	const struct bc_lin *l = bc_tree_lin(t);
	for (int e = 0; e < EDITS; e++) {
		uint32_t k, id;
		struct bc_prim_data p;
		double t0;
		x = x * 6364136223846793005ull + 1442695040888963407ull;
		k = (uint32_t)((x >> 33) % l->nprims);
		id = l->node_id[l->prim_slot[k]];
		bc_tree_get(t, id, &p, NULL);
		p.translate[0] += 0.01f;
		t0 = now_s();
		bc_tree_set_prim(t, id, &p, NULL);
		times[e] = now_s() - t0;
	}
	qsort(times, EDITS, sizeof(double), cmp_double);
	printf("param_edit  prims=%-8u median_us=%.3f p99_us=%.3f\n", n,
	       1e6 * times[EDITS / 2], 1e6 * times[EDITS * 99 / 100]);
	bc_tree_destroy(t);
}

static void bench_relinearize(uint32_t n)
{
	struct bc_tree *t = spheres(n);
	int reps = n >= 100000 ? 5 : 50;
	double best = 1e30;
	for (int r = 0; r < reps; r++) {
		double t0 = now_s(), dt;
		/* Structural edits splice the layout now (bench_splice):
		 * the full layout they used to make is timed alone. */
		bc_tree_relayout(t, NULL);
		dt = now_s() - t0;
		if (dt < best) {
			best = dt;
		}
	}
	printf("relinearize prims=%-8u ms=%.3f ms_per_1k=%.4f\n", n, 1e3 * best,
	       1e3 * best / ((double)n / 1000.0));
	bc_tree_destroy(t);
}

static struct bc_tree *comb(uint32_t n)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0, 0};
	struct bc_prim_data s;
	bc_tree_begin(t);
	bc_tree_push_op(t, 0, &u, NULL);
	bc_prim_data_init(&s, BC_PRIM_SPHERE);
	s.params[0] = 0.4f;
	for (uint32_t i = 0; i < n; i++) {
		s.translate[0] = 0.5f * (float)i;
		bc_tree_put_prim(t, 0, &s, NULL);
	}
	bc_tree_pop_op(t, NULL);
	bc_tree_end(t, NULL);
	return t;
}

/* Builds the view of two neighbouring primitives and evaluates it once:
 * the per-query cost of sparse evaluation. With `spread`, each query takes
 * another pair along the comb (memory-bound: the arrays leave the cache);
 * without, the same pair in the middle (the traversal's own cost). */
static double sparse_query_ns(uint32_t n, int spread)
{
	struct bc_tree *t = comb(n);
	const struct bc_lin *l = bc_tree_lin(t);
	struct bc_view v;
	enum { QUERIES = 200000 };
	volatile float sink = 0.0f;
	double t0, dt;
	bc_view_init(&v);
	t0 = now_s();
	for (uint32_t q = 0; q < QUERIES; q++) {
		uint32_t k = spread ? (q * 2654435761u) % (n - 1) : n / 2;
		uint32_t active[2] = {k, k + 1};
		float p[3] = {0.5f * (float)k + 0.25f, 0.1f, 0.0f};
		sink += bc_eval_sparse(l, active, 2, &v, p);
	}
	dt = now_s() - t0;
	(void)sink;
	bc_view_finish(&v);
	bc_tree_destroy(t);
	return 1e9 * dt / QUERIES;
}

int main(int argc, char **argv)
{
	int max_exp = argc > 1 ? atoi(argv[1]) : 6;
	uint32_t n = 100;
	double small, large;
	if (max_exp < 2 || max_exp > 6) {
		fprintf(stderr, "usage: bench_blobtree [2..6]\n");
		return 2;
	}
	for (int e = 2; e <= max_exp; e++, n *= 10) {
		bench_param_edit(n);
	}
	n = 1000;
	for (int e = 3; e <= max_exp; e++, n *= 10) {
		bench_relinearize(n);
	}
	for (int spread = 0; spread < 2; spread++) {
		const char *what = spread ? "pairs_spread" : "same_pair";
		small = sparse_query_ns(100, spread);
		large = sparse_query_ns(100000, spread);
		printf("sparse_comb %s prims=100    ns_per_query=%.1f\n", what,
		       small);
		printf("sparse_comb %s prims=100000 ns_per_query=%.1f "
		       "ratio=%.2f\n",
		       what, large, large / small);
	}
	return 0;
}
