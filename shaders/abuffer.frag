#version 430 core
// A-buffer pass, fragment stage (Zanni 2024 Sec. 6.1): one fragment is one
// (primitive, tile) pair. It clips the tile's 64 pixel rays against the ABV
// and aggregates their intervals (min entry, max exit); when any ray hits,
// the fragment is pushed on the tile's linked list. Depths are ray
// parameters t along unit directions, like the CPU renderers', rather than
// the paper's NDC. Fragments beyond the buffer's capacity are counted but
// not stored: the host sees the count, grows the buffer and draws the frame
// again. Tiles a region does not list get no fragments: their lists are not
// needed, and a listed tile's list does not depend on the others.
#include "common.glsl"
#include "abv.glsl"

flat in uint g_prim;
flat in float g_margin;

void main()
{
	uint tx = uint(gl_FragCoord.x), ty = uint(gl_FragCoord.y);
	uint tile = ty * u_size.z + tx;
	if (!bc_region_listed(tile)) {
		return;
	}
	bc_abv_rec a = b_abv[g_prim];
	// The widened ABV (common.glsl): radii and half extents grow.
	a.hi.w += g_margin;
	a.b.xyz += uint(a.lo.w + 0.5) == BC_ABV_BOX ? vec3(g_margin) : vec3(0.0);
	uint x0 = tx * BC_TILE, y0 = ty * BC_TILE;
	uint x1 = min(x0 + BC_TILE, u_size.x), y1 = min(y0 + BC_TILE, u_size.y);
	float t0 = BC_INF, t1 = -BC_INF;
	for (uint y = y0; y < y1; y++) {
		for (uint x = x0; x < x1; x++) {
			vec3 d = bc_ray_dir(float(x) + 0.5, float(y) + 0.5);
			bc_span s = bc_abv_span(a, u_eye.xyz, d);
			if (!bc_span_empty(s) && s.hi > 0.0) {
				t0 = min(t0, max(s.lo, 0.0));
				t1 = max(t1, s.hi);
			}
		}
	}
	if (!(t1 >= t0)) {
		return; // no ray of the tile meets the ABV
	}
	// Widen by more than float's rounding of the clip (see abv.glsl).
	float pad = 1.0e-5 * t1 + 1.0e-6 * u_misc.y;
	t0 = max(t0 - pad, 0.0);
	t1 += pad;
	uint idx = atomicAdd(b_stat[BC_STAT_FRAGMENTS], 1u);
	if (idx >= u_counts.y) {
		return;
	}
	uint prev = atomicExchange(b_tile[tile].x, idx);
	b_link[idx] = uvec4(floatBitsToUint(t0), floatBitsToUint(t1), g_prim,
			    prev);
	atomicAdd(b_tile[tile].y, 1u);
}
