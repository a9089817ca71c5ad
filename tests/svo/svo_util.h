/*
 * Helpers of the svo tests: a seeded PRNG, scenes from the generators,
 * single-primitive trees with random sizes and transforms, and random
 * points and regions around a tree.
 */
#ifndef BLOBCAST_TESTS_SVO_UTIL_H
#define BLOBCAST_TESTS_SVO_UTIL_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/svo.h"

struct rng {
	uint64_t s;
};

/* splitmix64: small, fast, good enough to spread test samples. */
static inline uint64_t rng_next(struct rng *r)
{
	uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
	return z ^ (z >> 31);
}

/* Uniform in [lo, hi). */
static inline float rng_f(struct rng *r, float lo, float hi)
{
	float u = (float)(rng_next(r) >> 40) * (1.0f / 16777216.0f);
	return lo + (hi - lo) * u;
}

static inline uint32_t rng_below(struct rng *r, uint32_t n)
{
	return (uint32_t)(rng_next(r) % n);
}

/* A tree from generator name with options (NULL: defaults); returns NULL
 * (and prints why) on failure. */
static inline struct bc_tree *gen_tree(const char *name,
                                       const struct bc_gen_opts *o)
{
	struct bc_errinfo ei = {0};
	struct bc_tree *t = bc_tree_create();
	if (!t) {
		return NULL;
	}
	if (bc_gen(name, o, t, NULL, &ei)) {
		fprintf(stderr, "  gen %s: %s\n", name, ei.msg);
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

/* A random unit quaternion. */
static inline void rng_quat(struct rng *r, float q[4])
{
	float n = 0.0f;
	do {
		n = 0.0f;
		for (int i = 0; i < 4; i++) {
			q[i] = rng_f(r, -1.0f, 1.0f);
			n += q[i] * q[i];
		}
	} while (n < 0.05f || n > 1.0f);
	n = sqrtf(n);
	for (int i = 0; i < 4; i++) {
		q[i] /= n;
	}
}

/* A tree holding one primitive of kind: its default sizes scaled by a
 * random factor (angles kept), a random rotation and a translation within
 * a unit of the origin. Falls back to the defaults when the scaled sizes do
 * not validate. */
static inline struct bc_tree *prim_tree(enum bc_prim kind, struct rng *r)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	struct bc_prim_data p, def;
	struct bc_errinfo ei = {0};
	struct bc_tree *t = bc_tree_create();
	float s = rng_f(r, 0.4f, 1.6f);
	if (!t || !info) {
		bc_tree_destroy(t);
		return NULL;
	}
	bc_prim_data_init(&p, kind);
	for (uint32_t i = 0; i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		if (strstr(d->name, "angle")) {
			continue;
		}
		for (uint32_t c = 0; c < d->count; c++) {
			p.params[d->offset + c] *= s;
		}
	}
	rng_quat(r, p.rotate);
	for (int i = 0; i < 3; i++) {
		p.translate[i] = rng_f(r, -1.0f, 1.0f);
	}
	def = p;
	if (bc_prim_validate(&p, &ei)) {
		bc_prim_data_init(&p, kind);
		memcpy(p.rotate, def.rotate, sizeof(p.rotate));
		memcpy(p.translate, def.translate, sizeof(p.translate));
	}
	if (bc_tree_begin(t) || bc_tree_put_prim(t, 0, &p, &ei) ||
	    bc_tree_end(t, &ei)) {
		fprintf(stderr, "  prim_tree %s: %s\n", info->name, ei.msg);
		bc_tree_destroy(t);
		return NULL;
	}
	return t;
}

/* A random point in the tree's box grown by margin on every side. */
static inline void rng_point(struct rng *r, const struct bc_lin *l,
                             float margin, float p[3])
{
	for (int i = 0; i < 3; i++) {
		p[i] = rng_f(r, l->lo[i] - margin, l->hi[i] + margin);
	}
}

/* A random box of edge up to `edge` times the tree's diagonal, inside the
 * tree's box grown by a tenth. */
static inline void rng_box(struct rng *r, const struct bc_lin *l, float edge,
                           struct bc_svo_region *rg)
{
	float c[3], h;
	memset(rg, 0, sizeof(*rg));
	rng_point(r, l, 0.1f * l->size, c);
	/* Sizes spread over three decades. */
	h = 0.5f * edge * l->size * powf(10.0f, rng_f(r, -3.0f, 0.0f));
	for (int i = 0; i < 3; i++) {
		float hi = h * rng_f(r, 0.5f, 1.0f);
		rg->lo[i] = c[i] - hi;
		rg->hi[i] = c[i] + hi;
	}
}

/* A random segment of length up to `edge` times the diagonal. */
static inline void rng_segment(struct rng *r, const struct bc_lin *l,
                               float edge, struct bc_svo_region *rg)
{
	float n = 0.0f, len;
	memset(rg, 0, sizeof(*rg));
	rg->segment = true;
	rng_point(r, l, 0.1f * l->size, rg->o);
	do {
		n = 0.0f;
		for (int i = 0; i < 3; i++) {
			rg->d[i] = rng_f(r, -1.0f, 1.0f);
			n += rg->d[i] * rg->d[i];
		}
	} while (n < 0.05f || n > 1.0f);
	n = sqrtf(n);
	for (int i = 0; i < 3; i++) {
		rg->d[i] /= n;
	}
	len = edge * l->size * powf(10.0f, rng_f(r, -3.0f, 0.0f));
	rg->t0 = rng_f(r, -0.5f, 0.5f) * len;
	rg->t1 = rg->t0 + len;
}

/* A random point of the region. */
static inline void rng_in(struct rng *r, const struct bc_svo_region *rg,
                          float p[3])
{
	if (rg->segment) {
		float t = rng_f(r, rg->t0, rg->t1);
		for (int i = 0; i < 3; i++) {
			p[i] = rg->o[i] + t * rg->d[i];
		}
	} else {
		for (int i = 0; i < 3; i++) {
			p[i] = rng_f(r, rg->lo[i], rg->hi[i]);
		}
	}
}

#endif
