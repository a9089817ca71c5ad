/*
 * Ray casting through the octree (thesis §5.6, Alg. 5.7-5.8). The ray visits
 * the leaves it crosses front to back: empty leaves are skipped, a full leaf
 * is a hit where the ray enters it, and in a leaf that holds surface the
 * segment is searched for its first root by interval bisection on the leaf's
 * pruned variant, in the octree's arithmetic (the segment is an affine form
 * of one noise symbol, so AA and RevAA keep the ray's correlation exactly).
 *
 * What is searched for is the first point where the field drops below the
 * hit band c(t), the sphere tracer's criterion (svo.h), so that both
 * renderers agree on silhouettes; the octree was built to keep the sign of
 * f - c for every c the frame uses. Bisection stops once a bracket is as
 * wide as the pixel footprint: then either its ends straddle the band and
 * the Illinois variant of regula falsi refines the crossing (superlinear,
 * unlike the thesis's plain bisection), or the dip is smaller than a pixel
 * and is dropped. The band's entry is where the ray hit, not the depth:
 * settle() refines it to the field's zero crossing, or on a silhouette to
 * the ray's closest approach, as the sphere tracer does, so that depths
 * agree to the refinement tolerance and not to the band's thickness.
 *
 * An evaluation bound (cp->max_evals) is checked before every point and
 * range evaluation of a ray (afford); where it is spent, the function
 * returns at once, the ray is marked ran_out and every caller up to the
 * cast gives it up, neither hit nor miss. Nothing else changes, so a ray
 * the bound does not stop is cast exactly as without one.
 */
#include "svo_impl.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/render_common.h"

/* Bisection depth at most: a segment halves per level, and 2^-40 of any
 * leaf is below float resolution. */
#define CAST_MAX_LEVELS 40
/* Iterations of the refinement at most; Illinois converges superlinearly,
 * so this only bounds degenerate brackets. */
#define CAST_MAX_REFINE 40
/* settle(): a probe goes at most this many bands past the last sample, and
 * the march takes at most this many probes (enough for its depth limit of
 * 64 bands at a band per step, with room for the short steps of a descent
 * onto a crossing). */
#define SETTLE_MAX_REACH 4.0f
#define SETTLE_MAX_STEPS 96
/* Steps through a 1-Lipschitz leaf before interval bisection takes over
 * the rest of its segment: a ray that passes a surface just outside the
 * band converges slowly, and bisection settles it in a few halvings. But
 * each halving is a range evaluation of every term: after 12 steps,
 * bisection took 10 % of a 64-sphere frame; after 24, a pixel-wide step
 * costs less than the halvings it spares (4-5 % faster frames, the depth
 * tests' figures unchanged). */
#define STEP_MAX 24
/* A step goes this fraction of the distance the Lipschitz bound allows:
 * the float field may be a few ulps below the exact one. */
#define STEP_SAFE 0.999f

struct bc_svo_caster {
	const struct bc_svo *s;
	struct bc_svo_ranger *g;
	uint32_t *idx;
	uint32_t *pidx;         /* a packet's leaf terms (leaf_root uses idx) */
	uint64_t packed, alone; /* bc_svo_caster_counts */
	uint32_t hit_leaf;      /* where the last packet hit (BC_NONE: none) */
	float pd[3][BC_SVO_PACKET]; /* the packet's directions by axis (0 past
	                               its rays) */
};

int bc_svo_caster_create(struct bc_svo_caster **out, const struct bc_svo *s)
{
	struct bc_svo_caster *c;
	int rc;
	*out = NULL;
	c = bc_calloc(1, sizeof(*c));
	if (!c) {
		return BC_ENOMEM;
	}
	c->s = s;
	c->hit_leaf = BC_NONE;
	c->idx = bc_calloc(s->rpn->n, sizeof(*c->idx));
	c->pidx = bc_calloc(s->rpn->n, sizeof(*c->pidx));
	if (!c->idx || !c->pidx) {
		bc_svo_caster_destroy(c);
		return BC_ENOMEM;
	}
	if ((rc = bc_svo_ranger_create(&c->g, s->rpn, s->opts.arith))) {
		bc_svo_caster_destroy(c);
		return rc;
	}
	*out = c;
	return 0;
}

void bc_svo_caster_destroy(struct bc_svo_caster *c)
{
	if (!c) {
		return;
	}
	bc_svo_ranger_destroy(c->g);
	bc_free(c->idx);
	bc_free(c->pidx);
	bc_free(c);
}

/* fmaxf and fminf are library calls (they must handle NaN); the caster's
 * operands are finite, and these run several times per sample. */
static inline float maxf(float a, float b)
{
	return a > b ? a : b;
}
static inline float minf(float a, float b)
{
	return a < b ? a : b;
}

static inline float band_at(const struct bc_svo_cast_params *cp, float t)
{
	return BC_SVO_HIT_LIPSCHITZ *
	       maxf(BC_SVO_HIT_FOOTPRINT * cp->pix_angle * t, cp->min_step);
}

float bc_svo_hit_band(const struct bc_svo_cast_params *cp, float t)
{
	/* In field units, whatever the tree's Lipschitz bound: the sphere
	 * tracer divides its steps by that bound, not its hit band. */
	return band_at(cp, t);
}

/* Whether the ray of hit may spend n more evaluations (point and range)
 * within cp's bound. When it may not, it has run out: ran_out is set and
 * the caller stops the ray without evaluating. Every evaluation of a ray
 * is preceded by this test, so a bounded ray stops before the first one
 * past the bound, and one that never meets it takes the same samples as
 * without a bound. */
static inline bool afford(const struct bc_svo_cast_params *cp,
                          struct bc_svo_hit *hit, uint32_t n)
{
	uint32_t used;
	if (!cp->max_evals) {
		return true;
	}
	used = hit->evals + hit->range_evals;
	if (used <= cp->max_evals && cp->max_evals - used >= n) {
		return true;
	}
	hit->ran_out = true;
	return false;
}

/* A field along the ray: a leaf's variant, or the octree (mask NULL).
 * Through the octree, the last leaf found is kept: the samples of a
 * refinement lie close together, mostly in one leaf, and the walk from
 * the root would otherwise cost as much as the evaluation. */
struct ray_field {
	const struct bc_svo *s;
	const struct bc_svo_cmask *mask;
	const uint32_t *list; /* the mask's terms decoded, or NULL */
	uint32_t nlist;
	uint32_t *buf; /* through the octree: where the terms of the leaf
	                  found last are decoded (NULL: not decoded) */
	const float *o, *d;
	const struct bc_svo_cast_params *cp;
	bool banded;            /* subtract the hit band */
	struct bc_svo_hit *hit; /* counts the evaluations */
	bool cached;
	struct bc_svo_leaf_ref leaf;
};

static inline bool in_box(const float lo[3], const float hi[3],
                          const float p[3])
{
	/* The octree sends a point on a mid plane to the upper child
	 * (bc_svo_locate), so a box holds its lower faces only. */
	return p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1] &&
	       p[2] >= lo[2] && p[2] < hi[2];
}

/* Decodes a stored mask into its increasing list of terms; returns n. */
static uint32_t decode(const struct bc_svo_cmask *m, uint32_t *list)
{
	uint32_t n = 0;
	for (uint32_t w = 0; w < m->nwords; w++) {
		uint32_t base = m->pairs[2 * w] << 5, b = m->pairs[2 * w + 1];
		while (b) {
			list[n++] = base + bc__svo_lowest(b);
			b &= b - 1u;
		}
	}
	return n;
}

static float field_at(struct ray_field *rf, float t)
{
	float p[3] = {rf->o[0] + t * rf->d[0], rf->o[1] + t * rf->d[1],
	              rf->o[2] + t * rf->d[2]};
	float v;
	if (rf->list) {
		v = bc__svo_list_eval(rf->s->rpn, rf->list, rf->nlist, p);
	} else if (rf->mask) {
		v = bc_svo_cmask_eval(rf->s->rpn, *rf->mask, p);
	} else {
		if (!(rf->cached && in_box(rf->leaf.lo, rf->leaf.hi, p))) {
			rf->cached = bc_svo_locate(rf->s, p, &rf->leaf);
			rf->nlist = 0;
			if (rf->cached && rf->buf &&
			    rf->leaf.state == BC_SVO_STATE_ACTIVE) {
				rf->nlist = decode(&rf->leaf.mask, rf->buf);
			}
		}
		if (!rf->cached) {
			v = bc_svo_eval(rf->s, p); /* outside the root */
		} else if (rf->leaf.state != BC_SVO_STATE_ACTIVE) {
			v = rf->leaf.value;
		} else if (rf->buf) {
			v = bc__svo_list_eval(rf->s->rpn, rf->buf, rf->nlist,
			                      p);
		} else {
			v = bc_svo_cmask_eval(rf->s->rpn, rf->leaf.mask, p);
		}
	}
	rf->hit->evals++;
	return rf->banded ? v - band_at(rf->cp, t) : v;
}

/* Illinois refinement of a root of rf in [a, b] with fa > 0 >= fb, to the
 * refinement tolerance; returns the root interpolated in the last bracket
 * (as the sphere tracer does). On a field that is nearly linear across
 * the bracket (a surface at pixel scale) the first secant sample lands
 * within the tolerance of the root, but the bracket's far end stays where
 * it was and Illinois would take several halvings to bring it in; so when
 * the next sample would fall within half the tolerance of the last one, it
 * goes half the tolerance past it instead, and the bracket closes at once
 * if the root is there. */
/* refine()'s state, cut at each sample so that a packet's lanes can run it
 * in lockstep (packet_hits) with the same operations. */
struct illinois {
	float a, fa, b, fb;
	int side, i;
};

/* The loop head: the next sample m, or false when the bracket is done. */
static inline bool ill_next(const struct illinois *s, float tol, float *m_out)
{
	float a = s->a, b = s->b, fa = s->fa, fb = s->fb, m;
	if (!(s->i < CAST_MAX_REFINE && b - a > tol)) {
		return false;
	}
	m = fa - fb > 0.0f ? a + (b - a) * fa / (fa - fb) : 0.5f * (a + b);
	if (s->side == 1 && m - a < 0.5f * tol) {
		m = a + 0.5f * tol;
	} else if (s->side == -1 && b - m < 0.5f * tol) {
		m = b - 0.5f * tol;
	}
	if (!(m > a && m < b)) {
		m = 0.5f * (a + b);
		if (!(m > a && m < b)) {
			return false; /* float resolution */
		}
	}
	*m_out = m;
	return true;
}

/* The sample fm at m narrows the bracket. */
static inline void ill_take(struct illinois *s, float m, float fm)
{
	if (fm > 0.0f) {
		s->a = m;
		s->fa = fm;
		if (s->side == 1) {
			s->fb *= 0.5f; /* Illinois: unstick the far end */
		}
		s->side = 1;
	} else {
		s->b = m;
		s->fb = fm;
		if (s->side == -1) {
			s->fa *= 0.5f;
		}
		s->side = -1;
	}
	s->i++;
}

/* The root interpolated in the last bracket. */
static inline float ill_root(const struct illinois *s)
{
	float a = s->a, b = s->b, fa = s->fa, fb = s->fb;
	if (fa - fb > 0.0f && isfinite(fa - fb)) {
		float t = a + (b - a) * fa / (fa - fb);
		return t < a ? a : (t > b ? b : t);
	}
	return a;
}

/* (Returns no root when the ray runs out of its bound: the callers look
 * at hit->ran_out.) */
static float refine(struct ray_field *rf, float a, float fa, float b, float fb)
{
	struct illinois s = {a, fa, b, fb, 0, 0};
	float m;
	while (ill_next(&s, rf->cp->refine_tol, &m)) {
		if (!afford(rf->cp, rf->hit, 1)) {
			return a;
		}
		ill_take(&s, m, field_at(rf, m));
	}
	return ill_root(&s);
}

/* Alg. 5.7 on one leaf's segment [ta, tb]: the first t where the variant
 * drops below the band, if any (false, and hit->ran_out, when the ray's
 * bound stopped it). */
static bool leaf_root(struct bc_svo_caster *c, const struct bc_svo_cmask *m,
                      const float o[3], const float d[3], float ta, float tb,
                      const struct bc_svo_cast_params *cp,
                      struct bc_svo_hit *hit, float *t_out)
{
	struct {
		float a, b;
	} st[CAST_MAX_LEVELS + 2];
	struct ray_field rf = {c->s, m,  NULL, 0,   NULL,  o,
	                       d,    cp, true, hit, false, {0}};
	struct bc_svo_region rg;
	uint32_t n = decode(m, c->idx), sp = 0;
	memset(&rg, 0, sizeof(rg));
	rg.segment = true;
	memcpy(rg.o, o, sizeof(rg.o));
	memcpy(rg.d, d, sizeof(rg.d));
	st[sp].a = ta;
	st[sp++].b = tb;
	while (sp) {
		float u0, u1, um, c0, c1;
		struct bc_svo_ivl r;
		sp--;
		u0 = st[sp].a;
		u1 = st[sp].b;
		c0 = band_at(cp, u0);
		c1 = band_at(cp, u1);
		rg.t0 = u0;
		rg.t1 = u1;
		if (!afford(cp, hit, 1)) {
			return false;
		}
		r = bc_svo_range(c->g, c->idx, n, &rg);
		hit->range_evals++;
		if (r.lo > (double)c1) {
			continue; /* above the band all along: no hit here */
		}
		if (r.hi < (double)c0) {
			/* Below it all along; everything before was above. */
			*t_out = u0;
			return true;
		}
		um = 0.5f * (u0 + u1);
		if (u1 - u0 <= maxf(cp->pix_angle * u1, cp->min_step) ||
		    sp >= CAST_MAX_LEVELS || !(um > u0 && um < u1)) {
			float g0, g1;
			if (!afford(cp, hit, 1)) {
				return false;
			}
			g0 = field_at(&rf, u0);
			if (g0 <= 0.0f) {
				*t_out = u0;
				return true;
			}
			if (!afford(cp, hit, 1)) {
				return false;
			}
			g1 = field_at(&rf, u1);
			if (g1 <= 0.0f) {
				*t_out = refine(&rf, u0, g0, u1, g1);
				return !hit->ran_out;
			}
			continue; /* a dip narrower than a pixel */
		}
		st[sp].a = um;
		st[sp++].b = u1;
		st[sp].a = u0;
		st[sp++].b = um;
	}
	return false;
}

/*
 * A leaf whose variant is 1-Lipschitz (no inexact primitive, no blend: svo.h,
 * rpn->steep) is searched by stepping, the same test as bisection made once
 * per sample: the variant at t' >= t is at least f(t) - (t' - t), so no
 * point of [t, t + s], s = f(t) - c(tb), drops below the band c <= c(tb).
 * For such a variant the interval of a segment in IA is that Lipschitz
 * enclosure anyway (range_tmpl.h), so each bisection level cost a range
 * evaluation of every term to learn what one point evaluation tells.
 *
 * Once s is shorter than a pixel footprint w, the next sample goes w
 * ahead, or a little past t + f(t) where that is nearer (the crossing of a
 * surface that faces the ray). That sample either lies below the band,
 * and the bracket it closes is refined as bisection refines its last one
 * (at once to the field's zero when the field is already negative there:
 * the band's entry and the crossing settle() would march to then lie in
 * one pixel-wide bracket), or above it, and the stretch between the two
 * samples is at most a pixel wide with both ends above the band:
 * bisection drops such a bracket too. After STEP_MAX samples interval
 * bisection takes over the rest of the segment.
 */
struct lane_step {
	float t, g; /* the last sample and its field minus the band */
	float tb;   /* the leaf's exit */
	float cmax; /* the band at the exit */
	int i;      /* samples taken after the entry */
};

/* Where a stepping ray samples next; false where bisection must take the
 * rest of the segment (STEP_MAX samples taken, or float resolution). */
static inline bool step_next(const struct bc_svo_cast_params *cp,
                             const struct lane_step *ls, float *q_out)
{
	/* g = f - c(t), so f - c(tb) = g + c(t) - c(tb). The choices are
	 * selects, not branches: a packet's lanes take them every round,
	 * and which way they go is a coin toss for the predictor. */
	float t = ls->t, g = ls->g, c = band_at(cp, t);
	float safe = STEP_SAFE * (g + c - ls->cmax);
	float w = maxf(cp->pix_angle * t, cp->min_step);
	/* Close to the band (safe below w, or not positive: the band
	 * widens ahead, w decides): where a surface faces the ray, the
	 * field's own value is the distance to it, and a sample a little
	 * past that lands beyond the crossing and brackets it tightly. */
	bool near = !(safe > 0.0f) | (safe < w);
	float q = near ? t + minf(w, 1.125f * (g + c)) : t + safe;
	*q_out = minf(q, ls->tb);
	/* Float resolution, or STEP_MAX samples: bisection decides. */
	return (ls->i < STEP_MAX) & (q > t);
}

/* The sample at q = step_next's fell below the band (gq = field minus
 * band <= 0): the hit, refined in rf.
 *
 * Where the field is negative at q the crossing lies in [t, q] and is
 * refined at once. Where it is still positive (the ray entered the band
 * but not the solid: the common case on an oblique surface, whose field
 * falls slower than the ray advances), one more sample goes past the
 * crossing the two samples' slope predicts, at most a pixel footprint
 * further and not past the leaf: if it is inside, the crossing lies
 * between it and q and is refined there, and settle() is not needed (its
 * march from the band's entry, in [t, q], would look for the same first
 * crossing; a sliver thinner than the probe's overshoot is the exception,
 * docs/svo.md). Otherwise (a silhouette: a ray that only grazes) the band's
 * entry is refined and settle() takes over.
 *
 * hit_plan says what that takes: the bracket to refine (on the banded
 * field or the field itself), after the probe at q2 if `probe` is set
 * (hit_probed: if the field there is not positive, [q, q2] unbanded and
 * settled instead); step_hit runs it for one ray, packet_hits for the
 * lanes of a packet in lockstep. */
struct hit_plan {
	struct illinois ill;
	bool banded, settled, probe;
	float q, fq, q2; /* the last sample in the band and the next probe */
	float tb;        /* the leaf's exit */
	int probes;      /* taken or under way */
};

/* Probes at most: each goes at most a pixel footprint ahead, and on an
 * oblique surface the first may fall short of the crossing. */
#define HIT_PROBES 3

/* The next probe after the sample fq at q, the previous one fp at tp:
 * past the crossing their slope predicts, at most a pixel footprint
 * ahead and not past the leaf. False where there is no room. */
static inline bool probe_next(const struct bc_svo_cast_params *cp,
                              struct hit_plan *h, float tp, float fp, float q,
                              float fq)
{
	float w = maxf(cp->pix_angle * q, cp->min_step);
	float slope = minf((fp - fq) / (q - tp), 1.0f);
	float q2 = minf(q + minf(w, 1.125f * fq / slope), h->tb);
	if (!(q2 > q)) {
		return false;
	}
	h->q = q;
	h->fq = fq;
	h->q2 = q2;
	h->probes++;
	return true;
}

static struct hit_plan hit_plan(const struct bc_svo_cast_params *cp,
                                const struct lane_step *ls, float q, float gq)
{
	struct hit_plan h;
	float fq = gq + band_at(cp, q);
	float ft = ls->g + band_at(cp, ls->t);
	memset(&h, 0, sizeof(h));
	if (fq <= 0.0f) {
		h.ill = (struct illinois){ls->t, ft, q, fq, 0, 0};
		h.settled = true;
		return h;
	}
	h.ill = (struct illinois){ls->t, ls->g, q, gq, 0, 0};
	h.banded = true;
	h.tb = ls->tb;
	h.probe = ft > fq && probe_next(cp, &h, ls->t, ft, q, fq);
	return h;
}

/* The probe's field f2 at q2: inside, the crossing is bracketed; still
 * falling and in the band, another probe; else the band's entry is what
 * gets refined (settle() follows). */
static void hit_probed(const struct bc_svo_cast_params *cp, struct hit_plan *h,
                       float f2)
{
	if (f2 <= 0.0f) {
		h->ill = (struct illinois){h->q, h->fq, h->q2, f2, 0, 0};
		h->banded = false;
		h->settled = true;
		h->probe = false;
		return;
	}
	h->probe = h->probes < HIT_PROBES && f2 < h->fq &&
	           f2 <= band_at(cp, h->q2) &&
	           probe_next(cp, h, h->q, h->fq, h->q2, f2);
}

/* The hit, refined in rf (the leaf's variant); *settled when the depth
 * is the crossing already. (No hit when the ray runs out of its bound:
 * the caller looks at hit->ran_out.) */
static float step_hit(struct ray_field *rf, const struct lane_step *ls, float q,
                      float gq, bool *settled)
{
	struct hit_plan h = hit_plan(rf->cp, ls, q, gq);
	float m;
	while (h.probe) {
		if (!afford(rf->cp, rf->hit, 1)) {
			return q;
		}
		rf->banded = false;
		hit_probed(rf->cp, &h, field_at(rf, h.q2));
	}
	rf->banded = h.banded;
	while (ill_next(&h.ill, rf->cp->refine_tol, &m)) {
		if (!afford(rf->cp, rf->hit, 1)) {
			return q;
		}
		ill_take(&h.ill, m, field_at(rf, m));
	}
	*settled = h.settled;
	return ill_root(&h.ill);
}

/* The sample gq > 0 at q: the next step, or false at the leaf's exit. */
static inline bool step_on(struct lane_step *ls, float q, float gq)
{
	if (!(q < ls->tb)) {
		return false;
	}
	ls->t = q;
	ls->g = gq;
	ls->i++;
	return true;
}

static bool leaf_step(struct bc_svo_caster *c, const struct bc_svo_cmask *m,
                      const float o[3], const float d[3], float ta, float tb,
                      const struct bc_svo_cast_params *cp,
                      struct bc_svo_hit *hit, float *t_out, bool *settled)
{
	struct ray_field rf = {c->s, m,  c->idx, 0,   NULL,  o,
	                       d,    cp, true,   hit, false, {0}};
	struct lane_step ls = {ta, 0.0f, tb, band_at(cp, tb), 0};
	rf.nlist = decode(m, c->idx);
	if (!afford(cp, hit, 1)) {
		return false;
	}
	ls.g = field_at(&rf, ta);
	if (ls.g <= 0.0f) {
		*t_out = ta;
		return true;
	}
	for (;;) {
		float q;
		if (!step_next(cp, &ls, &q)) {
			return leaf_root(c, m, o, d, ls.t, tb, cp, hit, t_out);
		}
		if (!afford(cp, hit, 1)) {
			return false;
		}
		float gq = field_at(&rf, q);
		if (gq <= 0.0f) {
			*t_out = step_hit(&rf, &ls, q, gq, settled);
			return !hit->ran_out;
		}
		if (!step_on(&ls, q, gq)) {
			return false;
		}
	}
}

/* The ray passes a surface by without crossing it: the field along it has
 * a minimum in [a, b] (the value at a, va > 0, and at b are above the
 * samples inside). Brent's method narrows the bracket to the refinement
 * tolerance, so a silhouette's depth is the closest approach: a parabola
 * through the three best samples where it falls well inside the bracket
 * (near a smooth minimum that converges in a few samples where golden
 * section search took 16), a golden section step where it does not. A
 * negative sample on the way is a crossing after all and is refined.
 * Inside the hit band the octree's field is the exact field (a variant
 * keeps the sign of f - c for every level c of the band, hence the value
 * of f wherever it lies in the band), so the minimum found is the true
 * field's. */
static float closest(struct ray_field *rf, float a, float va, float b)
{
	const float cg = 0.381966f; /* 2 - the golden ratio */
	const float tol = rf->cp->refine_tol;
	/* x the best sample, w the second best, v the one before w; d the
	 * last step, e the one before it. */
	float x = a + cg * (b - a), fx, w, fw, v, fv, d = 0.0f, e = 0.0f;
	if (!afford(rf->cp, rf->hit, 1)) {
		return a;
	}
	fx = field_at(rf, x);
	w = x;
	fw = fx;
	v = x;
	fv = fx;
	if (fx <= 0.0f) {
		return refine(rf, a, va, x, fx);
	}
	for (int i = 0; i < CAST_MAX_REFINE && b - a > tol; i++) {
		float m = 0.5f * (a + b), u, fu;
		bool golden = true;
		if (fabsf(e) > tol) {
			float r = (x - w) * (fx - fv), q = (x - v) * (fx - fw);
			float p = (x - v) * q - (x - w) * r, last = e;
			q = 2.0f * (q - r);
			p = q > 0.0f ? -p : p;
			q = fabsf(q);
			e = d;
			/* The parabola's vertex, if it is inside the bracket
			 * and the step is under half the one before last. */
			if (fabsf(p) < fabsf(0.5f * q * last) &&
			    p > q * (a - x) && p < q * (b - x)) {
				d = p / q;
				golden = false;
				if (x + d - a < 2.0f * tol ||
				    b - (x + d) < 2.0f * tol) {
					d = x < m ? tol : -tol;
				}
			}
		}
		if (golden) {
			e = (x >= m ? a : b) - x;
			d = cg * e;
		}
		u = fabsf(d) >= tol ? x + d : x + (d > 0.0f ? tol : -tol);
		if (!(u > a && u < b) || u == x) {
			break; /* float resolution */
		}
		if (!afford(rf->cp, rf->hit, 1)) {
			return x;
		}
		fu = field_at(rf, u);
		if (fu <= 0.0f) {
			return refine(rf, a, va, u, fu);
		}
		if (fu <= fx) {
			if (u >= x) {
				a = x;
				va = fx;
			} else {
				b = x;
			}
			v = w;
			fv = fw;
			w = x;
			fw = fx;
			x = u;
			fx = fu;
		} else {
			if (u < x) {
				a = u;
				va = fu;
			} else {
				b = u;
			}
			if (fu <= fw || w == x) {
				v = w;
				fv = fw;
				w = u;
				fw = fu;
			} else if (fu <= fv || v == x || v == w) {
				v = u;
				fv = fu;
			}
		}
	}
	return x;
}

/* The ray entered the hit band at th (the caster's bracketing finds the
 * band's entry). The surface it hit is where the field first crosses zero
 * while it stays in the band, or, where the ray only grazes the surface,
 * its closest approach: the smallest field along the stretch of the ray
 * inside the band. The march follows the field's slope (a secant
 * prediction of its zero, overshot by half, as the sphere tracer's
 * refinement in render/cpu/trace.c does) while it descends, and walks a
 * band at a time where it does not; a sample below zero is a crossing and
 * is refined to it; a sample above the band ends the stretch, and
 * closest() then narrows the smallest sample's bracket. Probes go at
 * most SETTLE_MAX_REACH bands ahead (a ray nearly parallel to a surface
 * predicts its zero far away, and a long probe could jump a dip and the
 * bump after it), the march at most 64 bands deep (beyond that the ray is
 * so oblique that any point of it is as good a depth) and never past tb,
 * the ray's exit from the octree. */
static float settle(struct ray_field *rf, float th, float ta, float tb)
{
	const struct bc_svo_cast_params *cp = rf->cp;
	float band = band_at(cp, th);
	float limit = minf(th + 64.0f * band, tb);
	float t = th, v, tp = th - 0.5f * band, vp = 0.0f;
	float best_t = th, best_v, before, before_v, after = th;
	bool slope = false, after_set = false;
	if (!afford(cp, rf->hit, 1)) {
		return th;
	}
	v = field_at(rf, th);
	if (!(v > 0.0f)) {
		return th; /* at or inside the surface already */
	}
	if (tp >= ta) {
		if (!afford(cp, rf->hit, 1)) {
			return th;
		}
		vp = field_at(rf, tp);
		slope = vp > v;
	}
	best_v = v;
	before = slope ? tp : th;
	before_v = slope ? vp : v;
	for (int i = 0; i < SETTLE_MAX_STEPS; i++) {
		float bt = band_at(cp, t), reach, probe, vq;
		if (slope && t > tp && vp > v) {
			reach = 1.5f * v * (t - tp) / (vp - v);
		} else {
			reach = bt; /* level or rising: walk on */
		}
		reach = minf(maxf(reach, cp->min_step), SETTLE_MAX_REACH * bt);
		probe = minf(t + reach, limit);
		if (!(probe > t)) {
			break; /* the march's end */
		}
		if (!afford(cp, rf->hit, 1)) {
			return th;
		}
		vq = field_at(rf, probe);
		if (vq <= 0.0f) {
			return refine(rf, t, v, probe, vq);
		}
		if (!after_set && t == best_t) {
			after = probe;
			after_set = true;
		}
		if (vq < best_v) {
			before = t;
			before_v = v;
			best_t = probe;
			best_v = vq;
			after_set = false;
		}
		tp = t;
		vp = v;
		t = probe;
		v = vq;
		slope = true;
		if (vq > band_at(cp, probe)) {
			break; /* out of the band: the ray grazed */
		}
	}
	if (!after_set) {
		after = minf(best_t + band_at(cp, best_t), tb);
	}
	if (!(after > before)) {
		return best_t;
	}
	return closest(rf, before, before_v, after);
}

/* The node's box halves: octant oct (bit i set: the upper half on axis
 * i) of the box lo..hi whose mid planes are mid. */
static inline void child_box(const float lo[3], const float hi[3],
                             const float mid[3], uint32_t oct, float clo[3],
                             float chi[3])
{
	for (int i = 0; i < 3; i++) {
		bool upper = (oct >> i) & 1u;
		clo[i] = upper ? mid[i] : lo[i];
		chi[i] = upper ? hi[i] : mid[i];
	}
}

/* Lane l's bit in a packet's masks. Loops that build a mask take it from
 * this table rather than shifting by l: they then vectorize. */
_Static_assert(BC_SVO_PACKET == 8, "lane_bit holds eight lanes");
static const uint32_t lane_bit[BC_SVO_PACKET] = {1u,  2u,  4u,  8u,
                                                 16u, 32u, 64u, 128u};

/*
 * A ray's way through a node's children. On axis i the ray crosses the
 * node's mid plane at tc = (mid - o) / d (a product by the reciprocal
 * inv: only the order of the crossings matters) and spends the t of
 * [lo0, lo1) in the lower half and of [up0, up1) in the upper: (-inf, tc)
 * and (tc, inf), the other way round where it runs down the axis. A ray
 * parallel to the plane (inv 0) is in one half all along: tc is -inf on
 * the plane or above it, +inf below. A child's stretch of the ray's
 * segment [ta, tb] is then [max(ta, its halves' starts), min(tb, their
 * ends)), empty unless the start is below the end: the segment cut where
 * it crosses the mid planes, each piece in the child it lies in, with no
 * zero-length pieces. Only max, min and selects: the same floats whether a
 * ray is walked alone or in a packet, and branch-free over a packet's
 * lanes (the lane loops vectorize).
 */
enum { HALF_LO0, HALF_LO1, HALF_UP0, HALF_UP1 };

/* h for a ray whose reciprocal on the axis is inv; dm = mid - o, and par
 * the crossing of a ray parallel to the plane. inv 0 adds par to a zero
 * product, any other inv adds zero: arithmetic rather than a select, so
 * the product is not moved into a branch (where, as it might trap, the
 * compiler would not vectorize the lanes' loop). */
static inline void halves(float dm, float par, float inv, float h[4])
{
	float tc = dm * inv + (inv == 0.0f ? par : 0.0f);
	bool down = inv < 0.0f;
	h[HALF_LO0] = down ? tc : -INFINITY;
	h[HALF_LO1] = down ? INFINITY : tc;
	h[HALF_UP0] = down ? -INFINITY : tc;
	h[HALF_UP1] = down ? tc : INFINITY;
}

static inline float parallel_crossing(float mid, float o)
{
	return o >= mid ? -INFINITY : INFINITY;
}

/* halves for the lanes of a packet: h[k][l] is lane l's h[k]. */
static inline void halves_lanes(float mid, float o, const float *inv,
                                float (*h)[BC_SVO_PACKET])
{
	float dm = mid - o, par = parallel_crossing(mid, o);
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		float hl[4];
		halves(dm, par, inv[l], hl);
		for (int k = 0; k < 4; k++) {
			h[k][l] = hl[k];
		}
	}
}

/* Child oc's stretch [*a, *b) of the segment [ta, tb]; h[i] the ray's
 * halves on axis i. True where it is not empty. */
static inline bool child_span(uint32_t oc, const float h[3][4], float ta,
                              float tb, float *a, float *b)
{
	for (int i = 0; i < 3; i++) {
		bool up = (oc >> i) & 1u;
		ta = maxf(ta, h[i][up ? HALF_UP0 : HALF_LO0]);
		tb = minf(tb, h[i][up ? HALF_UP1 : HALF_LO1]);
	}
	*a = ta;
	*b = tb;
	return ta < tb;
}

/* child_span for the lanes of a packet (h[i][k][l]: lane l's halves):
 * child oc's stretches [a[l], b[l]) of the segments [ta[l], tb[l]), the
 * same floats lane by lane. Returns the lanes whose stretch is not
 * empty. */
static inline uint32_t child_spans(uint32_t oc,
                                   const float (*h)[4][BC_SVO_PACKET],
                                   const float *ta, const float *tb, float *a,
                                   float *b)
{
	const float *s[3], *e[3];
	uint32_t m = 0, on[BC_SVO_PACKET];
	for (int i = 0; i < 3; i++) {
		bool up = (oc >> i) & 1u;
		s[i] = h[i][up ? HALF_UP0 : HALF_LO0];
		e[i] = h[i][up ? HALF_UP1 : HALF_LO1];
	}
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		float x = maxf(maxf(maxf(ta[l], s[0][l]), s[1][l]), s[2][l]);
		float y = minf(minf(minf(tb[l], e[0][l]), e[1][l]), e[2][l]);
		a[l] = x;
		b[l] = y;
		on[l] = x < y ? lane_bit[l] : 0u;
	}
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		m |= on[l];
	}
	return m;
}

/* 1/d per axis, 0 where the ray runs parallel to the axis's planes (or so
 * nearly that 1/d is not finite). The bits of the axes it runs down. */
static inline uint32_t reciprocal(const float d[3], float inv[3])
{
	uint32_t down = 0;
	for (int i = 0; i < 3; i++) {
		inv[i] = fabsf(d[i]) >= FLT_MIN ? 1.0f / d[i] : 0.0f;
		down |= inv[i] < 0.0f ? 1u << i : 0u;
	}
	return down;
}

/* The ray entered the hit band at th in a leaf whose variant is mask (the
 * full tree's for a full leaf), after leaves of terms active terms at
 * most; [ta, tb] is its segment in the octree. Settles the depth and takes
 * the id and the normals' variant. Returns false when the ray ran out of
 * its bound on the way (hit->ran_out). (A packet's settled hits whose id
 * it took already are finished in place: bc_svo_cast_packet.) */
static bool finish_hit(struct bc_svo_caster *c, const float o[3],
                       const float d[3], float ta, float tb, float th,
                       bool settled, uint32_t terms, struct bc_svo_cmask mask,
                       const struct bc_svo_cast_params *cp,
                       struct bc_svo_hit *hit)
{
	const struct bc_svo *s = c->s;
	hit->leaf_terms = terms;
	if (!settled) {
		/* The leaf phase is over: its scratch list is free. (Built
		 * only here: zeroing the struct for every hit was 40 % of
		 * this function's time.) */
		struct ray_field rf = {s, NULL, NULL,  0,   c->idx, o,
		                       d, cp,   false, hit, false,  {0}};
		th = settle(&rf, th, ta, tb);
	}
	if (hit->ran_out || !afford(cp, hit, 1)) {
		return false;
	}
	hit->t = th;
	hit->mask = mask;
	{
		float p[3] = {o[0] + th * d[0], o[1] + th * d[1],
		              o[2] + th * d[2]};
		struct bc_svo_leaf_ref ref;
		/* The id from the variant of the leaf the point lies in, when
		 * that leaf holds surface; else from the variant of the hit. */
		if (bc_svo_locate(s, p, &ref) &&
		    ref.state == BC_SVO_STATE_ACTIVE) {
			hit->mask = ref.mask;
		}
		(void)bc_svo_cmask_eval_id(s->rpn, hit->mask, p, &hit->prim);
		hit->evals++;
	}
	return true;
}

struct ent {
	uint32_t node;
	float lo[3], hi[3];
	float ta, tb;
};

bool bc_svo_cast(struct bc_svo_caster *c, const float o[3], const float d[3],
                 float t0, float t1, const struct bc_svo_cast_params *cp,
                 struct bc_svo_hit *hit)
{
	const struct bc_svo *s = c->s;
	/* Each level pushes at most four children (a ray crosses at most four
	 * octants of a node) and pops one. */
	struct ent st[4 * (BC_SVO_MAX_DEPTH + 1) + 4];
	struct bc_svo_cmask mask = {NULL, 0};
	uint32_t sp = 0, terms = 0;
	float th = 0.0f, ta = t0, tb = t1, inv[3];
	bool found = false, settled = false;
	uint32_t down = reciprocal(d, inv);
	memset(hit, 0, sizeof(*hit));
	hit->prim = BC_NONE;
	if (!bc_ray_box_clip(s->lo, s->hi, o, d, &ta, &tb)) {
		return false;
	}
	st[0].node = 0;
	memcpy(st[0].lo, s->lo, sizeof(st[0].lo));
	memcpy(st[0].hi, s->hi, sizeof(st[0].hi));
	st[0].ta = ta;
	st[0].tb = tb;
	sp = 1;
	while (sp && !found) {
		struct ent e = st[--sp];
		const struct bc__svo_node *nd = &s->nodes[e.node];
		float mid[3], h[3][4];
		if (!nd->child) {
			const struct bc__svo_leaf *lf = &s->leaves[nd->leaf];
			if (lf->state == BC_SVO_STATE_FULL) {
				mask = s->full_c;
				th = e.ta;
				found = true;
			} else if (lf->state == BC_SVO_STATE_ACTIVE) {
				mask.pairs = s->pool.v + 2u * (size_t)lf->off;
				mask.nwords = lf->npairs;
				terms = lf->nterms;
				found =
				    lf->flags & BC__SVO_LEAF_LIP1
				        ? leaf_step(c, &mask, o, d, e.ta, e.tb,
				                    cp, hit, &th, &settled)
				        : leaf_root(c, &mask, o, d, e.ta, e.tb,
				                    cp, hit, &th);
				if (hit->ran_out) {
					return false;
				}
			}
			continue;
		}
		for (int i = 0; i < 3; i++) {
			mid[i] = 0.5f * (e.lo[i] + e.hi[i]);
			halves(mid[i] - o[i], parallel_crossing(mid[i], o[i]),
			       inv[i], h[i]);
		}
		/* Children front to back are those of octant k ^ down for k
		 * up from 0: pushed the other way round, the nearest is popped
		 * first. */
		for (uint32_t k = 8; k-- > 0;) {
			uint32_t oc = k ^ down;
			struct ent *ch = &st[sp];
			if (child_span(oc, (const float(*)[4])h, e.ta, e.tb,
			               &ch->ta, &ch->tb)) {
				child_box(e.lo, e.hi, mid, oc, ch->lo, ch->hi);
				ch->node = nd->child + oc;
				sp++;
			}
		}
	}
	if (!found) {
		return false;
	}
	return finish_hit(c, o, d, ta, tb, th, settled, terms, mask, cp, hit);
}

/* ---- Ray packets -------------------------------------------------------- */

/* A node on a packet's walk: the rays (lanes) whose segments cross it, and
 * each one's segment. */
struct pent {
	uint32_t node, lanes;
	float lo[3], hi[3];
	float ta[BC_SVO_PACKET], tb[BC_SVO_PACKET];
};

/* The leaf's variant (its n terms decoded in c->pidx) at o + t[l] d[l]
 * for the lanes of `lanes` (not zero), in one call (d[l]: the packet's
 * directions, c->pd); the other lanes' values are the variant's at o,
 * whatever their t (0 where one or two lanes are live). With prim, also
 * the primitive deciding each lane's value. */
static void lanes_at(const struct bc_svo_caster *c, uint32_t n,
                     const float o[3], const float *t, uint32_t lanes, float *v,
                     uint32_t *prim)
{
	float px[BC__SVO_LANES], py[BC__SVO_LANES], pz[BC__SVO_LANES];
	uint32_t rest = lanes & (lanes - 1u); /* all but the lowest */
	if (!prim && !(rest & (rest - 1u))) {
		/* One or two samples (a seventh of the rounds): the scalar
		 * evaluator, whose values are the lanes' bit for bit, costs a
		 * third of an eight-lane round each. */
		for (uint32_t l = 0; l < BC__SVO_LANES; l++) {
			v[l] = 0.0f;
		}
		for (uint32_t b = lanes; b; b &= b - 1u) {
			uint32_t l = bc__svo_lowest(b);
			float p[3] = {o[0] + t[l] * c->pd[0][l],
			              o[1] + t[l] * c->pd[1][l],
			              o[2] + t[l] * c->pd[2][l]};
			v[l] = bc__svo_list_eval(c->s->rpn, c->pidx, n, p);
		}
		return;
	}
	for (uint32_t l = 0; l < BC__SVO_LANES; l++) {
		/* A select, not a gather: the loop vectorizes. */
		float tl = lanes & lane_bit[l] ? t[l] : 0.0f;
		px[l] = o[0] + tl * c->pd[0][l];
		py[l] = o[1] + tl * c->pd[1][l];
		pz[l] = o[2] + tl * c->pd[2][l];
	}
	if (prim) {
		bc__svo_list_eval_lanes_id(c->s->rpn, c->pidx, n, px, py, pz,
		                           lanes, v, prim);
	} else {
		bc__svo_list_eval_lanes(c->s->rpn, c->pidx, n, px, py, pz,
		                        lanes, v);
	}
}

/* step_hit for the lanes of `lanes` at once (their hit plans h[l]): the
 * probes in one evaluation of the leaf's variant, then every round of the
 * refinements in one. Each lane takes the samples step_hit would. */
static void packet_hits(struct bc_svo_caster *c, uint32_t n, const float o[3],
                        uint32_t lanes, const struct bc_svo_cast_params *cp,
                        struct hit_plan *h, struct bc_svo_hit *hits, float *th,
                        bool *settled)
{
	float m[BC_SVO_PACKET] = {0}, v[BC__SVO_LANES];
	uint32_t want, live = lanes;
	for (;;) {
		want = 0;
		for (uint32_t b = lanes; b; b &= b - 1u) {
			uint32_t l = bc__svo_lowest(b);
			if (h[l].probe && !afford(cp, &hits[l], 1)) {
				h[l].probe = false;
				live &= ~(1u << l);
			}
			if (h[l].probe) {
				m[l] = h[l].q2;
				want |= 1u << l;
			}
		}
		if (!want) {
			break;
		}
		lanes_at(c, n, o, m, want, v, NULL);
		for (uint32_t b = want; b; b &= b - 1u) {
			uint32_t l = bc__svo_lowest(b);
			hits[l].evals++;
			hit_probed(cp, &h[l], v[l]);
		}
	}
	while (live) {
		want = 0;
		for (uint32_t b = live; b; b &= b - 1u) {
			uint32_t l = bc__svo_lowest(b);
			if (ill_next(&h[l].ill, cp->refine_tol, &m[l]) &&
			    afford(cp, &hits[l], 1)) {
				want |= 1u << l;
			}
		}
		live = want;
		if (!want) {
			break;
		}
		lanes_at(c, n, o, m, want, v, NULL);
		for (uint32_t b = want; b; b &= b - 1u) {
			uint32_t l = bc__svo_lowest(b);
			hits[l].evals++;
			ill_take(&h[l].ill, m[l],
			         h[l].banded ? v[l] - band_at(cp, m[l]) : v[l]);
		}
	}
	for (uint32_t b = lanes; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		th[l] = ill_root(&h[l].ill);
		settled[l] = h[l].settled;
	}
}

/*
 * Whether no lane of `lanes` can hit in this leaf: the variant's range
 * (the octree's arithmetic) over the box of all their segments in it lies
 * above the hit band at the farthest of their exits. The samples a ray
 * takes, o + t d for t in its segment, lie between its ends' points (the
 * float expression is monotone in t), so the box holds them all. Stepping
 * covers a leaf by the field's value at a time: where a leaf is long and
 * its surface a few pixels off the rays, that took about five rounds of
 * samples to learn what one range evaluation of the packet's beam tells
 * (fig18: 62 % of the rounds, in 99 % of the leaves crossed without a
 * hit). Every lane counts the range evaluation (the caller made sure
 * each can afford it).
 */
static bool beam_clear(struct bc_svo_caster *c, uint32_t n, const float o[3],
                       const float (*d)[3], const struct pent *e,
                       uint32_t lanes, const struct bc_svo_cast_params *cp,
                       struct bc_svo_hit *hits)
{
	struct bc_svo_region rg;
	struct bc_svo_ivl v;
	float cmax = 0.0f;
	memset(&rg, 0, sizeof(rg));
	for (int i = 0; i < 3; i++) {
		rg.lo[i] = INFINITY;
		rg.hi[i] = -INFINITY;
	}
	for (uint32_t b = lanes; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		for (int i = 0; i < 3; i++) {
			float p0 = o[i] + e->ta[l] * d[l][i];
			float p1 = o[i] + e->tb[l] * d[l][i];
			rg.lo[i] = minf(rg.lo[i], minf(p0, p1));
			rg.hi[i] = maxf(rg.hi[i], maxf(p0, p1));
		}
		cmax = maxf(cmax, band_at(cp, e->tb[l]));
		hits[l].range_evals++;
	}
	v = bc_svo_range(c->g, c->pidx, n, &rg);
	return v.lo > (double)cmax;
}

/* The ids of the lanes of `lanes` whose hit is settled and lies in this
 * leaf (e's box, the same floats bc_svo_locate computes): finish_hit
 * would take each from this leaf's variant at that point; here one
 * evaluation of the variant with ids takes them all. Returns those lanes
 * (pid set). */
static uint32_t packet_ids(struct bc_svo_caster *c, uint32_t n,
                           const float o[3], const float (*d)[3],
                           const struct pent *e, uint32_t lanes,
                           const float *th, const bool *settled, uint32_t *pid,
                           const struct bc_svo_cast_params *cp,
                           struct bc_svo_hit *hits)
{
	float v[BC__SVO_LANES];
	uint32_t prim[BC__SVO_LANES], in = 0;
	for (uint32_t b = lanes; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		float p[3] = {o[0] + th[l] * d[l][0], o[1] + th[l] * d[l][1],
		              o[2] + th[l] * d[l][2]};
		/* The id costs the evaluation finish_hit would spend. */
		if (settled[l] && !hits[l].ran_out && in_box(e->lo, e->hi, p) &&
		    afford(cp, &hits[l], 1)) {
			in |= 1u << l;
		}
	}
	if (!in) {
		return 0;
	}
	lanes_at(c, n, o, th, in, v, prim);
	for (uint32_t b = in; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		pid[l] = prim[l];
	}
	return in;
}

/* The lanes of `lanes` that may spend n more evaluations within cp's
 * bound; the others have run out (afford). */
static uint32_t afford_lanes(const struct bc_svo_cast_params *cp,
                             struct bc_svo_hit *hits, uint32_t lanes,
                             uint32_t n)
{
	if (!cp->max_evals) {
		return lanes;
	}
	for (uint32_t b = lanes; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		if (!afford(cp, &hits[l], n)) {
			lanes &= ~(1u << l);
		}
	}
	return lanes;
}

/* The lanes of `lanes` that ran out of their bound. */
static uint32_t ran_out_lanes(const struct bc_svo_hit *hits, uint32_t lanes)
{
	uint32_t out = 0;
	for (uint32_t b = lanes; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		out |= hits[l].ran_out ? 1u << l : 0u;
	}
	return out;
}

/* leaf_step for the lanes of `lanes` at once: every lane takes the samples
 * leaf_step would take (step_next, step_hit, step_on), and each round of
 * samples is one evaluation of the variant (mask m, its n terms decoded in
 * c->pidx) over the lanes; a lane that cannot afford its next sample
 * drops out (ran_out). Returns the lanes that hit in this leaf (th,
 * settled set), some of which may have run out while refining. */
static uint32_t packet_step(struct bc_svo_caster *c,
                            const struct bc_svo_cmask *m, uint32_t n,
                            const float o[3], const float (*d)[3],
                            const struct pent *e, uint32_t lanes,
                            const struct bc_svo_cast_params *cp,
                            struct bc_svo_hit *hits, float *th, bool *settled,
                            uint32_t *pid, uint32_t *idset)
{
	/* The lanes' struct lane_step by field: every round's decisions
	 * (step_next, the sample's test, step_on) run over all eight lanes
	 * as selects, in loops the compiler vectorizes; the lanes outside
	 * `lanes` hold an empty segment and are masked off. */
	float t[BC_SVO_PACKET], g[BC_SVO_PACKET], tb[BC_SVO_PACKET];
	float cmax[BC_SVO_PACKET], q[BC_SVO_PACKET], gq[BC_SVO_PACKET];
	float v[BC__SVO_LANES];
	int steps[BC_SVO_PACKET];
	uint32_t bits[BC_SVO_PACKET], more[BC_SVO_PACKET];
	struct hit_plan plan[BC_SVO_PACKET];
	uint32_t found = 0, going = 0, hit = 0;
	lanes = afford_lanes(cp, hits, lanes, 1);
	if (!lanes) {
		return 0;
	}
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		bool in = lanes & lane_bit[l];
		t[l] = in ? e->ta[l] : 0.0f;
		tb[l] = in ? e->tb[l] : 0.0f;
		cmax[l] = band_at(cp, tb[l]);
		steps[l] = 0;
		q[l] = t[l];
	}
	lanes_at(c, n, o, q, lanes, v, NULL);
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		g[l] = v[l] - band_at(cp, q[l]);
		bits[l] = g[l] <= 0.0f ? lane_bit[l] : 0u;
	}
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		found |= bits[l];
	}
	found &= lanes;
	going = lanes & ~found;
	for (uint32_t b = lanes; b; b &= b - 1u) {
		hits[bc__svo_lowest(b)].evals++;
	}
	for (uint32_t b = found; b; b &= b - 1u) {
		th[bc__svo_lowest(b)] = t[bc__svo_lowest(b)];
	}
	while (going) {
		uint32_t want = 0, stop, on = 0;
		for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
			struct lane_step ls = {t[l], g[l], tb[l], cmax[l],
			                       steps[l]};
			bits[l] = step_next(cp, &ls, &q[l]) ? lane_bit[l] : 0u;
		}
		for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
			want |= bits[l];
		}
		want &= going;
		for (stop = going & ~want; stop; stop &= stop - 1u) {
			uint32_t l = bc__svo_lowest(stop);
			if (leaf_root(c, m, o, d[l], t[l], tb[l], cp, &hits[l],
			              &th[l])) {
				found |= 1u << l;
			}
		}
		want = afford_lanes(cp, hits, want, 1);
		if (!want) {
			break;
		}
		lanes_at(c, n, o, q, want, v, NULL);
		for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
			/* step_on: a sample above the band inside the leaf
			 * is the next step. */
			bool up, go;
			gq[l] = v[l] - band_at(cp, q[l]);
			up = !(gq[l] <= 0.0f);
			go = up & (q[l] < tb[l]) & ((want & lane_bit[l]) != 0u);
			bits[l] = up ? 0u : lane_bit[l];
			more[l] = go ? lane_bit[l] : 0u;
			t[l] = go ? q[l] : t[l];
			g[l] = go ? gq[l] : g[l];
			steps[l] += go;
		}
		going = 0;
		for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
			going |= more[l];
			on |= bits[l];
		}
		on &= want;
		for (uint32_t b = want; b; b &= b - 1u) {
			hits[bc__svo_lowest(b)].evals++;
		}
		/* The lanes that hit (their t, g still the last step's) are
		 * refined with the others that hit here, below. */
		for (uint32_t b = on; b; b &= b - 1u) {
			uint32_t l = bc__svo_lowest(b);
			struct lane_step ls = {t[l], g[l], tb[l], cmax[l],
			                       steps[l]};
			plan[l] = hit_plan(cp, &ls, q[l], gq[l]);
		}
		hit |= on;
	}
	if (hit) {
		packet_hits(c, n, o, hit, cp, plan, hits, th, settled);
		*idset |=
		    packet_ids(c, n, o, d, e, hit, th, settled, pid, cp, hits);
	}
	return found | hit;
}

uint32_t bc_svo_cast_packet(struct bc_svo_caster *c, const float o[3],
                            const float (*d)[3], uint32_t n, float t0, float t1,
                            const struct bc_svo_cast_params *cp,
                            struct bc_svo_hit *hits)
{
	const struct bc_svo *s = c->s;
	/* Each level pops one node and pushes at most its eight children. */
	struct pent st[8 * (BC_SVO_MAX_DEPTH + 1) + 1];
	float ta0[BC_SVO_PACKET], tb0[BC_SVO_PACKET], th[BC_SVO_PACKET] = {0};
	float inv[3][BC_SVO_PACKET];
	bool settled[BC_SVO_PACKET];
	uint32_t pid[BC_SVO_PACKET], idset = 0, down[BC_SVO_PACKET];
	uint32_t terms[BC_SVO_PACKET];
	struct bc_svo_cmask mask[BC_SVO_PACKET];
	uint32_t sp, live = 0, found = 0, alone = 0, hit = 0, sgn = 0, out = 0;
	for (uint32_t l = 0; l < n; l++) {
		memset(&hits[l], 0, sizeof(hits[l]));
		hits[l].prim = BC_NONE;
	}
	if (n > BC_SVO_PACKET) {
		return 0;
	}
	/* Every lane's segment and reciprocal are set, rays or not: the walk
	 * computes all lanes (a lane without a ray has an empty segment). */
	st[0].node = 0;
	memcpy(st[0].lo, s->lo, sizeof(st[0].lo));
	memcpy(st[0].hi, s->hi, sizeof(st[0].hi));
	for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
		float il[3] = {0.0f, 0.0f, 0.0f};
		down[l] = 0;
		st[0].ta[l] = INFINITY;
		st[0].tb[l] = -INFINITY;
		if (l < n) {
			settled[l] = false;
			terms[l] = 0;
			pid[l] = BC_NONE;
			mask[l] = (struct bc_svo_cmask){NULL, 0};
			th[l] = 0.0f;
			ta0[l] = t0;
			tb0[l] = t1;
			down[l] = reciprocal(d[l], il);
			if (bc_ray_box_clip(s->lo, s->hi, o, d[l], &ta0[l],
			                    &tb0[l])) {
				live |= 1u << l;
				sgn |= down[l];
				st[0].ta[l] = ta0[l];
				st[0].tb[l] = tb0[l];
			}
		}
		for (int i = 0; i < 3; i++) {
			inv[i][l] = il[i];
			c->pd[i][l] = l < n ? d[l][i] : 0.0f;
		}
	}
	if (!live) {
		return 0;
	}
	st[0].lanes = live;
	sp = 1;
	while (sp) {
		/* Children are pushed where the entry lies: copy it out. */
		struct pent e = st[--sp];
		const struct bc__svo_node *nd = &s->nodes[e.node];
		uint32_t lanes = e.lanes & ~(found | alone | out);
		float mid[3];
		if (!lanes) {
			continue;
		}
		if (!nd->child) {
			const struct bc__svo_leaf *lf = &s->leaves[nd->leaf];
			struct bc_svo_cmask m = {NULL, 0};
			uint32_t got = 0;
			if (lf->state == BC_SVO_STATE_FULL) {
				m = s->full_c;
				got = lanes;
				for (uint32_t b = lanes; b; b &= b - 1u) {
					th[bc__svo_lowest(b)] =
					    e.ta[bc__svo_lowest(b)];
				}
			} else if (lf->state == BC_SVO_STATE_ACTIVE) {
				m.pairs = s->pool.v + 2u * (size_t)lf->off;
				m.nwords = lf->npairs;
				/* Every way through the leaf starts with an
				 * evaluation, the beam test's or a lane's. */
				lanes = afford_lanes(cp, hits, lanes, 1);
				for (uint32_t b = lanes; b; b &= b - 1u) {
					terms[bc__svo_lowest(b)] = lf->nterms;
				}
				/* The terms, for the beam test and the
				 * packet's steps (leaf_root decodes its own).
				 */
				uint32_t nt = decode(&m, c->pidx);
				/* Where the packet before hit, this one mostly
				 * does too (fig18: three quarters of the beam
				 * tests that failed), and a failed test costs
				 * a range evaluation for nothing. */
				if (!lanes) {
					/* Every one of them ran out. */
				} else if (nd->leaf != c->hit_leaf &&
				           beam_clear(c, nt, o, d, &e, lanes,
				                      cp, hits)) {
					/* No hit here for any of them. */
				} else if (lf->flags & BC__SVO_LEAF_LIP1) {
					got = packet_step(c, &m, nt, o, d, &e,
					                  lanes, cp, hits, th,
					                  settled, pid, &idset);
				} else {
					for (uint32_t b = lanes; b;
					     b &= b - 1u) {
						uint32_t l = bc__svo_lowest(b);
						got |= leaf_root(
						           c, &m, o, d[l],
						           e.ta[l], e.tb[l], cp,
						           &hits[l], &th[l])
						           ? 1u << l
						           : 0u;
					}
				}
			}
			/* Lanes that ran out here are done, hit or not. */
			out |= ran_out_lanes(hits, e.lanes & ~(found | alone));
			got &= ~out;
			if (got) {
				c->hit_leaf = nd->leaf;
			}
			for (uint32_t b = got; b; b &= b - 1u) {
				mask[bc__svo_lowest(b)] = m;
			}
			found |= got;
			continue;
		}
		for (int i = 0; i < 3; i++) {
			mid[i] = 0.5f * (e.lo[i] + e.hi[i]);
		}
		/* Children are visited in the order of their octant's bits
		 * flipped where the packet's rays run down an axis: front to
		 * back for every ray whose crossings follow that order (a ray
		 * running up an axis the others run down crosses its mid
		 * plane the other way). A ray whose crossings do not is cast
		 * on its own afterwards. */
		{
			float h[3][4][BC_SVO_PACKET];
			for (int i = 0; i < 3; i++) {
				mid[i] = 0.5f * (e.lo[i] + e.hi[i]);
				halves_lanes(mid[i], o[i], inv[i], h[i]);
			}
			for (uint32_t b = lanes; b; b &= b - 1u) {
				uint32_t l = bc__svo_lowest(b);
				for (uint32_t w = down[l] ^ sgn; w;
				     w &= w - 1u) {
					uint32_t i = bc__svo_lowest(w);
					float tc = h[i][down[l] >> i & 1u
					                    ? HALF_LO0
					                    : HALF_LO1][l];
					if (tc > e.ta[l] && tc < e.tb[l]) {
						alone |= 1u << l;
					}
				}
			}
			lanes &= ~alone;
			for (uint32_t k = 8; k-- > 0;) {
				uint32_t oc = k ^ sgn;
				struct pent *ch = &st[sp];
				ch->lanes =
				    lanes & child_spans(oc, h, e.ta, e.tb,
				                        ch->ta, ch->tb);
				if (ch->lanes) {
					ch->node = nd->child + oc;
					child_box(e.lo, e.hi, mid, oc, ch->lo,
					          ch->hi);
					sp++;
				}
			}
		}
	}
	for (uint32_t b = found & ~alone; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		if ((idset >> l) & 1u) {
			/* The packet took the id of this settled hit: the
			 * point lies in the leaf of the hit (whose variant
			 * mask is), where bc_svo_locate would have found it
			 * (packet_ids). What finish_hit would do, without its
			 * call (its frame is sized for settling). */
			hits[l].leaf_terms = terms[l];
			hits[l].t = th[l];
			hits[l].mask = mask[l];
			hits[l].prim = pid[l];
			hits[l].evals++;
		} else if (!finish_hit(c, o, d[l], ta0[l], tb0[l], th[l],
		                       settled[l], terms[l], mask[l], cp,
		                       &hits[l])) {
			continue; /* ran out of its bound */
		}
		hit |= 1u << l;
	}
	for (uint32_t b = alone; b; b &= b - 1u) {
		uint32_t l = bc__svo_lowest(b);
		if (bc_svo_cast(c, o, d[l], t0, t1, cp, &hits[l])) {
			hit |= 1u << l;
		}
	}
	c->packed += (uint64_t)bc__svo_popcount(live & ~alone);
	c->alone += (uint64_t)bc__svo_popcount(alone);
	return hit;
}

void bc_svo_caster_forget(struct bc_svo_caster *c)
{
	c->hit_leaf = BC_NONE;
}

void bc_svo_caster_counts(const struct bc_svo_caster *c, uint64_t *packed,
                          uint64_t *alone)
{
	*packed = c->packed;
	*alone = c->alone;
}
