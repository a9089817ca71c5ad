/*
 * Evaluation timings for the benchmarks and `blobcast eval-bench`: random
 * points of the tree's box, evaluated through the pruned variants (octree
 * leaves or grid voxels) and through the full tree, timed on the calling
 * thread. The full tree is timed on a prefix of the points bounded in time,
 * since on large trees it is thousands of times slower; every point timed
 * both ways is also checked for equal signs.
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"

/* The cheapest generator that spreads points well (splitmix64). */
static uint64_t mix(uint64_t *s)
{
	uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
	return z ^ (z >> 31);
}

static float *points_in(const struct bc_lin *l, uint32_t n, uint64_t seed)
{
	float *p = bc_reallocarray(NULL, (size_t)n * 3u, sizeof(float));
	if (!p) {
		return NULL;
	}
	for (size_t i = 0; i < (size_t)n * 3u; i++) {
		float u = (float)(mix(&seed) >> 40) * (1.0f / 16777216.0f);
		int a = (int)(i % 3u);
		p[i] = l->lo[a] + (l->hi[a] - l->lo[a]) * u;
	}
	return p;
}

/* What is timed: a grid or an octree. */
struct target {
	const struct bc_svo *s;
	const struct bc_svo_grid *g;
};

static inline float eval_t(const struct target *t, const float p[3])
{
	return t->s ? bc_svo_eval(t->s, p) : bc_svo_grid_eval(t->g, p);
}

static int time_any(const struct target *t, const struct bc_lin *l, uint32_t n,
                    uint64_t seed, struct bc_svo_timing *out)
{
	float *p, *v;
	volatile float sink = 0.0f;
	float acc = 0.0f;
	double t0, t1;
	uint32_t k;
	memset(out, 0, sizeof(*out));
	if (!l || n == 0) {
		return BC_EINVAL;
	}
	p = points_in(l, n, seed);
	v = bc_reallocarray(NULL, n, sizeof(*v));
	if (!p || !v) {
		bc_free(p);
		bc_free(v);
		return BC_ENOMEM;
	}
	/* Warm the caches once, then time. */
	for (uint32_t i = 0; i < n && i < 1000u; i++) {
		acc += eval_t(t, p + 3u * i);
	}
	t0 = bc_clock_ms();
	for (uint32_t i = 0; i < n; i++) {
		v[i] = eval_t(t, p + 3u * i);
	}
	t1 = bc_clock_ms();
	out->points = n;
	out->pruned_ns = (t1 - t0) * 1e6 / n;
	if (t->s) {
		struct bc_svo_leaf_ref ref;
		t0 = bc_clock_ms();
		for (uint32_t i = 0; i < n; i++) {
			acc += bc_svo_locate(t->s, p + 3u * i, &ref)
			           ? (float)ref.depth
			           : 0.0f;
		}
		t1 = bc_clock_ms();
		out->locate_ns = (t1 - t0) * 1e6 / n;
	}
	t0 = bc_clock_ms();
	for (k = 0; k < n; k++) {
		float f = bc_eval_full(l, p + 3u * k);
		out->mismatches += (f < 0.0f) != (v[k] < 0.0f);
		acc += f;
		/* Check the clock every 64 points: it costs more than a
		 * small tree's evaluation. */
		if ((k & 63u) == 63u &&
		    bc_clock_ms() - t0 > BC_SVO_FULL_TIME_MS) {
			k++;
			break;
		}
	}
	t1 = bc_clock_ms();
	out->full_points = k;
	out->full_ns = (t1 - t0) * 1e6 / k;
	sink = acc;
	(void)sink;
	bc_free(p);
	bc_free(v);
	return 0;
}

int bc_svo_time_octree(const struct bc_svo *s, const struct bc_lin *l,
                       uint32_t points, uint64_t seed,
                       struct bc_svo_timing *out)
{
	struct target t = {s, NULL};
	return time_any(&t, l, points, seed, out);
}

int bc_svo_time_grid(const struct bc_svo_grid *g, const struct bc_lin *l,
                     uint32_t points, uint64_t seed, struct bc_svo_timing *out)
{
	struct target t = {NULL, g};
	return time_any(&t, l, points, seed, out);
}
