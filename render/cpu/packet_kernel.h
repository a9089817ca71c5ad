/*
 * The body of a packet kernel (packet.h), written once over a small vector
 * vocabulary that the including file defines for its instruction set:
 *
 *   vf, vm            float vector of PK_LANES lanes, lane mask
 *   vset1 vload vstore vadd vsub vmul vdiv vfma(a, b, c) = a * b + c
 *   vmin vmax         a < b ? a : b and a > b ? a : b, as bc__minf/maxf
 *   vsqrt vabs vneg vfloor (floorf)
 *   vlt vle vgt       ordered comparisons (false on NaN)
 *   vge               ordered a >= b
 *   mand mnot mfrombits(bits) mtobits(m)
 *   vsel(m, a, b) = m ? a : b (bitwise)
 *   vbits(u)          every lane holds the bits of uint32_t u
 *
 * and PK_MARCH, PK_HITS, PK_SHADE, the kernels' names. Including it
 * twice (AVX2 and AVX-512) gives two kernels whose lanes do the same
 * operations in the same order. PK_SHADE's formulas are
 * blobcast/shade_lanes.h's, on this vocabulary.
 *
 * The view is interpreted instruction by instruction: each primitive's
 * affine map and field and each operator are inlined vector code over the
 * whole packet. NaN never steers a lane: the compact operators' tests are
 * ordered comparisons, so a NaN (from +inf - +inf between two missing
 * operands) selects the sharp operator, as ops.c's `!(h > 0)` does. Kinds
 * without a vector form here take bc_prim_sdf lane by lane.
 */

#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "blobcast/shade_lanes.h"

static inline vf vclamp(vf v, vf lo, vf hi)
{
	return vmin(vmax(v, lo), hi);
}

static inline vf vlen2(vf x, vf y)
{
	return vsqrt(vfma(x, x, vmul(y, y)));
}

static inline vf vlen3(vf x, vf y, vf z)
{
	return vsqrt(vfma(x, x, vfma(y, y, vmul(z, z))));
}

/* prim.c's box_d. */
static inline vf vbox_d(vf dx, vf dy, vf dz)
{
	vf zero = vset1(0.0f);
	vf out = vlen3(vmax(dx, zero), vmax(dy, zero), vmax(dz, zero));
	return vadd(out, vmin(vmax(dx, vmax(dy, dz)), zero));
}

/* prim.c's extrude. */
static inline vf vextrude(vf d2, vf dz)
{
	vf zero = vset1(0.0f);
	return vadd(vmin(vmax(d2, dz), zero),
	            vlen2(vmax(d2, zero), vmax(dz, zero)));
}

/* A kind without a vector form: the scalar field, lane by lane. */
static vf scalar_sdf(uint32_t kind, const float *k, vf x, vf y, vf z,
                     uint32_t active)
{
	_Alignas(64) float xs[PK_LANES], ys[PK_LANES], zs[PK_LANES];
	_Alignas(64) float out[PK_LANES] = {0};
	vstore(xs, x);
	vstore(ys, y);
	vstore(zs, z);
	for (uint32_t i = 0; i < PK_LANES; i++) {
		if ((active >> i) & 1u) {
			out[i] = bc_prim_sdf((enum bc_prim)kind, k, xs[i],
			                     ys[i], zs[i]);
		}
	}
	return vload(out);
}

/* blobtree's bc_domain_apply for one domain node over the lanes: the same
 * operations in the same order, lane-wise; twist and bend (a sine and a
 * cosine per point) lane by lane. */
static void domain_node(uint32_t kind, const float *rec, vf *px, vf *py, vf *pz,
                        uint32_t active)
{
	vf *p[3] = {px, py, pz};
	switch (kind) {
	case BC_OP_ELONGATE:
		for (int i = 0; i < 3; i++) {
			*p[i] = vsub(*p[i], vmin(vmax(*p[i], vset1(-rec[i])),
			                         vset1(rec[i])));
		}
		return;
	case BC_OP_MIRROR: {
		uint32_t mask = (uint32_t)rec[0];
		for (int i = 0; i < 3; i++) {
			if (mask & (1u << i)) {
				*p[i] = vabs(*p[i]);
			}
		}
		return;
	}
	case BC_OP_REPEAT:
		for (int i = 0; i < 3; i++) {
			float n = rec[3 + i], o;
			vf id;
			if (!(n > 1.0f)) {
				continue;
			}
			o = 0.5f * (n - 1.0f);
			id = vfloor(
			    vadd(vadd(vdiv(*p[i], vset1(rec[i])), vset1(o)),
			         vset1(0.5f)));
			id = vmin(vmax(id, vset1(0.0f)), vset1(n - 1.0f));
			*p[i] = vsub(*p[i],
			             vmul(vset1(rec[i]), vsub(id, vset1(o))));
		}
		return;
	case BC_OP_SCALE:
		for (int i = 0; i < 3; i++) {
			*p[i] = vmul(*p[i], vset1(rec[1]));
		}
		return;
	default: {
		_Alignas(64) float xs[PK_LANES], ys[PK_LANES], zs[PK_LANES];
		vstore(xs, *px);
		vstore(ys, *py);
		vstore(zs, *pz);
		for (uint32_t i = 0; i < PK_LANES; i++) {
			if ((active >> i) & 1u) {
				float q[3] = {xs[i], ys[i], zs[i]};
				bc_domain_apply(kind, rec, q);
				xs[i] = q[0];
				ys[i] = q[1];
				zs[i] = q[2];
			}
		}
		*px = vload(xs);
		*py = vload(ys);
		*pz = vload(zs);
		return;
	}
	}
}

/* The points (px, py, pz) mapped through the domain nodes from d (a unary
 * index) outward, outermost first: blobtree's bc_domain_map. */
static void domain_lanes(const struct bc_lin *lin, uint32_t d, vf *px, vf *py,
                         vf *pz, uint32_t active)
{
	uint32_t chain[BC_DOMAIN_MAX_CHAIN];
	uint32_t n = 0;
	for (; d != BC_NONE && n < BC_DOMAIN_MAX_CHAIN; d = lin->unary_dom[d]) {
		chain[n++] = d;
	}
	while (n-- > 0) {
		uint32_t u = chain[n];
		domain_node(lin->unary_kind[u],
		            lin->param + 4u * (size_t)lin->unary_param[u], px,
		            py, pz, active);
	}
}

/* Unary node u's value map of f at the world points (blobtree's
 * bc_unary_value): offset, onion and scale over the lanes, twist and bend
 * (the distance from their axis in their own domain) lane by lane. */
static vf unary_lanes(const struct bc_lin *lin, uint32_t u, vf f, vf px, vf py,
                      vf pz, uint32_t active)
{
	const float *rec = lin->param + 4u * (size_t)lin->unary_param[u];
	_Alignas(64) float xs[PK_LANES], ys[PK_LANES], zs[PK_LANES],
	    fs[PK_LANES];
	switch (lin->unary_kind[u]) {
	case BC_OP_OFFSET:
		return vsub(f, vset1(rec[0]));
	case BC_OP_ONION:
		return vsub(vabs(f), vset1(rec[0]));
	case BC_OP_SCALE:
		return vmul(f, vset1(rec[0]));
	case BC_OP_TWIST:
	case BC_OP_BEND:
		break;
	default:
		return f;
	}
	vstore(xs, px);
	vstore(ys, py);
	vstore(zs, pz);
	vstore(fs, f);
	for (uint32_t i = 0; i < PK_LANES; i++) {
		if ((active >> i) & 1u) {
			const float p[3] = {xs[i], ys[i], zs[i]};
			fs[i] = bc_unary_value(lin, u, fs[i], p);
		}
	}
	return vload(fs);
}

/* The field of a primitive record (affine map, then packed shape; a
 * sphere's centre and radius) at the world points (px, py, pz). */
static inline vf prim_field(uint32_t kind, const float *rec, vf px, vf py,
                            vf pz, uint32_t active)
{
	const float *k;
	if (kind == BC_PRIM_SPHERE) {
		return vsub(vlen3(vsub(px, vset1(rec[0])),
		                  vsub(py, vset1(rec[1])),
		                  vsub(pz, vset1(rec[2]))),
		            vset1(rec[3]));
	}
	vf x = vfma(
	    vset1(rec[0]), px,
	    vfma(vset1(rec[1]), py, vfma(vset1(rec[2]), pz, vset1(rec[3]))));
	vf y = vfma(
	    vset1(rec[4]), px,
	    vfma(vset1(rec[5]), py, vfma(vset1(rec[6]), pz, vset1(rec[7]))));
	vf z = vfma(
	    vset1(rec[8]), px,
	    vfma(vset1(rec[9]), py, vfma(vset1(rec[10]), pz, vset1(rec[11]))));
	k = rec + 12;
	switch (kind) {
	case BC_PRIM_BOX:
		return vsub(vbox_d(vsub(vabs(x), vset1(k[0])),
		                   vsub(vabs(y), vset1(k[1])),
		                   vsub(vabs(z), vset1(k[2]))),
		            vset1(k[3]));
	case BC_PRIM_CAPSULE: {
		vf ex = vset1(k[3]), ey = vset1(k[4]), ez = vset1(k[5]);
		vf qx = vsub(x, vset1(k[0])), qy = vsub(y, vset1(k[1])),
		   qz = vsub(z, vset1(k[2]));
		vf t = vclamp(
		    vmul(vfma(qx, ex, vfma(qy, ey, vmul(qz, ez))), vset1(k[7])),
		    vset1(0.0f), vset1(1.0f));
		return vsub(vlen3(vsub(qx, vmul(ex, t)), vsub(qy, vmul(ey, t)),
		                  vsub(qz, vmul(ez, t))),
		            vset1(k[6]));
	}
	case BC_PRIM_CYLINDER:
		return vextrude(vsub(vlen2(x, z), vset1(k[0])),
		                vsub(vabs(y), vset1(k[1])));
	case BC_PRIM_TORUS:
		return vsub(vlen2(vsub(vlen2(x, z), vset1(k[0])), y),
		            vset1(k[1]));
	case BC_PRIM_LINK: {
		vf qy = vmax(vsub(vabs(y), vset1(k[0])), vset1(0.0f));
		return vsub(vlen2(vsub(vlen2(x, qy), vset1(k[1])), z),
		            vset1(k[2]));
	}
	default:
		return scalar_sdf(kind, k, x, y, z, active);
	}
}

/* ops.c's blend_amount, beta per lane: 0 where beta <= 0 or h <= 0. */
static inline vf vblend_amount(vf f0, vf f1, vf beta)
{
	vf zero = vset1(0.0f);
	vf h = vsub(vset1(1.0f), vdiv(vabs(vsub(f0, f1)), beta));
	vf amount = vmul(vmul(vmul(vmul(beta, vset1(1.0f / 6.0f)), h), h), h);
	return vsel(mand(vgt(beta, zero), vgt(h, zero)), amount, zero);
}

/* The same for the operator's own beta > 0, the same in every lane:
 * 1 / beta and beta / 6 come from the caller, so the lanes divide
 * nothing. */
static inline vf vblend_amount_k(vf f0, vf f1, float inv_beta, float beta_6)
{
	vf zero = vset1(0.0f);
	vf h = vsub(vset1(1.0f), vmul(vabs(vsub(f0, f1)), vset1(inv_beta)));
	vf amount = vmul(vmul(vmul(vset1(beta_6), h), h), h);
	return vsel(vgt(h, zero), amount, zero);
}

/* ops.c's transition (eq. 18): den = 6 r_o - beta > 0 was checked, and
 * six_den is 6 / den. */
static inline vf vtransition(vf x, float beta, float six_den)
{
	vf t = vsub(vset1(1.0f), vmul(x, vset1(six_den)));
	return vsel(vgt(t, vset1(0.0f)), vmul(vset1(beta), t), vset1(0.0f));
}

/* ops.c's bc_op_eval. Its divisions by the operator's constants are
 * products with their reciprocals here (a smooth operator divided five
 * times per lane; now once, by the lane's own closing blend), which moves
 * the value by a rounding at most: the vector field is the scalar one
 * within the kernels' rounding, not bit for bit (test_simd). Where no lane
 * lies within the blend range of both operands the blend is the sharp
 * operator in every lane (the final select would pick it), and its
 * arithmetic, a division among it, is skipped: most operator
 * instructions of a tile's list combine operands far apart, as the
 * scalar bc_op_eval's early return finds per ray. */
static inline vf op_field(uint32_t kind, float blend, float range, vf f0, vf f1)
{
	float den = 6.0f * range - blend;
	float inv_beta, beta_6, six_den;
	vf r = vset1(range), sharp, g, b;
	vm in;
	switch (kind) {
	case BC_OP_UNION:
		return vmin(f0, f1);
	case BC_OP_INTERSECTION:
		return vmax(f0, f1);
	case BC_OP_DIFFERENCE:
		return vmax(f0, vneg(f1));
	case BC_OP_SMOOTH_UNION:
	case BC_OP_SMOOTH_INTERSECTION:
	case BC_OP_SMOOTH_DIFFERENCE:
		break;
	default:
		return vset1(INFINITY);
	}
	if (kind == BC_OP_SMOOTH_DIFFERENCE) {
		f1 = vneg(f1);
	}
	sharp = kind == BC_OP_SMOOTH_UNION ? vmin(f0, f1) : vmax(f0, f1);
	if (!(den > 0.0f) || !(blend > 0.0f)) {
		/* b_r is 0, or no blend to close: G is the sharp operator
		 * (ops.c's blend_amount is 0 for beta <= 0). */
		return sharp;
	}
	inv_beta = 1.0f / blend;
	beta_6 = blend / 6.0f;
	six_den = 6.0f / den;
	if (kind == BC_OP_SMOOTH_UNION) {
		in = mand(vle(f0, r), vle(f1, r));
		if (!mtobits(in)) {
			return sharp;
		}
		g = vsub(sharp, vblend_amount_k(f0, f1, inv_beta, beta_6));
		b = vtransition(g, blend, six_den);
		return vsel(in, vsub(sharp, vblend_amount(f0, f1, b)), sharp);
	}
	/* Intersection, and difference as the intersection with -f1: ops.c
	 * tests |f1| against the range, the same for -f1. */
	in = mand(vle(vabs(f0), r), vle(vabs(f1), r));
	if (!mtobits(in)) {
		return sharp;
	}
	g = vadd(sharp, vblend_amount_k(f0, f1, inv_beta, beta_6));
	b = vtransition(vabs(g), blend, six_den);
	return vsel(in, vadd(sharp, vblend_amount(f0, f1, b)), sharp);
}

/* ops.c's follows_right: where the operator's value follows f1. */
static inline vm op_follows_right(uint32_t kind, vf f0, vf f1)
{
	switch (bc_op_class((enum bc_op)kind)) {
	case BC_OPCLASS_UNION:
		return vlt(f1, f0);
	case BC_OPCLASS_INTERSECTION:
		return vgt(f1, f0);
	case BC_OPCLASS_DIFFERENCE:
	default:
		return vgt(vneg(f1), f0);
	}
}

/* The interpreter; with_id is a constant at each call, and the forced
 * inlining makes two copies, so the id tracking costs the tracing kernel
 * nothing. */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void
run(const struct bc_view *v, const struct bc_lin *lin, struct bc__pk_lanes *ln,
    uint32_t active, bool with_id)
{
	vf stack[BC_EVAL_STACK];
	vf who[BC_EVAL_STACK]; /* primitive indices, as float bits */
	uint32_t sp = 0;
	vf t = vload(ln->t);
	vf px = vfma(t, vload(ln->dx), vload(ln->ox));
	vf py = vfma(t, vload(ln->dy), vload(ln->oy));
	vf pz = vfma(t, vload(ln->dz), vload(ln->oz));
	/* The points mapped through the domain chain from `dom` (the
	 * innermost domain node) last: the leaves under one innermost domain
	 * node come in a row and share the map (eval.c's dom_cache). */
	uint32_t dom = BC_NONE;
	vf qx = px, qy = py, qz = pz;
	for (uint32_t i = 0; i < v->n; i++) {
		const struct bc_view_instr *in = &v->instr[i];
		const float *rec = lin->param + 4u * (size_t)in->param;
		if (in->leaf == BC_VIEW_UNARY) {
			stack[sp - 1] = unary_lanes(
			    lin, in->slot, stack[sp - 1], px, py, pz, active);
		} else if (in->leaf) {
			if (with_id) {
				who[sp] =
				    vbits(bc_lin_leaf_prim(lin, in->slot));
			}
			if (lin->nunary && lin->dom[in->slot] != BC_NONE) {
				/* Under domain nodes: the primitive sees the
				 * mapped point (eval.c's eval_leaf). */
				if (lin->dom[in->slot] != dom) {
					dom = lin->dom[in->slot];
					qx = px;
					qy = py;
					qz = pz;
					domain_lanes(lin, dom, &qx, &qy, &qz,
					             active);
				}
				stack[sp++] = prim_field(in->kind, rec, qx, qy,
				                         qz, active);
			} else {
				stack[sp++] = prim_field(in->kind, rec, px, py,
				                         pz, active);
			}
		} else {
			vf f1 = stack[--sp], f0 = stack[sp - 1];
			if (with_id) {
				who[sp - 1] =
				    vsel(op_follows_right(in->kind, f0, f1),
				         who[sp], who[sp - 1]);
			}
			stack[sp - 1] =
			    op_field(in->kind, rec[0], rec[1], f0, f1);
		}
	}
	vstore(ln->v, sp ? stack[0] : vset1(INFINITY));
	if (with_id) {
		_Alignas(64) float bits[PK_LANES];
		vstore(bits, sp ? who[0] : vbits(BC_NONE));
		memcpy(ln->id, bits, sizeof(bits));
	}
}

/* The lanes (of `lanes`) whose bisection starts on the bracket [a, b]
 * (packet.c's bisect_start and bisect_head with i = 0) and goes on: b - a
 * wider than refine_tol and the midpoint strictly inside. *m gets the
 * midpoints. */
static inline vm bisect_opens(vm lanes, vf a, vf b, float refine_tol, vf *m)
{
	*m = vmul(vset1(0.5f), vadd(a, b));
	return mand(lanes, mand(vgt(vsub(b, a), vset1(refine_tol)),
	                        mand(vgt(*m, a), vlt(*m, b))));
}

/* packet.c's refine_head's probe from (t, v) with (t_prev, v_prev) before
 * it, i already counted: the secant's reach, or v itself on the first
 * round (first) when the secant does not apply; *ok is false where the
 * state machine would end the refinement instead. */
static inline vf refine_probe(vf t, vf v, vf t_prev, vf v_prev, vm first,
                              vf limit, float min_step, vm *ok)
{
	vm secant = mand(vgt(t, t_prev), vgt(v_prev, v));
	vf reach = vsel(
	    secant,
	    vdiv(vmul(vmul(vset1(1.5f), v), vsub(t, t_prev)), vsub(v_prev, v)),
	    v);
	vf probe = vmin(vadd(t, vmax(reach, vset1(min_step))), limit);
	*ok = mand(mfrombits(mtobits(secant) | mtobits(first)), vgt(probe, t));
	return probe;
}

/* Lanes where a equals b (the golden-section phases, small whole numbers
 * held as floats). */
static inline vm veq(vf a, vf b)
{
	return mand(vle(a, b), vge(a, b));
}

uint32_t PK_MARCH(const struct bc_view *v, const struct bc_lin *lin,
                  struct bc__pk_lanes *ln, uint32_t active,
                  struct bc__pk_kinds *k, const struct bc__pk_steps *st)
{
	uint32_t march = k->of[BC__PK_LANE_MARCH] & active,
	         bisect = k->of[BC__PK_LANE_BISECT] & active,
	         refine = k->of[BC__PK_LANE_REFINE] & active,
	         gold = k->of[BC__PK_LANE_GOLD] & active, stepped, ended,
	         missed;
	vf zero = vset1(0.0f), one = vset1(1.0f), vn, q, t, fv, tp, vp, om, t1,
	   eps, evals, a, fa, b, fb, bi, m_b, m_x, next, plain, cap, limit,
	   probe_m, probe_r, ri, t_new, g_t = zero, g_hit = zero, g_m = zero,
	   g_a = zero, g_fa = zero;
	vm room, mm, bm, rm, gm, relax, cross, b_go, b_end, m_fast, m_refine,
	    r_go, advance, ok_m, ok_r, g_enter,
	    g_cross = mfrombits(0), g_c0 = mfrombits(0), g_fin = mfrombits(0),
	    g_go = mfrombits(0);
	run(v, lin, ln, active, false);
	k->hit = 0;
	k->miss = 0;
	if (!(march | bisect | refine | gold)) {
		return active;
	}
	/* The value the state machine is fed (trace.c's eval_at): the field
	 * over the tree's own Lipschitz bound (above 1 under twist and
	 * bend), as bc__trace divides it. */
	vn = vmul(vload(ln->v), vset1(1.0f / BC_CPU_LIPSCHITZ));
	if (lin->lip != 1.0f) {
		/* x / 1 is x: a division (the slowest instruction here)
		 * only where a twist or bend raised the bound. */
		vn = vdiv(vn, vset1(lin->lip));
	}
	q = vload(ln->t);
	evals = vload(ln->mevals);
	/* A lane whose bound has no further sample goes back to the state
	 * machine, which stops it. */
	room = vlt(vadd(evals, one), vload(ln->mbudget));
	mm = mand(mfrombits(march), room);
	bm = mand(mfrombits(bisect), room);
	rm = mand(mfrombits(refine), room);
	gm = mand(mfrombits(gold), room);
	/* Marching and refining lanes: t, v, t_prev, v_prev. */
	t = vload(ln->mt);
	fv = vload(ln->mv);
	tp = vload(ln->mt_prev);
	vp = vload(ln->mv_prev);
	t1 = vload(ln->mt1);

	/* Bisection (S_BISECT, then bisect_head): the side of the bracket
	 * the value falls on is replaced (an ordered test, so NaN moves a),
	 * and the bisection goes on while fewer than 40 halvings are done. */
	{
		vm neg = vlt(vn, zero);
		a = vsel(neg, vload(ln->ba), q);
		fa = vsel(neg, vload(ln->bfa), vn);
		b = vsel(neg, q, vload(ln->bb));
		fb = vsel(neg, vn, vload(ln->bfb));
		bi = vadd(vload(ln->bi), one);
		b_go = bisect_opens(mand(bm, vlt(bi, vset1(40.0f))), a, b,
		                    st->refine_tol, &m_b);
		/* The others end here: bisect_head's last interpolation,
		 * a division, where a lane takes it. */
		b_end = mand(bm, mnot(b_go));
		ended = mtobits(b_end);
	}

	/* A marching lane (S_STEP, S_STEP2, or a start lane holding the state
	 * its first value gives) whose relaxed step overshot takes the plain
	 * step from t, omega 1 from then on (S_STEP's first test). */
	om = vload(ln->momega);
	relax =
	    mand(mm, mand(vgt(om, one), vlt(vadd(fv, vabs(vn)), vsub(q, t))));
	/* A value below zero after a step (step_check) or a refining probe
	 * (S_REFINE) starts a bisection of [t, q]. A start lane (q == t)
	 * would hit at t0 instead: the state machine's. */
	cross = bisect_opens(
	    mand(mand(mfrombits(mtobits(mm) | mtobits(rm)), mnot(relax)),
	         mand(vlt(vn, zero), vgt(q, t))),
	    t, q, st->refine_tol, &m_x);
	/* Else a marching lane's new point (q, vn) (march_head): within the
	 * hit epsilon a refinement starts (cap, limit, the first probe); else
	 * an ordinary step, not at t1. */
	eps = vmax(vmul(vset1(st->eps_per_t), q), vset1(st->min_step));
	if (lin->lip != 1.0f) {
		eps = vdiv(eps, vset1(lin->lip));
	}
	{
		vm plain_lane = mand(mand(mm, mnot(relax)), vge(vn, zero));
		vm within = vlt(vn, eps);
		cap = vadd(
		    q, vmul(vset1(64.0f * BC_CPU_LIPSCHITZ * lin->lip), eps));
		limit = vmin(cap, t1);
		vm start = mand(plain_lane, within);
		/* The probes (a division each) only where a lane takes one:
		 * most rounds start no refinement and continue none. */
		probe_m = zero;
		ok_m = mfrombits(0);
		if (mtobits(start)) {
			probe_m =
			    refine_probe(q, vn, t, fv, mfrombits(UINT32_MAX),
			                 limit, st->min_step, &ok_m);
		}
		m_refine = mand(start, ok_m);
		m_fast = mand(mand(plain_lane, mnot(within)), vlt(q, t1));
		/* At the interval's end and not near a surface: march_head's
		 * miss. */
		missed = mtobits(
		    mand(mand(plain_lane, mnot(within)), mnot(vlt(q, t1))));
		next = vmin(
		    vadd(q, vmax(vmul(om, vn), vmul(vset1(1.0e-6f), q))), t1);
		plain = vmin(vadd(t, vmax(fv, vmul(vset1(1.0e-6f), t))), t1);
	}
	/* A refining lane (S_REFINE) whose probe came closer without
	 * crossing: the probe is its new point, and refine_head's next probe
	 * while fewer than 8 rounds are done. A value not below v starts
	 * the golden section (below). */
	ri = vadd(vload(ln->ri), one);
	probe_r = zero;
	ok_r = mfrombits(0);
	if (mtobits(rm)) {
		probe_r = refine_probe(q, vn, t, fv, mfrombits(0),
		                       vload(ln->rlimit), st->min_step, &ok_r);
	}
	r_go = mand(mand(mand(rm, vge(vn, zero)), vlt(vn, fv)),
	            mand(vlt(ri, vset1(8.0f)), ok_r));

	/* The golden-section search (S_GOLD_*, packet.c's gold_start and
	 * gold_head): a refining lane whose probe did not come closer
	 * starts it on [t_prev or t, q]; a searching lane takes its value at
	 * c (phases 0 and 2) or e (1 and 3), crosses into a bisection of
	 * [a, there] where it is below zero, or goes on to the next round, or
	 * ends at the closer sample after the sixth. A value that is not a
	 * number is the machine's. */
	g_enter = mand(mand(rm, vge(vn, zero)), mnot(vlt(vn, fv)));
	if (mtobits(g_enter) | gold) {
		const vf gr = vset1(0.618034f);
		vm back = vlt(tp, t), pos, is_c0, is_e0, is_c, head, left;
		vf ea = vsel(back, tp, t), efa = vsel(back, vp, fv);
		vf ph = vload(ln->gph), ga = vload(ln->ga),
		   gfa = vload(ln->gfa);
		vf gb = vload(ln->gb), gc = vload(ln->gc), ge = vload(ln->ge);
		vf gvc, gve, gi, nb, na, nfa, nc, ne, nv;
		pos = mand(gm, vge(vn, zero));
		g_cross = bisect_opens(mand(gm, vlt(vn, zero)), ga, q,
		                       st->refine_tol, &g_m);
		is_c0 = veq(ph, zero);
		is_e0 = veq(ph, one);
		is_c =
		    mfrombits(mtobits(is_c0) | mtobits(veq(ph, vset1(2.0f))));
		/* S_GOLD_C0 takes vc and asks for e; the others take their
		 * value and run gold_head, E0 from round 0. */
		g_c0 = mand(pos, is_c0);
		head = mand(pos, mnot(is_c0));
		gvc = vsel(is_c, vn, vload(ln->gvc));
		gve = vsel(is_c, vload(ln->gve), vn);
		gi = vsel(is_e0, zero, vadd(vload(ln->gi), one));
		g_fin = mand(head, vge(gi, vset1(6.0f)));
		g_go = mand(head, mnot(g_fin));
		/* gold_head. Left: b = e, e = c, ve = vc, c = b - G (b - a).
		 * Right: a = c, fa = vc, c = e, vc = ve, e = a + G (b - a). */
		left = vlt(gvc, gve);
		nb = vsel(left, ge, gb);
		na = vsel(left, ga, gc);
		nfa = vsel(left, gfa, gvc);
		nc = vsel(left, vsub(nb, vmul(gr, vsub(nb, na))), ge);
		ne = vsel(left, gc, vadd(na, vmul(gr, vsub(nb, na))));
		nv = vsel(left, gvc, gve);
		g_hit = vsel(left, gc, ge);
		g_t = vsel(g_c0, ge, vsel(left, nc, ne));
		/* Entering lanes: gold_start's bracket, asking for c. */
		gc = vsub(q, vmul(gr, vsub(q, ea)));
		ge = vadd(ea, vmul(gr, vsub(q, ea)));
		g_t = vsel(g_enter, gc, g_t);
		vstore(ln->ga, vsel(g_enter, ea, vsel(g_go, na, ga)));
		vstore(ln->gfa, vsel(g_enter, efa, vsel(g_go, nfa, gfa)));
		vstore(ln->gb, vsel(g_enter, q, vsel(g_go, nb, gb)));
		vstore(ln->gc,
		       vsel(g_enter, gc, vsel(g_go, nc, vload(ln->gc))));
		vstore(ln->ge,
		       vsel(g_enter, ge, vsel(g_go, ne, vload(ln->ge))));
		vstore(ln->gvc, vsel(g_go, nv, vsel(g_c0, vn, vload(ln->gvc))));
		vstore(ln->gve, vsel(g_go, nv, vload(ln->gve)));
		vstore(ln->gi, vsel(g_go, gi, vload(ln->gi)));
		vstore(
		    ln->gph,
		    vsel(g_enter, zero,
		         vsel(g_c0, one,
		              vsel(g_go, vsel(left, vset1(2.0f), vset1(3.0f)),
		                   ph))));
		/* A crossing's bisection starts from the bracket's a. */
		g_a = ga;
		g_fa = gfa;
	}

	ended |= mtobits(g_fin);
	stepped = mtobits(b_go) | mtobits(relax) | mtobits(cross) |
	          mtobits(m_refine) | mtobits(m_fast) | mtobits(r_go) | ended |
	          missed | mtobits(g_enter) | mtobits(g_cross) | mtobits(g_c0) |
	          mtobits(g_go);
	if (!stepped) {
		return active;
	}
	/* Bisecting lanes: those that go on, and those that start (from a
	 * march or a refinement, at [t, q]; from a search, at [a, q]). */
	vstore(ln->ba, vsel(b_go, a,
	                    vsel(cross, t, vsel(g_cross, g_a, vload(ln->ba)))));
	vstore(ln->bfa,
	       vsel(b_go, fa,
	            vsel(cross, fv, vsel(g_cross, g_fa, vload(ln->bfa)))));
	vstore(ln->bb, vsel(b_go, b,
	                    vsel(mfrombits(mtobits(cross) | mtobits(g_cross)),
	                         q, vload(ln->bb))));
	vstore(ln->bfb, vsel(b_go, fb,
	                     vsel(mfrombits(mtobits(cross) | mtobits(g_cross)),
	                          vn, vload(ln->bfb))));
	vstore(ln->bi, vsel(b_go, bi,
	                    vsel(mfrombits(mtobits(cross) | mtobits(g_cross)),
	                         zero, vload(ln->bi))));
	/* The new point of an ordinary step, a refinement's start or its
	 * next round: t_prev, v_prev = t, v; t, v = q, vn. */
	advance =
	    mfrombits(mtobits(m_fast) | mtobits(m_refine) | mtobits(r_go));
	vstore(ln->mt_prev, vsel(advance, t, tp));
	vstore(ln->mv_prev, vsel(advance, fv, vp));
	vstore(ln->mt, vsel(advance, q, t));
	vstore(ln->mv, vsel(advance, vn, fv));
	vstore(ln->momega, vsel(relax, one, om));
	vstore(ln->ri, vsel(m_refine, zero, vsel(r_go, ri, vload(ln->ri))));
	vstore(ln->rcap, vsel(m_refine, cap, vload(ln->rcap)));
	vstore(ln->rlimit, vsel(m_refine, limit, vload(ln->rlimit)));
	t_new = vsel(m_fast, next, vsel(relax, plain, q));
	t_new = vsel(m_refine, probe_m, vsel(r_go, probe_r, t_new));
	t_new = vsel(b_go, m_b, vsel(cross, m_x, t_new));
	t_new =
	    vsel(mfrombits(mtobits(g_enter) | mtobits(g_c0) | mtobits(g_go)),
	         g_t, vsel(g_cross, g_m, t_new));
	t_new = vsel(g_fin, g_hit, t_new);
	if (mtobits(b_end)) {
		/* fa - fb > 0 and finite: the chord's zero, clamped into
		 * [a, b]; else a (in the machine's order of operations). */
		vf den = vsub(fa, fb);
		vf th = vadd(a, vdiv(vmul(vsub(b, a), fa), den));
		th = vsel(vlt(th, a), a, vsel(vgt(th, b), b, th));
		th = vsel(mand(vgt(den, zero), vlt(den, vset1(INFINITY))), th,
		          a);
		t_new = vsel(b_end, th, t_new);
	}
	vstore(ln->t, t_new);
	vstore(ln->mevals, vadd(evals, vsel(mfrombits(stepped), one, zero)));
	/* The lanes that changed kind, and those that hit or missed. */
	k->of[BC__PK_LANE_MARCH] &=
	    ~(mtobits(cross) | mtobits(m_refine) | missed);
	k->of[BC__PK_LANE_BISECT] =
	    (k->of[BC__PK_LANE_BISECT] | mtobits(cross) | mtobits(g_cross)) &
	    ~mtobits(b_end);
	k->of[BC__PK_LANE_REFINE] =
	    (k->of[BC__PK_LANE_REFINE] & ~(mtobits(cross) | mtobits(g_enter))) |
	    mtobits(m_refine);
	k->of[BC__PK_LANE_GOLD] =
	    (k->of[BC__PK_LANE_GOLD] & ~(mtobits(g_cross) | mtobits(g_fin))) |
	    mtobits(g_enter);
	k->hit = ended;
	k->miss = missed;
	return active & ~stepped;
}

void PK_HITS(const struct bc_view *v, const struct bc_lin *lin,
             struct bc__pk_lanes *ln, struct bc__pk_shade *sh, uint32_t n)
{
	for (uint32_t i = 0; i < n; i += PK_LANES) {
		uint32_t m = n - i < PK_LANES ? n - i : PK_LANES;
		uint32_t active = (uint32_t)((1ull << m) - 1u);
		vf g[3] = {vset1(0.0f), vset1(0.0f), vset1(0.0f)};
		vstore(ln->ox, vload(sh->o[0] + i));
		vstore(ln->oy, vload(sh->o[1] + i));
		vstore(ln->oz, vload(sh->o[2] + i));
		vstore(ln->t, vload(sh->step + i));
		/* The primitive at the hit: o + step 0. */
		vstore(ln->dx, vset1(0.0f));
		vstore(ln->dy, vset1(0.0f));
		vstore(ln->dz, vset1(0.0f));
		run(v, lin, ln, active, true);
		memcpy(sh->prim + i, ln->id, sizeof(uint32_t) * PK_LANES);
		/* bc__put_hit's differences, in its order. o + step tet is
		 * exact in the fused multiply-add (step tet is +-step):
		 * bc__put_hit's p + h tet. */
		for (int k = 0; k < 4; k++) {
			vf val;
			vstore(ln->dx, vset1(bc__tet[k][0]));
			vstore(ln->dy, vset1(bc__tet[k][1]));
			vstore(ln->dz, vset1(bc__tet[k][2]));
			run(v, lin, ln, active, false);
			val = vload(ln->v);
			for (int c = 0; c < 3; c++) {
				g[c] =
				    vadd(g[c], vmul(vset1(bc__tet[k][c]), val));
			}
		}
		for (int c = 0; c < 3; c++) {
			vstore(sh->g[c] + i, g[c]);
		}
	}
}

void PK_SHADE(const struct bc_shade *s, struct bc__pk_shade *sh, uint32_t n)
{
	for (uint32_t i = 0; i < n; i += PK_LANES) {
		vf g[3], d[3], albedo[3], lit[3];
		for (int c = 0; c < 3; c++) {
			g[c] = vload(sh->g[c] + i);
			d[c] = vload(sh->d[c] + i);
			albedo[c] = vload(sh->albedo[c] + i);
		}
		bc__shade_lit(s, g, d, albedo, lit);
		for (int c = 0; c < 3; c++) {
			vstore(sh->lit[c] + i, lit[c]);
		}
	}
}
