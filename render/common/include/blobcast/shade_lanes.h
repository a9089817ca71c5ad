/*
 * bc_shade_hit's colour before it becomes bytes, written once over a lane
 * vocabulary that the including file defines (render/cpu/packet_kernel.h's
 * names):
 *
 *   vf, vm            a float per lane, a lane mask
 *   vset1 vadd vsub vmul vdiv vsqrt vabs vneg
 *   vmax              a > b ? a : b
 *   vgt vle           ordered comparisons (false on NaN)
 *   mand, vsel(m, a, b) = m ? a : b
 *
 * render/common/shade.c includes it with one float a lane (bc_shade_hit);
 * the packet kernels of render/cpu with 8 or 16 (the vector tracer shades
 * a tile's hits together). Every lane takes the same float operations in
 * the same order, and none is fused (the includers are compiled without
 * contraction, -std=c11), so a lane's colour is bit for bit the one-lane
 * colour. Branches are selections: a lane computes both sides.
 *
 * Not guarded: each including file defines its vocabulary once and
 * includes this once.
 */

#include <float.h>

#include "blobcast/shade.h"

static inline vf bc__shade_dot(const vf a[3], const vf b[3])
{
	return vadd(vadd(vmul(a[0], b[0]), vmul(a[1], b[1])), vmul(a[2], b[2]));
}

/* bc_v3_normalize_div: a divided by its length where that is above 0. */
static inline void bc__shade_normalize_div(vf a[3])
{
	vf n = vsqrt(bc__shade_dot(a, a));
	vm pos = vgt(n, vset1(0.0f));
	for (int c = 0; c < 3; c++) {
		a[c] = vsel(pos, vdiv(a[c], n), a[c]);
	}
}

/* The linear colour lit[] of a surface point seen along unit direction d
 * with field gradient grad and linear albedo (bc_shade_hit). */
static inline void bc__shade_lit(const struct bc_shade *s, const vf grad[3],
                                 const vf d[3], const vf albedo[3], vf lit[3])
{
	vf zero = vset1(0.0f), big = vset1(FLT_MAX);
	vf light[3] = {vset1(s->light[0]), vset1(s->light[1]),
	               vset1(s->light[2])};
	vf n[3], hv[3], x, spec, diff, scale;
	vm ok = vgt(bc__shade_dot(grad, grad), zero), inside;
	for (int c = 0; c < 3; c++) {
		/* No usable gradient (not finite, or zero: a sample fell
		 * outside every active primitive): face the viewer. */
		ok = mand(ok, vle(vabs(grad[c]), big));
	}
	for (int c = 0; c < 3; c++) {
		n[c] = vsel(ok, grad[c], vneg(d[c]));
		hv[c] = vsub(light[c], d[c]);
	}
	bc__shade_normalize_div(n);
	/* Seen from inside (the eye is in the solid): light the side that
	 * faces us. */
	inside = vgt(bc__shade_dot(n, d), zero);
	for (int c = 0; c < 3; c++) {
		n[c] = vsel(inside, vneg(n[c]), n[c]);
	}
	diff = vmax(bc__shade_dot(n, light), zero);
	bc__shade_normalize_div(hv);
	/* x^48 as (x^3)^16: five products instead of a powf call; the
	 * highlight moves by a few ulps. No highlight where the diffuse
	 * term is 0. */
	x = vmax(bc__shade_dot(n, hv), zero);
	spec = vmul(vmul(x, x), x);
	for (int k = 0; k < 4; k++) {
		spec = vmul(spec, spec);
	}
	spec = vsel(vgt(diff, zero), spec, zero);
	scale = vadd(vset1(s->ambient),
	             vmul(vsub(vset1(1.0f), vset1(s->ambient)), diff));
	for (int c = 0; c < 3; c++) {
		lit[c] = vadd(vmul(albedo[c], scale), vmul(vset1(0.25f), spec));
	}
}
