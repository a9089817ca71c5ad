#version 430 core
// A-buffer pass, geometry stage (Zanni 2024 Sec. 6.1): turns a primitive into a
// screen-space quad imposter over the tiles its ABV can cover, in a
// framebuffer with one pixel per 8x8 tile. The quad's corners are rounded
// outwards to whole tiles, so every covered tile's centre is strictly inside
// it: no conservative rasterization is needed and the diagonal never makes
// duplicate fragments. The tile rectangle is the projection of the ABV's
// world AABB, widened by the hit margin (common.glsl), as the tiled CPU
// renderer computes it.
#include "common.glsl"

layout(points) in;
layout(triangle_strip, max_vertices = 4) out;

flat in uint v_prim[];
flat out uint g_prim;
flat out float g_margin;

void emit_corner(float x, float y, float margin)
{
	vec2 tiles = vec2(u_size.zw);
	g_prim = v_prim[0];
	g_margin = margin;
	gl_Position = vec4(2.0 * x / tiles.x - 1.0, 2.0 * y / tiles.y - 1.0,
			   0.0, 1.0);
	EmitVertex();
}

void main()
{
	bc_abv_rec a = b_abv[v_prim[0]];
	float m = bc_abv_margin(a.lo.xyz, a.hi.xyz);
	vec3 lo = a.lo.xyz - m, hi = a.hi.xyz + m;
	// Corners project into the whole view (u_window), the rectangle is
	// clipped to the frame's window there and counted in the frame's
	// tiles: render/cpu/tiled.c's project_box.
	float w = float(u_window.z), h = float(u_window.w);
	vec2 o = vec2(u_window.xy);
	float px0 = BC_INF, px1 = -BC_INF, py0 = BC_INF, py1 = -BC_INF;
	uint behind = 0u;
	for (uint c = 0u; c < 8u; c++) {
		vec3 p = vec3((c & 1u) != 0u ? hi.x : lo.x,
			      (c & 2u) != 0u ? hi.y : lo.y,
			      (c & 4u) != 0u ? hi.z : lo.z);
		vec3 v = p - u_eye.xyz;
		float z = dot(v, u_forward.xyz);
		if (!(z > 1.0e-6 * (abs(v.x) + abs(v.y) + abs(v.z)))) {
			behind++;
			continue;
		}
		float sx = dot(v, u_right.xyz) / (z * u_eye.w * u_forward.w);
		float sy = dot(v, u_up.xyz) / (z * u_eye.w);
		px0 = min(px0, (sx + 1.0) * 0.5 * w);
		px1 = max(px1, (sx + 1.0) * 0.5 * w);
		py0 = min(py0, (1.0 - sy) * 0.5 * h);
		py1 = max(py1, (1.0 - sy) * 0.5 * h);
	}
	uvec4 r; // x0, y0, x1, y1 in tiles, half-open
	if (behind == 8u) {
		return; // wholly behind the eye
	}
	if (behind > 0u) {
		r = uvec4(0u, 0u, u_size.zw); // straddles the eye plane
	} else {
		// One pixel of margin absorbs rounding (pixel i is covered
		// when its centre i + 0.5 is inside).
		px0 = max(px0 - 1.5, o.x);
		py0 = max(py0 - 1.5, o.y);
		px1 = min(px1 + 0.5, float(u_window.x + u_size.x) - 1.0);
		py1 = min(py1 + 0.5, float(u_window.y + u_size.y) - 1.0);
		if (!(px0 <= px1 && py0 <= py1)) {
			return;
		}
		r = uvec4((uint(px0) - u_window.x) / BC_TILE,
			  (uint(py0) - u_window.y) / BC_TILE,
			  (uint(px1) - u_window.x) / BC_TILE + 1u,
			  (uint(py1) - u_window.y) / BC_TILE + 1u);
	}
	// A region's list: only tiles inside the listed tiles' bounding box
	// can be asked for, so the quad is clipped to it (u_bound.yz), and
	// a primitive outside draws nothing. An edit's damage on a large
	// scene then rasterizes what lies near it, not every imposter.
	if (u_region.w == 1u) {
		uvec4 box = uvec4(u_bound.y & 0xffffu, u_bound.y >> 16u,
				  u_bound.z & 0xffffu, u_bound.z >> 16u);
		r = uvec4(max(r.xy, box.xy), min(r.zw, box.zw));
		if (r.x >= r.z || r.y >= r.w) {
			return;
		}
	}
	// Window y runs with the tile row here: the framebuffer is never
	// shown, so tile row ty is window row ty.
	emit_corner(float(r.x), float(r.y), m);
	emit_corner(float(r.z), float(r.y), m);
	emit_corner(float(r.x), float(r.w), m);
	emit_corner(float(r.z), float(r.w), m);
	EndPrimitive();
}
