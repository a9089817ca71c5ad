/*
 * The tiled renderer keeps a fragment's depth interval in 16-bit steps of
 * its tile's depth scale (render/cpu/tiled.h). A step that rounds an entry
 * late or an exit early drops a primitive from a depth range that needs
 * it, which the renders' agreement with `naive` only shows when the error
 * is large: these tests check the rounding itself, on depths of every
 * magnitude the renderer meets (behind the eye, a scene at the origin, one
 * a million units away, lists of one depth), and that a list sorts into
 * one order however it is sorted.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test.h"
#include "tiled.h"

static uint64_t rng = 0x9e3779b97f4a7c15ull;

/* Uniform in [0, 1). */
static double uniform(void)
{
	rng ^= rng << 13;
	rng ^= rng >> 7;
	rng ^= rng << 17;
	return (double)(rng >> 11) * 0x1.0p-53;
}

static void test_fragment_is_eight_bytes(void)
{
	CHECK_EQ_INT((int)sizeof(struct bc__frag), 8);
}

/* Every interval of a list rounds outward, by at most three steps each
 * way (the entry to a step at or below it, the exit to one at or above). */
static int check_list(const float *t0, const float *t1, int n)
{
	float lo = INFINITY, hi = -INFINITY, inv;
	struct bc__zq z;
	int bad = 0;
	for (int i = 0; i < n; i++) {
		lo = fminf(lo, t0[i]);
		hi = fmaxf(hi, t1[i]);
	}
	z = bc__zq_for(lo, hi);
	inv = 1.0f / z.step;
	if (!(z.step > 0.0f) || bc__zq_at(z, 0) != lo ||
	    bc__zq_at(z, BC__ZQ_MAX) < hi) {
		return 1;
	}
	for (int i = 0; i < n; i++) {
		uint32_t q0 = bc__zq_down(z, inv, t0[i]);
		uint32_t q1 = bc__zq_up(z, inv, t1[i]);
		bad += bc__zq_at(z, q0) > t0[i];
		bad += bc__zq_at(z, q1) < t1[i];
		bad += q0 > q1;
		bad += q0 + 3u < BC__ZQ_MAX && bc__zq_at(z, q0 + 4u) <= t0[i];
		bad += q1 > 3u && bc__zq_at(z, q1 - 4u) >= t1[i];
	}
	return bad;
}

static void test_steps_round_outward_at_every_magnitude(void)
{
	static const double bases[] = {0.0, -3.0, 1e-3, 1.0, 7.5, 1e3, 1e6};
	static const double spreads[] = {0.0, 1e-7, 1e-3, 0.5, 40.0, 1e4};
	static float t0[2000], t1[2000];
	int lists = 0, bad = 0;
	for (size_t b = 0; b < sizeof(bases) / sizeof(*bases); b++) {
		for (size_t s = 0; s < sizeof(spreads) / sizeof(*spreads);
		     s++) {
			for (int rep = 0; rep < 60; rep++) {
				int n = 1 + (int)(uniform() * 1999.0);
				for (int i = 0; i < n; i++) {
					double a =
					    bases[b] + spreads[s] * uniform();
					double len = spreads[s] * 0.1 *
					             uniform() * uniform();
					t0[i] = (float)a;
					t1[i] = fmaxf(t0[i], (float)(a + len));
				}
				bad += check_list(t0, t1, n);
				lists++;
			}
		}
	}
	printf("  %d lists, %d intervals rounded wrong\n", lists, bad);
	CHECK_EQ_INT(bad, 0);
}

/* Lists of a single depth, and one spanning the eye. */
static void test_degenerate_lists(void)
{
	float zero[1] = {0.0f}, neg[2] = {-2.0f, -1.0f}, pos[2] = {3.0f, 4.0f};
	float one[3] = {5.0f, 5.0f, 5.0f};
	CHECK_EQ_INT(check_list(zero, zero, 1), 0);
	CHECK_EQ_INT(check_list(one, one, 3), 0);
	CHECK_EQ_INT(check_list(neg, pos, 2), 0);
}

/* Entries keep their order: a list sorted by step is sorted by depth, up
 * to entries that share a step. */
static void test_steps_keep_the_order(void)
{
	enum { N = 5000 };
	static float t[N];
	struct bc__zq z;
	int bad = 0;
	for (int i = 0; i < N; i++) {
		t[i] = (float)(10.0 + 3.0 * i / N + 1e-5 * uniform());
	}
	z = bc__zq_for(t[0], t[N - 1]);
	for (int i = 1; i < N; i++) {
		if (t[i] >= t[i - 1]) {
			bad += bc__zq_down(z, 1.0f / z.step, t[i]) <
			       bc__zq_down(z, 1.0f / z.step, t[i - 1]);
			bad += bc__zq_up(z, 1.0f / z.step, t[i]) <
			       bc__zq_up(z, 1.0f / z.step, t[i - 1]);
		}
	}
	CHECK_EQ_INT(bad, 0);
	/* The scale spends its steps on the list's range: one step is a
	 * 65535th of it (the 4-ulp floor is far below here). */
	CHECK(z.step <= (t[N - 1] - t[0]) / (float)BC__ZQ_MAX * 1.001f);
}

static int by_entry_then_prim(const void *pa, const void *pb)
{
	const struct bc__frag *a = pa, *b = pb;
	if (a->q0 != b->q0) {
		return a->q0 < b->q0 ? -1 : 1;
	}
	return (a->prim > b->prim) - (a->prim < b->prim);
}

/* bc__frags_sort gives qsort's order by (entry, primitive): for lists in
 * primitive order as they are listed (counted from 256 entries on), with
 * entries spread over all 16 bits, bunched in a few steps or all equal;
 * without room to count in; and for lists out of primitive order. */
static void test_sorts_lists_as_qsort_does(void)
{
	static const uint32_t lens[] = {2, 255, 256, 257, 1000, 70000};
	static const uint32_t spreads[] = {65536, 7, 1};
	enum { MAX = 70000 };
	struct bc__frag *a = malloc(MAX * sizeof(*a));
	struct bc__frag *want = malloc(MAX * sizeof(*want));
	struct bc__frag *c = malloc(MAX * sizeof(*c));
	struct bc__frag *tmp = malloc(MAX * sizeof(*tmp));
	REQUIRE(a && want && c && tmp);
	for (size_t i = 0; i < sizeof(lens) / sizeof(lens[0]); i++) {
		for (size_t s = 0; s < 3; s++) {
			uint32_t n = lens[i], prim = 0;
			for (uint32_t k = 0; k < n; k++) {
				prim += 1u + (uint32_t)(uniform() * 50.0);
				a[k].prim = prim;
				a[k].q0 = (uint16_t)(uniform() * spreads[s]);
				a[k].q1 = (uint16_t)k;
			}
			memcpy(want, a, n * sizeof(*a));
			qsort(want, n, sizeof(*want), by_entry_then_prim);
			for (int how = 0; how < 3; how++) {
				memcpy(c, a, n * sizeof(*a));
				for (uint32_t k = 0; how == 2 && k + 1 < n;
				     k++) {
					uint32_t j =
					    k + (uint32_t)(uniform() * (n - k));
					struct bc__frag x = c[k];
					c[k] = c[j];
					c[j] = x;
				}
				bc__frags_sort(c, n, how == 1 ? NULL : tmp);
				CHECK(memcmp(c, want, n * sizeof(*c)) == 0);
			}
		}
	}
	free(a);
	free(want);
	free(c);
	free(tmp);
}

static const struct bc_test tests[] = {
    {"fragment_is_eight_bytes", test_fragment_is_eight_bytes},
    {"steps_round_outward_at_every_magnitude",
     test_steps_round_outward_at_every_magnitude},
    {"degenerate_lists", test_degenerate_lists},
    {"steps_keep_the_order", test_steps_keep_the_order},
    {"sorts_lists_as_qsort_does", test_sorts_lists_as_qsort_does},
};

BC_TEST_MAIN(tests)
