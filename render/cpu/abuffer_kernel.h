/*
 * The body of the A-buffer's vector kernels (abuffer.h), written once over
 * a small vocabulary that the including file defines for its instruction
 * set:
 *
 *   vf, vm            float vector of AB_LANES lanes (8 or 16), lane mask
 *   vset1 vload vstore vadd vsub vmul vdiv vsqrt vabs
 *   vmin vmax         a < b ? a : b and a > b ? a : b
 *   vgt vge           ordered comparisons (false on NaN)
 *   mand mfrombits(bits)
 *   vsel(m, a, b) = m ? a : b
 *
 * and AB_DIRS, AB_SPHERE, the kernels' names. Each lane does what the
 * scalar form does for its ray, operation by operation in the same order
 * (the including files are compiled with -ffp-contract=off, so no multiply
 * and add fuse), which makes the results equal bit for bit: IEEE division
 * and square root are correctly rounded in both, and the minimum and
 * maximum folded at the end do not depend on the order of the lanes.
 */

#include <math.h>

#define AB_PER_QUARTER (BC__AB_QUARTER_RAYS / AB_LANES)

/* Pixel offsets within the tile of ray l of quarter q (abuffer.h), as
 * floats: whole numbers, so adding them to the tile's corner is exact. */
static _Alignas(64) const float ab_off_x[4][BC__AB_QUARTER_RAYS] = {
    {0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3},
    {4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7},
    {0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3},
    {4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7},
};
static _Alignas(64) const float ab_off_y[4][BC__AB_QUARTER_RAYS] = {
    {0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3},
    {0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3},
    {4, 4, 4, 4, 5, 5, 5, 5, 6, 6, 6, 6, 7, 7, 7, 7},
    {4, 4, 4, 4, 5, 5, 5, 5, 6, 6, 6, 6, 7, 7, 7, 7},
};

/* bc_view_rays_dir for pixel centres (float)x + 0.5f, (float)y + 0.5f of
 * the window, to which it adds the window's origin in the view. */
void AB_DIRS(const struct bc_view_rays *vr, uint32_t x0, uint32_t y0,
             struct bc__ab_rays *out)
{
	vf fx = vset1((float)x0), fy = vset1((float)y0), half = vset1(0.5f);
	vf ox = vset1((float)vr->x0), oy = vset1((float)vr->y0);
	vf two = vset1(2.0f), one = vset1(1.0f), zero = vset1(0.0f);
	vf w = vset1((float)vr->width), h = vset1((float)vr->height);
	vf th = vset1(vr->tan_half_y), asp = vset1(vr->aspect);
	vf fw[3], rt[3], up[3];
	for (int i = 0; i < 3; i++) {
		fw[i] = vset1(vr->forward[i]);
		rt[i] = vset1(vr->right[i]);
		up[i] = vset1(vr->up[i]);
	}
	for (uint32_t q = 0; q < 4; q++) {
		for (uint32_t k = 0; k < AB_PER_QUARTER; k++) {
			uint32_t l = k * AB_LANES;
			vf x = vadd(
			    vadd(vadd(fx, vload(&ab_off_x[q][l])), half), ox);
			vf y = vadd(
			    vadd(vadd(fy, vload(&ab_off_y[q][l])), half), oy);
			vf sx = vmul(vmul(vsub(vdiv(vmul(two, x), w), one), th),
			             asp);
			vf sy = vmul(vsub(one, vdiv(vmul(two, y), h)), th);
			vf d[3], n;
			vm ok;
			for (int i = 0; i < 3; i++) {
				d[i] = vadd(vadd(fw[i], vmul(sx, rt[i])),
				            vmul(sy, up[i]));
			}
			n = vsqrt(vadd(vadd(vmul(d[0], d[0]), vmul(d[1], d[1])),
			               vmul(d[2], d[2])));
			ok = vgt(n, zero);
			for (int i = 0; i < 3; i++) {
				vstore(&out->d[q][i][l],
				       vsel(ok, vdiv(d[i], n), d[i]));
			}
		}
	}
}

/* bc__ab_ray_sphere and its fold, lane by lane. */
void AB_SPHERE(const struct bc__ab_rays *rays, uint64_t lanes, const float v[3],
               float r, float t[2])
{
	vf v0 = vset1(v[0]), v1 = vset1(v[1]), v2 = vset1(v[2]);
	vf vr = vset1(r), r2 = vset1(r * r), zero = vset1(0.0f);
	vf eps = vset1(1.0e-5f), inf = vset1(INFINITY);
	vf lo = inf, hi = vset1(-INFINITY);
	_Alignas(64) float l_lo[AB_LANES], l_hi[AB_LANES];
	float t0 = t[0], t1 = t[1];
	for (uint32_t q = 0; q < 4; q++) {
		for (uint32_t k = 0; k < AB_PER_QUARTER; k++) {
			uint32_t l = k * AB_LANES;
			uint32_t bits =
			    (uint32_t)(lanes >> (q * BC__AB_QUARTER_RAYS + l)) &
			    ((1u << AB_LANES) - 1u);
			vf dx, dy, dz, b, px, py, pz, disc, s, pad, a, e;
			vm hit;
			if (!bits) {
				continue;
			}
			dx = vload(&rays->d[q][0][l]);
			dy = vload(&rays->d[q][1][l]);
			dz = vload(&rays->d[q][2][l]);
			b = vadd(vadd(vmul(v0, dx), vmul(v1, dy)),
			         vmul(v2, dz));
			px = vsub(v0, vmul(b, dx));
			py = vsub(v1, vmul(b, dy));
			pz = vsub(v2, vmul(b, dz));
			disc = vsub(r2, vadd(vadd(vmul(px, px), vmul(py, py)),
			                     vmul(pz, pz)));
			hit = mand(mfrombits(bits), vge(disc, zero));
			s = vsqrt(vsel(hit, disc, zero));
			pad = vmul(eps, vadd(vabs(b), vr));
			a = vsub(vsub(b, s), pad);
			e = vadd(vadd(b, s), pad);
			hit = mand(hit, vgt(e, zero));
			/* a > 0 ? a : 0, as the scalar fold: vmax gives its
			 * second operand, +0, for either zero. */
			a = vmax(a, zero);
			lo = vmin(vsel(hit, a, inf), lo);
			hi = vmax(vsel(hit, e, vset1(-INFINITY)), hi);
		}
	}
	vstore(l_lo, lo);
	vstore(l_hi, hi);
	for (uint32_t i = 0; i < AB_LANES; i++) {
		t0 = l_lo[i] < t0 ? l_lo[i] : t0;
		t1 = l_hi[i] > t1 ? l_hi[i] : t1;
	}
	t[0] = t0;
	t[1] = t1;
}
