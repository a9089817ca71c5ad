/*
 * Helpers of the svo tests: a seeded PRNG, scenes from the generators,
 * single-primitive trees with random sizes and transforms, and random
 * points and regions around a tree.
 */
#ifndef BLOBCAST_TESTS_SVO_UTIL_H
#define BLOBCAST_TESTS_SVO_UTIL_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
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

/* Whether two casts of one ray agree bit for bit: hit or not, depth, id,
 * normals' variant and terms. Not the evaluation counts: a packet skips
 * with one range evaluation of its beam a leaf where none of its rays can
 * hit, which a ray alone steps through (cast.c, beam_clear). */
static inline bool same_hit(bool ha, const struct bc_svo_hit *a, bool hb,
                            const struct bc_svo_hit *b)
{
	return ha == hb &&
	       (!ha || (memcmp(&a->t, &b->t, sizeof(a->t)) == 0 &&
	                a->prim == b->prim && a->mask.pairs == b->mask.pairs &&
	                a->mask.nwords == b->mask.nwords &&
	                a->leaf_terms == b->leaf_terms));
}

/*
 * bc_svo_cast_packet against bc_svo_cast over the w x h pixels of cam, ray
 * by ray, bit for bit (same_hit), and for no more point evaluations than
 * the ray alone, with three groupings: the backend's 4 x 2 blocks,
 * packets of eight pixels drawn at random from the whole image (their rays
 * run different ways along an axis, so some are cast alone), and blocks
 * of one to seven pixels. cp is filled for the frame. Returns how many
 * rays differ, printing the first; *hits counts the rays that hit and
 * *alone the rays of the 4 x 2 blocks that their packet cast alone (the
 * packets must really walk together: a caster that cast every ray alone
 * would find the same hits).
 */
static inline uint32_t packet_mismatches(const struct bc_svo *s,
                                         const struct bc_camera *cam,
                                         uint32_t w, uint32_t h,
                                         struct bc_svo_cast_params *cp,
                                         uint32_t *hits, uint32_t *alone)
{
	uint64_t packed0, alone0, packed1, alone1;
	struct bc_svo_caster *c = NULL;
	struct bc_view_rays vr;
	struct bc_svo_hit *one = calloc((size_t)w * h, sizeof(*one));
	bool *hit = calloc((size_t)w * h, sizeof(*hit));
	struct rng r = {0x5eed};
	uint32_t bad = 0, n = w * h;
	*hits = 0;
	*alone = UINT32_MAX;
	bc_view_rays_init(&vr, cam, w, h);
	if (!one || !hit || bc_svo_caster_create(&c, s)) {
		free(one);
		free(hit);
		return UINT32_MAX;
	}
	for (uint32_t i = 0; i < n; i++) {
		float d[3];
		bc_view_rays_dir(&vr, (float)(i % w) + 0.5f,
		                 (float)(i / w) + 0.5f, d);
		hit[i] = bc_svo_cast(c, vr.eye, d, 0.0f, INFINITY, cp, &one[i]);
		*hits += hit[i];
	}
	bc_svo_caster_counts(c, &packed0, &alone0);
	for (int pass = 0; pass < 3; pass++) {
		for (uint32_t k = 0; k < n; k += BC_SVO_PACKET) {
			uint32_t pix[BC_SVO_PACKET], m = 0, got;
			float d[BC_SVO_PACKET][3];
			struct bc_svo_hit ph[BC_SVO_PACKET];
			uint32_t want =
			    pass == 2 ? 1u + rng_below(&r, 7u) : BC_SVO_PACKET;
			for (uint32_t l = 0; l < want; l++) {
				/* Block k / 8 of 4 x 2 pixels, or anywhere. */
				uint32_t b = k / BC_SVO_PACKET, bw = w / 4u;
				uint32_t x = (b % bw) * 4u + l % 4u,
				         y = (b / bw) * 2u + l / 4u;
				uint32_t i =
				    pass == 1 ? rng_below(&r, n) : y * w + x;
				if (y >= h) {
					continue;
				}
				bc_view_rays_dir(&vr, (float)(i % w) + 0.5f,
				                 (float)(i / w) + 0.5f, d[m]);
				pix[m++] = i;
			}
			if (!m) {
				continue;
			}
			got =
			    bc_svo_cast_packet(c, vr.eye, (const float(*)[3])d,
			                       m, 0.0f, INFINITY, cp, ph);
			for (uint32_t l = 0; l < m; l++) {
				uint32_t i = pix[l];
				/* The same hit, for no more point
				 * evaluations than alone. */
				if (!same_hit(hit[i], &one[i], (got >> l) & 1u,
				              &ph[l]) ||
				    ph[l].evals > one[i].evals) {
					if (!bad) {
						printf(
						    "  pass %d pixel %u: "
						    "alone %d t %.9g evals %u"
						    ", packet %d t %.9g "
						    "evals %u\n",
						    pass, i, hit[i],
						    (double)one[i].t,
						    one[i].evals,
						    (int)((got >> l) & 1u),
						    (double)ph[l].t,
						    ph[l].evals);
					}
					bad++;
				}
			}
		}
		if (pass == 0) {
			bc_svo_caster_counts(c, &packed1, &alone1);
			*alone = (uint32_t)(alone1 - alone0);
			if (packed1 - packed0 + alone1 - alone0 == 0) {
				*alone = UINT32_MAX; /* nothing was cast */
			}
		}
	}
	bc_svo_caster_destroy(c);
	free(one);
	free(hit);
	return bad;
}

/*
 * bc_svo_cast_packet against bc_svo_cast on rays no camera makes: npackets
 * packets of one to eight rays from an origin drawn in and around the
 * tree's box (inside the octree too), with t0 and t1 drawn (t1 finite or
 * not), half of them coherent (directions a few degrees apart), half any
 * directions, some with components exactly 0; and one packet of more rays
 * than it may hold, which must cast nothing and clear every hit. Returns
 * how many rays differ (printing the first).
 */
static inline uint32_t
packet_mismatches_random(const struct bc_svo *s, const struct bc_svo_rpn *rpn,
                         const struct bc_svo_cast_params *cp, uint32_t npackets,
                         uint64_t seed)
{
	struct bc_svo_caster *c = NULL;
	struct rng r = {seed};
	uint32_t bad = 0;
	if (bc_svo_caster_create(&c, s)) {
		return UINT32_MAX;
	}
	for (uint32_t k = 0; k < npackets; k++) {
		float o[3], base[3], d[BC_SVO_PACKET][3], t0, t1;
		struct bc_svo_hit ph[BC_SVO_PACKET], one;
		uint32_t n = 1u + rng_below(&r, BC_SVO_PACKET), got;
		bool coherent = k & 1u;
		for (int i = 0; i < 3; i++) {
			float m = 0.2f * (rpn->hi[i] - rpn->lo[i]);
			o[i] = rng_f(&r, rpn->lo[i] - m, rpn->hi[i] + m);
			base[i] = rng_f(&r, -1.0f, 1.0f);
		}
		/* A quarter of the packets start on a mid plane of one of the
		 * octree's first three levels (the same floats the walk
		 * computes), and half of their rays run parallel to it: the
		 * walk's rule for a ray in a plane it never crosses. */
		int plane = rng_below(&r, 4) == 0 ? (int)rng_below(&r, 3) : -1;
		if (plane >= 0) {
			float lo[3], hi[3], mid = 0.0f;
			bc_svo_bounds(s, lo, hi);
			for (uint32_t j = 0, lv = 1u + rng_below(&r, 3); j < lv;
			     j++) {
				mid = 0.5f * (lo[plane] + hi[plane]);
				if (rng_below(&r, 2)) {
					lo[plane] = mid;
				} else {
					hi[plane] = mid;
				}
			}
			o[plane] = mid;
		}
		t0 =
		    rng_below(&r, 2) ? 0.0f : rng_f(&r, 0.0f, 0.3f) * rpn->size;
		t1 = rng_below(&r, 2) ? INFINITY
		                      : t0 + rng_f(&r, 0.05f, 1.5f) * rpn->size;
		for (uint32_t l = 0; l < n; l++) {
			float len = 0.0f;
			for (int i = 0; i < 3; i++) {
				d[l][i] = coherent ? base[i] + rng_f(&r, -0.05f,
				                                     0.05f)
				                   : rng_f(&r, -1.0f, 1.0f);
				if (rng_below(&r, 16) == 0 ||
				    (i == plane && rng_below(&r, 2))) {
					d[l][i] = 0.0f;
				}
				len += d[l][i] * d[l][i];
			}
			len = sqrtf(len);
			for (int i = 0; i < 3; i++) {
				d[l][i] = len > 0.0f ? d[l][i] / len
				                     : (i == 0 ? 1.0f : 0.0f);
			}
		}
		got = bc_svo_cast_packet(c, o, (const float(*)[3])d, n, t0, t1,
		                         cp, ph);
		for (uint32_t l = 0; l < n; l++) {
			bool h = bc_svo_cast(c, o, d[l], t0, t1, cp, &one);
			if (!same_hit(h, &one, (got >> l) & 1u, &ph[l]) ||
			    ph[l].evals > one.evals) {
				if (!bad) {
					printf(
					    "  random packet %u ray %u: alone "
					    "%d t %.9g, packet %d t %.9g\n",
					    k, l, h, (double)one.t,
					    (int)((got >> l) & 1u),
					    (double)ph[l].t);
				}
				bad++;
			}
		}
	}
	{
		/* More rays than a packet holds: nothing cast, every hit
		 * cleared (svo.h). */
		float o[3] = {0.0f, 0.0f, 0.0f}, d[BC_SVO_PACKET + 1][3];
		struct bc_svo_hit ph[BC_SVO_PACKET + 1];
		uint32_t got;
		memset(ph, 0xab, sizeof(ph));
		for (uint32_t l = 0; l <= BC_SVO_PACKET; l++) {
			d[l][0] = 0.0f;
			d[l][1] = 0.0f;
			d[l][2] = 1.0f;
		}
		got = bc_svo_cast_packet(c, o, (const float(*)[3])d,
		                         BC_SVO_PACKET + 1, 0.0f, INFINITY, cp,
		                         ph);
		for (uint32_t l = 0; l <= BC_SVO_PACKET; l++) {
			bad += got != 0 || ph[l].prim != BC_NONE ||
			       ph[l].evals != 0 || ph[l].range_evals != 0;
		}
	}
	bc_svo_caster_destroy(c);
	return bad;
}

/* The cast parameters of a w x h frame of cam, as the backend sets them,
 * and the hit band the octree must keep for them (with its 50 % slack). */
/* The packet tests' verdict on one octree and view: packet_mismatches over
 * a w x h frame (cp filled for it) and packet_mismatches_random (300
 * packets from seed) find no ray that differs from its cast alone, more
 * than a twentieth of the frame's rays hit, and at most a twentieth of
 * the blocks' rays are cast alone (the packets really walk together).
 * Prints one line, label first, with the counts. */
static inline bool packets_agree(const struct bc_svo *s,
                                 const struct bc_svo_rpn *rpn,
                                 const struct bc_camera *cam, uint32_t w,
                                 uint32_t h, struct bc_svo_cast_params *cp,
                                 uint64_t seed, const char *label)
{
	uint32_t hits, alone;
	uint32_t bad = packet_mismatches(s, cam, w, h, cp, &hits, &alone);
	uint32_t rnd = packet_mismatches_random(s, rpn, cp, 300, seed);
	printf("  %s: %u of %u rays hit, %u differ in packets (%u of the "
	       "blocks' cast alone), %u of random packets\n",
	       label, hits, w * h, bad, alone, rnd);
	return bad == 0 && rnd == 0 && hits > w * h / 20 &&
	       alone * 20u <= w * h;
}

static inline float frame_cast_params(const struct bc_svo_rpn *rpn,
                                      const struct bc_camera *cam, uint32_t w,
                                      uint32_t h, struct bc_svo_cast_params *cp)
{
	struct bc_view_rays vr;
	float far = 0.0f;
	bc_view_rays_init(&vr, cam, w, h);
	memset(cp, 0, sizeof(*cp));
	cp->pix_angle = 2.0f * vr.tan_half_y / (float)h;
	cp->min_step = BC_SVO_MIN_STEP_REL * rpn->size;
	cp->refine_tol = BC_SVO_REFINE_REL * rpn->size;
	for (uint32_t k = 0; k < 8; k++) {
		float s2 = 0.0f;
		for (int a = 0; a < 3; a++) {
			float x = (k >> a) & 1u ? rpn->hi[a] : rpn->lo[a];
			s2 += (x - vr.eye[a]) * (x - vr.eye[a]);
		}
		far = fmaxf(far, sqrtf(s2));
	}
	return 1.5f * bc_svo_hit_band(cp, far);
}

#endif
