// The primitive fields, ported from blobtree/prim.c (bc_prim_sdf) line for
// line so that the gl backend and the CPU renderers trace the same surfaces:
// the same folding into symmetry chambers, the same profile distances, the
// same packed parameters (bc_prim_pack writes k0 = packed[0..3], k1 =
// packed[4..7]). prim.c explains each shape; the comments here only say
// where GLSL needed something different.

// enum bc_prim.
#define BC_PRIM_SPHERE 1u
#define BC_PRIM_BOX 2u
#define BC_PRIM_CAPSULE 3u
#define BC_PRIM_CYLINDER 4u
#define BC_PRIM_TORUS 5u
#define BC_PRIM_CONE 6u
#define BC_PRIM_ROUND_CONE 7u
#define BC_PRIM_ELLIPSOID 8u
#define BC_PRIM_HEX_PRISM 9u
#define BC_PRIM_OCTAHEDRON 10u
#define BC_PRIM_BOX_FRAME 11u
#define BC_PRIM_CAPPED_TORUS 12u
#define BC_PRIM_LINK 13u
#define BC_PRIM_SOLID_ANGLE 14u
#define BC_PRIM_PYRAMID 15u
#define BC_PRIM_TRI_PRISM 16u
#define BC_PRIM_CUT_SPHERE 17u
#define BC_PRIM_CUT_HOLLOW_SPHERE 18u
#define BC_PRIM_DEATH_STAR 19u
#define BC_PRIM_ROUNDED_CYLINDER 20u
#define BC_PRIM_CAPPED_CYLINDER 21u
#define BC_PRIM_CAPPED_CONE 22u
#define BC_PRIM_RHOMBUS 23u
#define BC_PRIM_VESICA_SEGMENT 24u
#define BC_PRIM_EXTRUDE_CIRCLE 25u
#define BC_PRIM_EXTRUDE_RECT 26u
#define BC_PRIM_EXTRUDE_POLYGON 27u
#define BC_PRIM_EXTRUDE_STAR 28u
#define BC_PRIM_REVOLVE_CIRCLE 29u
#define BC_PRIM_REVOLVE_RECT 30u
#define BC_PRIM_REVOLVE_POLYGON 31u
#define BC_PRIM_REVOLVE_STAR 32u

// Signed distance to the box [-h, h] given d = |p| - h per axis.
float bc_box_d(vec3 d)
{
	return length(max(d, vec3(0.0))) + min(max(d.x, max(d.y, d.z)), 0.0);
}

// Signed distance of an extrusion of the exact 2D distance d2.
float bc_extrude(float d2, float dz)
{
	return min(max(d2, dz), 0.0) + length(vec2(max(d2, 0.0), max(dz, 0.0)));
}

// Squared distance from p to the segment from a along e (inv_e2 = 1/|e|^2).
float bc_seg2(vec2 p, vec2 a, vec2 e, float inv_e2)
{
	vec2 w = p - a;
	float t = clamp(dot(w, e) * inv_e2, 0.0, 1.0);
	w -= e * t;
	return dot(w, w);
}

float bc_sdf_cone(vec4 k0, vec4 k1, vec3 p)
{
	float h = k0.x, r1 = k0.y, r2 = k0.z, ex = k0.w, ey = k1.x;
	float rho = length(p.xz);
	float bx = max(rho - r1, 0.0), by = p.y + h;
	float tx = max(rho - r2, 0.0), ty = p.y - h;
	float d2 = min(bx * bx + by * by, tx * tx + ty * ty);
	float wx = rho - r1, wy = p.y + h;
	d2 = min(d2, bc_seg2(vec2(rho, p.y), vec2(r1, -h), vec2(ex, ey), k1.y));
	bool inside = abs(p.y) < h && wx * ey - wy * ex < 0.0;
	float d = sqrt(d2);
	return inside ? -d : d;
}

float bc_sdf_round_cone(vec4 k0, vec4 k1, vec3 p)
{
	vec3 q = p - k0.xyz;
	vec3 e = vec3(k0.w, k1.x, k1.y);
	float ra = k1.z, rb = k1.w;
	float l2 = dot(e, e);
	float p2 = dot(q, q);
	if (l2 == 0.0) {
		return sqrt(p2) - ra;
	}
	float yl = dot(q, e);
	float xl = sqrt(max(p2 * l2 - yl * yl, 0.0));
	float rr = ra - rb;
	float c = sqrt(max(l2 - rr * rr, 0.0));
	float s = yl * c - xl * rr;
	if (s < 0.0) {
		return sqrt(p2) - ra;
	}
	if (s > c * l2) {
		return length(q - e) - rb;
	}
	return (xl * c + yl * rr) / l2 - ra;
}

float bc_sdf_ellipsoid(vec4 k0, vec4 k1, vec3 p)
{
	vec3 inv = vec3(k0.w, k1.x, k1.y);
	vec3 u = p * inv;
	float g0 = length(u), f;
	if (g0 < 1.0) {
		f = k1.z * (g0 - 1.0);
	} else {
		float g1 = length(u * inv);
		f = g0 * (g0 - 1.0) / g1;
	}
	return max(f, bc_box_d(abs(p) - k0.xyz));
}

float bc_sdf_hex_prism(vec4 k0, vec3 p)
{
	const vec2 n = vec2(-0.86602540378, 0.5);
	float a = k0.x, half_side = k0.z;
	vec2 q = abs(p.xy);
	float m = min(dot(n, q), 0.0);
	q -= 2.0 * m * n;
	float dx = q.x - clamp(q.x, -half_side, half_side), dy = q.y - a;
	float d2 = length(vec2(dx, dy));
	return bc_extrude(dy < 0.0 ? -d2 : d2, abs(p.z) - k0.y);
}

float bc_sdf_octahedron(vec4 k0, vec3 p)
{
	float s = k0.x;
	vec3 q = abs(p);
	float m = q.x + q.y + q.z - s;
	vec3 r; // (a, b, c): a is the coordinate that is 0 on the edge
	if (3.0 * q.x < m) {
		r = q.xyz;
	} else if (3.0 * q.y < m) {
		r = q.yzx;
	} else if (3.0 * q.z < m) {
		r = q.zxy;
	} else {
		return m * 0.57735026919;
	}
	float t = clamp(0.5 * (r.z - r.y + s), 0.0, s);
	return length(vec3(r.x, r.y - s + t, r.z - t));
}

float bc_sdf_box_frame(vec4 k0, vec3 p)
{
	float e = k0.w;
	vec3 q = abs(p) - k0.xyz;
	vec3 w = abs(q + e) - e;
	float d = bc_box_d(vec3(q.x, w.y, w.z));
	d = min(d, bc_box_d(vec3(w.x, q.y, w.z)));
	return min(d, bc_box_d(vec3(w.x, w.y, q.z)));
}

float bc_sdf_capped_torus(vec4 k0, vec4 k1, vec3 p)
{
	float big = k0.x, sn = k0.z, cs = k0.w;
	float u = abs(p.x);
	float d;
	if (cs * u > sn * p.z) {
		d = length(vec3(u - k1.x, p.y, p.z - k1.y));
	} else {
		d = length(vec2(length(vec2(u, p.z)) - big, p.y));
	}
	return d - k0.y;
}

float bc_sdf_solid_angle(vec4 k0, vec3 p)
{
	float ra = k0.x, sn = k0.y, cs = k0.z;
	float rho = length(p.xz);
	float l = length(vec2(rho, p.y)) - ra;
	float t = clamp(rho * sn + p.y * cs, 0.0, ra);
	float m = length(vec2(rho - sn * t, p.y - cs * t));
	if (cs * rho - sn * p.y > 0.0) {
		return m;
	}
	return l >= 0.0 ? l : max(l, -m);
}

float bc_sdf_pyramid(vec4 k0, vec4 k1, vec3 p)
{
	float b = k0.x, l = k0.z, nx = k0.w, ny = k1.x;
	float ax = abs(p.x), az = abs(p.z), y = p.y;
	if (az > ax) {
		float t = ax;
		ax = az;
		az = t;
	}
	float bx = max(ax - b, 0.0), bz = max(az - b, 0.0);
	float base2 = bx * bx + bz * bz + y * y;
	float dx = ax - b;
	float w = dx * nx + y * ny;
	float v = y * nx - dx * ny;
	float u = az;
	float face2;
	if (v >= 0.0 && u * l + v * b <= b * l) {
		face2 = 0.0;
	} else {
		float ub = max(u - b, 0.0);
		face2 = min(ub * ub + v * v,
			    bc_seg2(vec2(u, v), vec2(b, 0.0), vec2(-b, l), k1.y));
	}
	face2 += w * w;
	float d = sqrt(min(face2, base2));
	return (y > 0.0 && w < 0.0) ? -d : d;
}

float bc_sdf_tri_prism(vec4 k0, vec3 p)
{
	float r = k0.x, hb = k0.z;
	float ax = abs(p.x), y = p.y;
	float side2 = bc_seg2(vec2(ax, y), vec2(0.0, 2.0 * r),
			      vec2(hb, -3.0 * r), k0.w);
	float bx = max(ax - hb, 0.0), by = y + r;
	float d = sqrt(min(side2, bx * bx + by * by));
	bool inside = y > -r && 0.86602540378 * ax + 0.5 * y < r;
	return bc_extrude(inside ? -d : d, abs(p.z) - k0.y);
}

// ---- The later kinds (prim.c: sdf_new and its helpers).

float bc_sdf_cut_sphere(vec4 k0, vec3 p)
{
	float r = k0.x, h = k0.y, w = k0.z;
	float q = length(p.xz), l = length(vec2(q, p.y));
	float arc = w * p.y <= h * q ? abs(l - r) : length(vec2(q - w, p.y - h));
	float disc = length(vec2(max(q - w, 0.0), p.y - h));
	float d = min(arc, disc);
	return (l < r && p.y < h) ? -d : d;
}

float bc_sdf_cut_hollow_sphere(vec4 k0, vec3 p)
{
	float r = k0.x, h = k0.y, w = k0.z;
	float q = length(p.xz);
	float arc = w * p.y <= h * q ? abs(length(vec2(q, p.y)) - r)
				     : length(vec2(q - w, p.y - h));
	return arc - k0.w;
}

float bc_sdf_death_star(vec4 k0, vec4 k1, vec3 p)
{
	float ra = k0.x, rb = k0.y, d = k0.z, a = k0.w, b = k1.x;
	float q = length(p.yz), x = p.x;
	float la = length(vec2(x, q)), lb = length(vec2(x - d, q));
	float rim = length(vec2(x - a, q - b));
	float da = a * q - b * x >= 0.0 ? abs(la - ra) : rim;
	float db = (a - d) * q - b * (x - d) >= 0.0 ? abs(lb - rb) : rim;
	float dist = min(da, db);
	return (la < ra && lb > rb) ? -dist : dist;
}

// Axial coordinate, distance from the axis and half length about the
// segment with midpoint k0.xyz and half axis (k0.w, k1.x, k1.y).
vec3 bc_seg_frame(vec4 k0, vec4 k1, vec3 p)
{
	vec3 q = p - k0.xyz, e = vec3(k0.w, k1.x, k1.y);
	float l = length(e);
	float t = dot(q, e) / l;
	return vec3(t, sqrt(max(dot(q, q) - t * t, 0.0)), l);
}

float bc_cone2(float rho, float y, float h, float r1, float r2)
{
	float ex = r2 - r1, ey = 2.0 * h;
	return bc_sdf_cone(vec4(h, r1, r2, ex),
			   vec4(ey, 1.0 / (ex * ex + ey * ey), 0.0, 0.0),
			   vec3(rho, y, 0.0));
}

float bc_vesica2(float q, float y, float hl, float w)
{
	float c = 0.5 * (hl * hl - w * w) / w;
	y = abs(y);
	if (hl * q < c * (y - hl)) {
		return length(vec2(q, y - hl));
	}
	return length(vec2(q + c, y)) - (c + w);
}

float bc_sdf_rhombus(vec4 k0, vec4 k1, vec3 p)
{
	float la = k0.x, lb = k0.y;
	vec2 a = abs(p.xz);
	float d2 = sqrt(bc_seg2(a, vec2(la, 0.0), vec2(-la, lb), k1.x));
	float side = a.x * lb + a.y * la - la * lb;
	return bc_extrude((side < 0.0 ? -d2 : d2) - k0.w, abs(p.y) - k0.z);
}

float bc_polygon2(vec4 k0, vec2 p)
{
	float apo = k0.x, half_edge = k0.y;
	float b = mod(atan(p.x, p.y), k0.w) - k0.z;
	float l = length(p);
	float px = l * cos(b) - apo, py = l * abs(sin(b)) - half_edge;
	py += clamp(-py, 0.0, half_edge);
	float d = length(vec2(px, py));
	return px < 0.0 ? -d : d;
}

float bc_star2(vec4 k0, vec4 k1, vec2 p)
{
	float r = k0.x, ex = k0.w, ey = k1.x;
	float b = abs(mod(atan(p.x, p.y) + k0.y, k0.z) - k0.y);
	float l = length(p);
	float px = l * sin(b), py = l * cos(b);
	float d = sqrt(bc_seg2(vec2(px, py), vec2(0.0, r), vec2(ex, ey), k1.y));
	return ex * (py - r) - ey * px < 0.0 ? -d : d;
}

float bc_profile2(uint kind, vec4 k0, vec4 k1, vec2 p)
{
	switch (kind) {
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_REVOLVE_CIRCLE:
		return length(p) - k0.x;
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_REVOLVE_RECT: {
		vec2 d = abs(p) - k0.xy;
		return length(max(d, vec2(0.0))) + min(max(d.x, d.y), 0.0);
	}
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_REVOLVE_POLYGON:
		return bc_polygon2(k0, p);
	default:
		return bc_star2(k0, k1, p);
	}
}

float bc_sdf_new(uint kind, vec4 k0, vec4 k1, vec3 p)
{
	switch (kind) {
	case BC_PRIM_CUT_SPHERE:
		return bc_sdf_cut_sphere(k0, p);
	case BC_PRIM_CUT_HOLLOW_SPHERE:
		return bc_sdf_cut_hollow_sphere(k0, p);
	case BC_PRIM_DEATH_STAR:
		return bc_sdf_death_star(k0, k1, p);
	case BC_PRIM_ROUNDED_CYLINDER:
		return bc_extrude(length(p.xz) - k0.x, abs(p.y) - k0.y) - k0.z;
	case BC_PRIM_CAPPED_CYLINDER: {
		vec3 f = bc_seg_frame(k0, k1, p);
		return bc_extrude(f.y - k1.z, abs(f.x) - f.z);
	}
	case BC_PRIM_CAPPED_CONE: {
		vec3 f = bc_seg_frame(k0, k1, p);
		return bc_cone2(f.y, f.x, f.z, k1.z, k1.w);
	}
	case BC_PRIM_VESICA_SEGMENT: {
		vec3 f = bc_seg_frame(k0, k1, p);
		return bc_vesica2(f.y, f.x, f.z, k1.z);
	}
	case BC_PRIM_RHOMBUS:
		return bc_sdf_rhombus(k0, k1, p);
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_EXTRUDE_STAR:
		return bc_extrude(bc_profile2(kind, k0, k1, p.xy),
				  abs(p.z) - k1.w);
	case BC_PRIM_REVOLVE_CIRCLE:
	case BC_PRIM_REVOLVE_RECT:
	case BC_PRIM_REVOLVE_POLYGON:
	case BC_PRIM_REVOLVE_STAR: {
		float q = length(p.xz);
		return min(bc_profile2(kind, k0, k1, vec2(q - k1.w, p.y)),
			   bc_profile2(kind, k0, k1, vec2(-q - k1.w, p.y)));
	}
	default:
		return BC_INF;
	}
}

// bc_prim_sdf: field of primitive kind at the local point p.
float bc_prim_sdf(uint kind, vec4 k0, vec4 k1, vec3 p)
{
	switch (kind) {
	case BC_PRIM_SPHERE:
		return length(p) - k0.x;
	case BC_PRIM_BOX:
		return bc_box_d(abs(p) - k0.xyz) - k0.w;
	case BC_PRIM_CAPSULE: {
		vec3 q = p - k0.xyz;
		vec3 e = vec3(k0.w, k1.x, k1.y);
		float t = clamp(dot(q, e) * k1.w, 0.0, 1.0);
		return length(q - e * t) - k1.z;
	}
	case BC_PRIM_CYLINDER:
		return bc_extrude(length(p.xz) - k0.x, abs(p.y) - k0.y);
	case BC_PRIM_TORUS:
		return length(vec2(length(p.xz) - k0.x, p.y)) - k0.y;
	case BC_PRIM_CONE:
		return bc_sdf_cone(k0, k1, p);
	case BC_PRIM_ROUND_CONE:
		return bc_sdf_round_cone(k0, k1, p);
	case BC_PRIM_ELLIPSOID:
		return bc_sdf_ellipsoid(k0, k1, p);
	case BC_PRIM_HEX_PRISM:
		return bc_sdf_hex_prism(k0, p);
	case BC_PRIM_OCTAHEDRON:
		return bc_sdf_octahedron(k0, p);
	case BC_PRIM_BOX_FRAME:
		return bc_sdf_box_frame(k0, p);
	case BC_PRIM_CAPPED_TORUS:
		return bc_sdf_capped_torus(k0, k1, p);
	case BC_PRIM_LINK: {
		float qy = max(abs(p.y) - k0.x, 0.0);
		return length(vec2(length(vec2(p.x, qy)) - k0.y, p.z)) - k0.z;
	}
	case BC_PRIM_SOLID_ANGLE:
		return bc_sdf_solid_angle(k0, p);
	case BC_PRIM_PYRAMID:
		return bc_sdf_pyramid(k0, k1, p);
	case BC_PRIM_TRI_PRISM:
		return bc_sdf_tri_prism(k0, p);
	default:
		return bc_sdf_new(kind, k0, k1, p);
	}
}

// Vec4s of a leaf's record (blobtree.h's bc_prim_record_vec4): a sphere's
// is (centre, radius), every other kind's the rows and packed shape below.
uint bc_record_vec4(uint kind)
{
	return kind == BC_PRIM_SPHERE ? BC_SPHERE_RECORD_VEC4
				      : BC_PRIM_RECORD_VEC4;
}

// Field of the sphere whose record is r0 (centre, radius) at world point p.
float bc_sphere_record(vec4 r0, vec3 p)
{
	return length(p - r0.xyz) - r0.w;
}

// Field of the primitive (not a sphere) whose record is r0..r2
// (world-to-local rows) and k0, k1 (packed shape), at world point p.
float bc_prim_record(uint kind, vec4 r0, vec4 r1, vec4 r2, vec4 k0, vec4 k1,
		     vec3 p)
{
	vec3 q = vec3(dot(r0.xyz, p) + r0.w, dot(r1.xyz, p) + r1.w,
		      dot(r2.xyz, p) + r2.w);
	return bc_prim_sdf(kind, k0, k1, q);
}
