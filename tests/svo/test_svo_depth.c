/*
 * The `svo` backend's depth against the CPU `tiled` renderer's at 64x64 on
 * generated scenes, each seen from its own camera and from a grazing one
 * (the eye a few degrees above the scene's main plane, so that many rays
 * run along surfaces). Both renderers refine every hit to the field's
 * crossing, or to the ray's closest approach on a silhouette, so over the
 * pixels both hit the depths agree: the 95th percentile of the difference
 * is at most 1e-3 scene units, and no pixel is off by more than a few
 * pixel footprints unless the two renderers saw different surfaces (a ray
 * grazing one solid and hitting another behind it), which stays rare.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "blobcast/svo.h"
#include "blobcast/vec.h"
#include "svo_util.h"
#include "test.h"

#define W 64
#define H 64

static int cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;
	return (x > y) - (x < y);
}

/* The oracle: the hit criterion of both renderers (the field below
 * 1.45 max(half a pixel footprint, the minimal step) at t) evaluated on the
 * full tree with no sparse structure, no relaxed steps and no range
 * arithmetic. Conservative steps to the band's entry (the field falls at
 * most by the Lipschitz bound per unit), then samples every
 * 1/8 band: the first sign change is bisected (a crossing); where the field
 * leaves the band again first, the ray grazed the surface and the hit is
 * the smallest sample, narrowed by golden section search (a silhouette's
 * closest approach). Returns +inf on a miss; *crossing says which. */
struct oracle {
	const struct bc_lin *l;
	float pix, min_step, tol;
	const float *o, *d;
};

static float of(const struct oracle *q, float t)
{
	float p[3] = {q->o[0] + t * q->d[0], q->o[1] + t * q->d[1],
	              q->o[2] + t * q->d[2]};
	return bc_eval_full(q->l, p);
}

static float oband(const struct oracle *q, float t)
{
	return BC_SVO_HIT_LIPSCHITZ *
	       fmaxf(BC_SVO_HIT_FOOTPRINT * q->pix * t, q->min_step);
}

static float oracle_depth(const struct oracle *q, bool *crossing)
{
	float t0 = 0.0f, t1 = INFINITY, t, f;
	*crossing = false;
	for (int i = 0; i < 3; i++) {
		float inv = 1.0f / q->d[i];
		float ta = (q->l->lo[i] - q->o[i]) * inv,
		      tb = (q->l->hi[i] - q->o[i]) * inv;
		t0 = fmaxf(t0, fminf(ta, tb));
		t1 = fminf(t1, fmaxf(ta, tb));
	}
	if (!(t0 <= t1)) {
		return INFINITY;
	}
	t = t0;
	f = of(q, t);
	if (f < 0.0f) {
		*crossing = true;
		return t0;
	}
	while (f >= oband(q, t)) {
		/* The field falls at most 1.45 per unit: no point before
		 * t + (f - band) / 1.45 is in the band. */
		t += fmaxf((f - oband(q, t)) / BC_SVO_HIT_LIPSCHITZ,
		           oband(q, t) / 16.0f);
		if (t > t1) {
			return INFINITY;
		}
		f = of(q, t);
	}
	{
		float band = oband(q, t), h = band / 8.0f;
		float tp = fmaxf(t - band, t0), fp = of(q, tp);
		float best = fp, tbest = tp;
		for (int k = 0; k < 8 * 64 + 8; k++) {
			float tn = tp + h, fn = of(q, tn);
			if (fn < 0.0f) {
				float a = tp, b = tn;
				for (int it = 0;
				     it < 60 && b - a > 0.1f * q->tol; it++) {
					float m = 0.5f * (a + b);
					if (of(q, m) < 0.0f) {
						b = m;
					} else {
						a = m;
					}
				}
				*crossing = true;
				return 0.5f * (a + b);
			}
			if (fn < best) {
				best = fn;
				tbest = tn;
			}
			if (tn > t && fn >= oband(q, tn)) {
				break; /* left the band: grazed */
			}
			tp = tn;
			fp = fn;
		}
		{
			float a = tbest - h, b = tbest + h;
			const float g = 0.618034f;
			for (int it = 0; it < 60 && b - a > 0.1f * q->tol;
			     it++) {
				float c = b - g * (b - a), e = a + g * (b - a);
				if (of(q, c) < of(q, e)) {
					b = e;
				} else {
					a = c;
				}
			}
			return 0.5f * (a + b);
		}
	}
}

struct dstat {
	uint32_t n, far; /* far: beyond 0.05 scene units */
	float p50, p95, max;
};

static void dstat_of(float *v, uint32_t n, struct dstat *s)
{
	memset(s, 0, sizeof(*s));
	s->n = n;
	for (uint32_t i = 0; i < n; i++) {
		s->far += v[i] > 0.05f;
	}
	if (n) {
		qsort(v, n, sizeof(*v), cmp_float);
		s->p50 = v[n / 2];
		s->p95 = v[(uint32_t)(0.95 * (double)(n - 1))];
		s->max = v[n - 1];
	}
}

struct depth_stats {
	uint32_t mask_diff;
	struct dstat svo_tiled, svo_tiled_cross, svo_oracle, tiled_oracle;
};

static int depth_compare(const struct bc_tree *t, const struct bc_camera *cam,
                         enum bc_range_arith arith, struct depth_stats *ds)
{
	struct bc_frame a, b;
	struct bc_render_opts ot = {.threads = 2};
	struct bc_render_opts os = {.threads = 2, .svo_range = arith};
	struct bc_errinfo ei = {0};
	struct bc_view_rays vr;
	const struct bc_lin *l = bc_tree_lin(t);
	float *st = NULL, *stc, *so, *to;
	uint32_t nst = 0, nstc = 0, nso = 0, nto = 0;
	int rc;
	memset(ds, 0, sizeof(*ds));
	if (bc_frame_init(&a, W, H) || bc_frame_init(&b, W, H)) {
		return BC_ENOMEM;
	}
	st = calloc(4 * W * H, sizeof(*st));
	rc = st ? 0 : BC_ENOMEM;
	stc = st + W * H;
	so = stc + W * H;
	to = so + W * H;
	if (rc == 0) {
		rc = bc_render_once(BC_BACKEND_TILED, &ot, t, cam, &a, NULL,
		                    &ei);
	}
	if (rc == 0) {
		rc = bc_render_once(BC_BACKEND_SVO, &os, t, cam, &b, NULL, &ei);
	}
	if (rc) {
		fprintf(stderr, "  render: %s\n", ei.msg);
	}
	bc_view_rays_init(&vr, cam, W, H);
	for (uint32_t i = 0; rc == 0 && i < W * H; i++) {
		bool ha = isfinite(a.depth[i]), hb = isfinite(b.depth[i]);
		bool cross;
		float d[3], z;
		struct oracle q = {l,
		                   2.0f * vr.tan_half_y / (float)H,
		                   BC_SVO_MIN_STEP_REL * l->size,
		                   BC_SVO_REFINE_REL * l->size,
		                   vr.eye,
		                   d};
		bc_view_rays_dir(&vr, (float)(i % W) + 0.5f,
		                 (float)(i / W) + 0.5f, d);
		z = oracle_depth(&q, &cross);
		ds->mask_diff += ha != hb;
		if (ha && hb) {
			float e = fabsf(a.depth[i] - b.depth[i]);
			st[nst++] = e;
			if (cross) {
				stc[nstc++] = e;
			}
		}
		if (hb && isfinite(z)) {
			so[nso++] = fabsf(b.depth[i] - z);
		}
		if (ha && isfinite(z)) {
			to[nto++] = fabsf(a.depth[i] - z);
		}
	}
	dstat_of(st, nst, &ds->svo_tiled);
	dstat_of(stc, nstc, &ds->svo_tiled_cross);
	dstat_of(so, nso, &ds->svo_oracle);
	dstat_of(to, nto, &ds->tiled_oracle);
	free(st);
	bc_frame_finish(&a);
	bc_frame_finish(&b);
	return rc;
}

/* The camera moved to look at its target from elev degrees above the plane
 * normal to axis (0 x, 1 y, 2 z), from the same distance. */
static void grazing(const struct bc_camera *c, int axis, float elev_deg,
                    struct bc_camera *out)
{
	float dist = 0.0f, e = elev_deg * 3.14159265f / 180.0f;
	int u = (axis + 1) % 3, v = (axis + 2) % 3;
	*out = *c;
	for (int i = 0; i < 3; i++) {
		float k = c->eye[i] - c->target[i];
		dist += k * k;
	}
	dist = sqrtf(dist);
	out->eye[axis] = c->target[axis] + dist * sinf(e);
	out->eye[u] = c->target[u] + dist * cosf(e) * 0.8f;
	out->eye[v] = c->target[v] + dist * cosf(e) * 0.6f;
	memset(out->up, 0, sizeof(out->up));
	out->up[axis] = 1.0f;
}

static void print_dstat(const char *what, const struct dstat *s)
{
	printf("    %-18s %4u px: p50 %.1e p95 %.1e max %.1e, %u beyond 0.05\n",
	       what, s->n, (double)s->p50, (double)s->p95, (double)s->max,
	       s->far);
}

/* flat: the scene's solids have large planar faces (gears). A ray parallel
 * to such a face, within the band, has a nearly constant field along a long
 * stretch: its closest approach is ill-conditioned, and any point of the
 * plateau is as good a depth. There the svo backend is held to the
 * tiled tracer's own agreement with the oracle. */
static void check(const char *what, const struct bc_tree *t,
                  const struct bc_camera *cam, enum bc_range_arith arith,
                  bool flat, float *worst)
{
	struct depth_stats ds;
	REQUIRE(depth_compare(t, cam, arith, &ds) == 0);
	printf("  %s (hit masks differ on %u px)\n", what, ds.mask_diff);
	print_dstat("svo - tiled", &ds.svo_tiled);
	print_dstat("  on crossings", &ds.svo_tiled_cross);
	print_dstat("svo - oracle", &ds.svo_oracle);
	print_dstat("tiled - oracle", &ds.tiled_oracle);
	CHECK(ds.svo_tiled.n > W * H / 50); /* the scene is in view */
	CHECK(ds.mask_diff * 100u <= W * H);
	CHECK(ds.svo_oracle.p50 <= 1e-4f);
	/* A ray that grazes one solid and crosses another behind it within
	 * the march's reach is the one place where the two may pick
	 * different surfaces; such a pixel stays within the scene. */
	CHECK(ds.svo_oracle.max <= 0.3f * bc_tree_lin(t)->size);
	if (!flat) {
		/* Where the oracle crosses the surface both renderers refine
		 * to the crossing. */
		CHECK(ds.svo_tiled_cross.p95 <= 1e-3f);
		CHECK(ds.svo_oracle.p95 <= 1e-3f);
		CHECK(ds.svo_oracle.far * 100u <= 6u * ds.svo_oracle.n);
		CHECK(ds.svo_oracle.far <= ds.tiled_oracle.far);
		if (ds.svo_oracle.p95 > *worst) {
			*worst = ds.svo_oracle.p95;
		}
	} else {
		CHECK(ds.svo_oracle.p95 <=
		      fmaxf(1e-3f, 4.0f * ds.tiled_oracle.p95));
		CHECK(ds.svo_oracle.far * 4u <= ds.tiled_oracle.far * 5u + 8u);
	}
}

static void svo_depth_matches_tiled(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
		int axis;
		bool flat;
	} scenes[] = {
	    {"gears", {.teeth = 16}, 2, true},
	    {"many-gears", {.count = 9}, 2, true},
	    {"fig18", {.count = 32, .kind = BC_GEN_KIND_SPHERES}, 1, false},
	    {"fig18", {.count = 24}, 1, false},
	    {"fig16", {.level = 2}, 1, false},
	    {"many-spheres", {.count = 120}, 1, false},
	    {"catalogue", {0}, 1, true},
	};
	float worst = 0.0f;
	for (size_t i = 0; i < sizeof(scenes) / sizeof(scenes[0]); i++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam, gz;
		struct bc_errinfo ei = {0};
		char what[64];
		REQUIRE(t);
		REQUIRE(bc_gen(scenes[i].name, &scenes[i].o, t, &cam, &ei) ==
		        0);
		snprintf(what, sizeof(what), "%s", scenes[i].name);
		check(what, t, &cam, BC_RANGE_DEFAULT, scenes[i].flat, &worst);
		grazing(&cam, scenes[i].axis, 4.0f, &gz);
		snprintf(what, sizeof(what), "%s grazing", scenes[i].name);
		check(what, t, &gz, BC_RANGE_DEFAULT, scenes[i].flat, &worst);
		bc_tree_destroy(t);
	}
	printf("  worst p95 against the oracle (curved scenes) %.2e\n",
	       (double)worst);
}

static void svo_depth_matches_tiled_on_the_default_scene(void)
{
	const char *json = bc_scene_default_json();
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam, gz;
	struct bc_errinfo ei = {0};
	float worst = 0.0f;
	REQUIRE(t);
	REQUIRE(bc_scene_parse_json(json, strlen(json), t, &cam, &ei) == 0);
	check("default ia", t, &cam, BC_RANGE_IA, false, &worst);
	check("default revaa", t, &cam, BC_RANGE_REVAA, false, &worst);
	check("default aa", t, &cam, BC_RANGE_AA, false, &worst);
	for (int axis = 0; axis < 3; axis++) {
		char what[32];
		grazing(&cam, axis, 3.0f, &gz);
		snprintf(what, sizeof(what), "default grazing %c", "xyz"[axis]);
		check(what, t, &gz, BC_RANGE_DEFAULT, false, &worst);
	}
	printf("  worst p95 against the oracle %.2e\n", (double)worst);
	bc_tree_destroy(t);
}

/* Casts W x H rays of cam through s; depth +inf on a miss. Returns the
 * range evaluations spent. */
static uint64_t cast_all(const struct bc_svo *s, const struct bc_camera *cam,
                         const struct bc_svo_cast_params *cp, float *depth)
{
	struct bc_svo_caster *c = NULL;
	struct bc_view_rays vr;
	uint64_t ranges = 0;
	bc_view_rays_init(&vr, cam, W, H);
	if (bc_svo_caster_create(&c, s)) {
		return UINT64_MAX;
	}
	for (uint32_t i = 0; i < W * H; i++) {
		struct bc_svo_hit hit;
		float d[3];
		bc_view_rays_dir(&vr, (float)(i % W) + 0.5f,
		                 (float)(i / W) + 0.5f, d);
		depth[i] = bc_svo_cast(c, vr.eye, d, 0.0f, INFINITY, cp, &hit)
		               ? hit.t
		               : INFINITY;
		ranges += hit.range_evals;
	}
	bc_svo_caster_destroy(c);
	return ranges;
}

/* Leaves whose variant is 1-Lipschitz are searched by steps of the field's
 * value instead of interval bisection (cast.c): every such leaf of a scene
 * of exact primitives under sharp operators, none under blends; and the
 * two searches find the same hits at the same depths (to the refinement
 * tolerance, except the few rays where a pixel-wide dip is bracketed at
 * different samples), with far fewer range evaluations. */
static void stepping_matches_bisection(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
		bool all; /* every active leaf is 1-Lipschitz */
	} scenes[] = {
	    {"fig18",
	     {.count = 48,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SHARP},
	     true},
	    {"gears", {.teeth = 16}, false},
	    {"catalogue", {0}, false},
	    {"fig18", {.count = 24, .blend = BC_GEN_BLEND_SMOOTH}, false},
	};
	for (size_t i = 0; i < sizeof(scenes) / sizeof(scenes[0]); i++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct bc_svo_rpn rpn;
		struct bc_svo *sa = NULL, *sb = NULL;
		struct bc_svo_stats st;
		struct bc_svo_cast_params cp;
		float *da = calloc(2 * W * H, sizeof(*da)), *db = da + W * H;
		float *err = calloc(W * H, sizeof(*err));
		uint32_t diff = 0, both = 0;
		uint64_t ra, rb;
		REQUIRE(t && da && err);
		REQUIRE(bc_gen(scenes[i].name, &scenes[i].o, t, &cam, &ei) ==
		        0);
		REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
		{
			struct bc_svo_opts oa = {
			    .band = frame_cast_params(&rpn, &cam, W, H, &cp)};
			struct bc_svo_opts ob = oa;
			ob.no_step = true;
			REQUIRE(bc_svo_build(&sa, &rpn, &oa, &ei) == 0);
			REQUIRE(bc_svo_build(&sb, &rpn, &ob, &ei) == 0);
		}
		bc_svo_get_stats(sa, &st);
		ra = cast_all(sa, &cam, &cp, da);
		rb = cast_all(sb, &cam, &cp, db);
		for (uint32_t k = 0; k < W * H; k++) {
			bool ha = isfinite(da[k]), hb = isfinite(db[k]);
			diff += ha != hb;
			if (ha && hb) {
				err[both++] = fabsf(da[k] - db[k]);
			}
		}
		qsort(err, both, sizeof(*err), cmp_float);
		printf("  %-9s %u of %u active leaves stepped; hit masks "
		       "differ on %u px, of %u both hit: depth p95 %.1e "
		       "max %.1e; range evaluations %llu against %llu\n",
		       scenes[i].name, st.stepped, st.active, diff, both,
		       both ? (double)err[both * 95 / 100] : 0.0,
		       both ? (double)err[both - 1] : 0.0,
		       (unsigned long long)ra, (unsigned long long)rb);
		if (scenes[i].all) {
			CHECK_EQ_INT(st.stepped, st.active);
		}
		if (scenes[i].o.blend == BC_GEN_BLEND_SMOOTH) {
			CHECK(st.stepped < st.active);
		}
		CHECK(diff * 200u <= W * H); /* <= 0.5 % */
		CHECK(both > W * H / 20);
		CHECK(both == 0 ||
		      err[both * 95 / 100] <= 10.0f * cp.refine_tol);
		if (st.stepped * 2u >= st.active) {
			/* Mostly stepped: bisection is a fallback there. */
			CHECK(ra * 2u <= rb);
		}
		bc_svo_destroy(sa);
		bc_svo_destroy(sb);
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
		free(da);
		free(err);
	}
}

/* A packet of rays (bc_svo_cast_packet, what the backend casts) finds,
 * ray by ray, bit for bit what each ray cast alone finds: on scenes whose
 * leaves are all stepped, some, or none (blends), under every arithmetic
 * on the default scene, from their own cameras and grazing ones, and on
 * random packets from origins in and around the octree with random ray
 * intervals. The backend's 4 x 2 blocks mostly walk together (at most one
 * ray in 20 cast alone). */
static void packets_match_single_rays(void)
{
	static const struct {
		const char *name;
		struct bc_gen_opts o;
	} scenes[] = {
	    {"fig18",
	     {.count = 48,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SHARP}},
	    {"gears", {.teeth = 16}},
	    {"catalogue", {0}},
	    {"fig18", {.count = 24, .blend = BC_GEN_BLEND_SMOOTH}},
	    {"many-spheres", {.count = 120}},
	    {NULL, {0}}, /* the default scene */
	};
	for (size_t i = 0; i < sizeof(scenes) / sizeof(scenes[0]); i++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cams[2];
		struct bc_errinfo ei = {0};
		struct bc_svo_rpn rpn;
		REQUIRE(t);
		if (scenes[i].name) {
			REQUIRE(bc_gen(scenes[i].name, &scenes[i].o, t,
			               &cams[0], &ei) == 0);
		} else {
			const char *json = bc_scene_default_json();
			REQUIRE(bc_scene_parse_json(json, strlen(json), t,
			                            &cams[0], &ei) == 0);
		}
		grazing(&cams[0], 1, 4.0f, &cams[1]);
		REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
		for (int a = 0; a < 3; a++) {
			static const enum bc_range_arith ar[3] = {
			    BC_RANGE_IA, BC_RANGE_REVAA, BC_RANGE_AA};
			static const char *const an[3] = {"ia", "revaa", "aa"};
			if (a > 0 && scenes[i].name) {
				break; /* every arithmetic on one scene */
			}
			for (int k = 0; k < 2; k++) {
				struct bc_svo_cast_params cp;
				struct bc_svo_opts o = {
				    .arith = ar[a],
				    .band = frame_cast_params(&rpn, &cams[k], W,
				                              H, &cp)};
				struct bc_svo *s = NULL;
				char label[64];
				REQUIRE(bc_svo_build(&s, &rpn, &o, &ei) == 0);
				snprintf(label, sizeof(label), "%-12s %s %s",
				         scenes[i].name ? scenes[i].name
				                        : "default",
				         k ? "grazing" : "own", an[a]);
				CHECK(packets_agree(s, &rpn, &cams[k], W, H,
				                    &cp, 7u + i, label));
				bc_svo_destroy(s);
			}
		}
		bc_svo_rpn_finish(&rpn);
		bc_tree_destroy(t);
	}
}

/* Rays along an axis that lie in the octree's mid planes never cross them:
 * the walk puts such a ray in the upper half, where a point on the plane
 * lies (bc_svo_locate). A sphere with eight small ones around it, in an
 * octree subdivided down to one term a leaf (two levels): rays along each
 * axis, both ways, in the planes of the first three levels (and at their
 * crossings) hit the first sphere on their line where the formula puts
 * it, and miss where no sphere is near their line, alone and in packets
 * with tilted rays. */
#define MIDPLANE_SPHERES 9
static void axis_rays_in_mid_planes_hit_the_spheres(void)
{
	const struct bc_prim_info *info = bc_prim_info(BC_PRIM_SPHERE);
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	struct bc_svo_rpn rpn;
	struct bc_svo_cast_params cp;
	struct bc_svo *s = NULL;
	struct bc_svo_caster *cs = NULL;
	struct bc_svo_stats stats;
	struct bc_camera cam = {
	    {0.0f, 0.0f, 6.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 45.0f};
	float c[MIDPLANE_SPHERES][3], r[MIDPLANE_SPHERES];
	float lo[3], hi[3], planes[3][7];
	uint32_t hits = 0, misses = 0, bad = 0, packed_bad = 0;
	REQUIRE(t && info);
	REQUIRE(bc_tree_begin(t) == 0);
	REQUIRE(bc_tree_push_op(t, 0, &(struct bc_op_data){BC_OP_UNION, 0, 0},
	                        &ei) == 0);
	for (uint32_t k = 0; k < MIDPLANE_SPHERES; k++) {
		struct bc_prim_data p;
		static const float big[3] = {0.13f, -0.21f, 0.07f};
		for (int i = 0; i < 3; i++) {
			c[k][i] = big[i] +
			          (k == 0 ? 0.0f
			                  : ((k - 1) >> i & 1u ? 1.2f : -1.2f));
		}
		r[k] = k == 0 ? 0.6f : 0.15f;
		bc_prim_data_init(&p, BC_PRIM_SPHERE);
		for (uint32_t i = 0; i < info->nparams; i++) {
			if (strcmp(info->params[i].name, "radius") == 0) {
				p.params[info->params[i].offset] = r[k];
			}
		}
		memcpy(p.translate, c[k], sizeof(p.translate));
		REQUIRE(bc_tree_put_prim(t, 0, &p, &ei) == 0);
	}
	REQUIRE(bc_tree_pop_op(t, &ei) == 0);
	REQUIRE(bc_tree_end(t, &ei) == 0);
	REQUIRE(bc_svo_rpn_init(&rpn, bc_tree_lin(t)) == 0);
	{
		struct bc_svo_opts o = {
		    .threshold = 1,
		    .band = frame_cast_params(&rpn, &cam, W, H, &cp)};
		REQUIRE(bc_svo_build(&s, &rpn, &o, &ei) == 0);
	}
	bc_svo_get_stats(s, &stats);
	CHECK(stats.max_depth >= 2); /* the walk has nodes to cross */
	REQUIRE(bc_svo_caster_create(&cs, s) == 0);
	bc_svo_bounds(s, lo, hi);
	/* The mid planes of levels 1-3 on each axis, as the walk computes
	 * them: halving the box's floats. */
	for (int i = 0; i < 3; i++) {
		float m1 = 0.5f * (lo[i] + hi[i]);
		float m2l = 0.5f * (lo[i] + m1), m2h = 0.5f * (m1 + hi[i]);
		float v[7] = {m1,
		              m2l,
		              m2h,
		              0.5f * (lo[i] + m2l),
		              0.5f * (m2l + m1),
		              0.5f * (m1 + m2h),
		              0.5f * (m2h + hi[i])};
		memcpy(planes[i], v, sizeof(v));
	}
	for (int a = 0; a < 3; a++) {
		int b = (a + 1) % 3, e = (a + 2) % 3;
		for (int sg = -1; sg <= 1; sg += 2) {
			for (int j = 0; j < 7 * 7; j++) {
				float o[3], d[BC_SVO_PACKET][3],
				    want = INFINITY;
				bool near = false;
				struct bc_svo_hit one, ph[BC_SVO_PACKET];
				uint32_t got;
				bool h;
				o[a] = sg > 0 ? lo[a] - 1.0f : hi[a] + 1.0f;
				o[b] = planes[b][j / 7];
				o[e] = planes[e][j % 7];
				memset(d, 0, sizeof(d));
				d[0][a] = (float)sg;
				for (uint32_t k = 0; k < MIDPLANE_SPHERES;
				     k++) {
					float rho2 =
					    (o[b] - c[k][b]) *
					        (o[b] - c[k][b]) +
					    (o[e] - c[k][e]) * (o[e] - c[k][e]);
					float r2 = r[k] * r[k];
					if (rho2 < 0.98f * r2) {
						want = fminf(
						    want,
						    fabsf(o[a] - c[k][a]) -
						        sqrtf(r2 - rho2));
					} else if (rho2 <= 1.1f * r2) {
						near = true; /* a silhouette */
					}
				}
				h = bc_svo_cast(cs, o, d[0], 0.0f, INFINITY,
				                &cp, &one);
				if (want < INFINITY) {
					hits++;
					bad +=
					    !h || fabsf(one.t - want) > 1e-4f;
				} else if (!near) {
					misses++;
					bad += h;
				}
				/* A packet: the axis ray, and rays tilted off
				 * the planes by growing angles. */
				for (uint32_t l = 1; l < BC_SVO_PACKET; l++) {
					float tilt = 0.02f * (float)l;
					d[l][a] = (float)sg;
					d[l][b] = l & 1u ? tilt : 0.0f;
					d[l][e] = l & 2u ? -tilt : 0.0f;
					bc_v3_normalize_div(d[l]);
				}
				got = bc_svo_cast_packet(
				    cs, o, (const float(*)[3])d, BC_SVO_PACKET,
				    0.0f, INFINITY, &cp, ph);
				for (uint32_t l = 0; l < BC_SVO_PACKET; l++) {
					struct bc_svo_hit al;
					bool ha =
					    bc_svo_cast(cs, o, d[l], 0.0f,
					                INFINITY, &cp, &al);
					packed_bad += !same_hit(
					    ha, &al, (got >> l) & 1u, &ph[l]);
				}
			}
		}
	}
	printf("  octree depth %u; %u rays in mid planes that must hit, %u "
	       "that must miss: %u wrong; %u packed rays differ from "
	       "alone\n",
	       stats.max_depth, hits, misses, bad, packed_bad);
	CHECK(hits > 50);
	CHECK(misses > 100);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(packed_bad, 0);
	bc_svo_caster_destroy(cs);
	bc_svo_destroy(s);
	bc_svo_rpn_finish(&rpn);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"axis_rays_in_mid_planes_hit_the_spheres",
     axis_rays_in_mid_planes_hit_the_spheres},
    {"packets_match_single_rays", packets_match_single_rays},
    {"stepping_matches_bisection", stepping_matches_bisection},
    {"svo_depth_matches_tiled", svo_depth_matches_tiled},
    {"svo_depth_matches_tiled_on_the_default_scene",
     svo_depth_matches_tiled_on_the_default_scene},
};

BC_TEST_MAIN(tests)
