// Rays against the three ABV shapes (sphere, oriented box, capsule), for
// the A-buffer: the interval of a ray inside a primitive's ABV. The CPU's
// bc_abv_ray (blobtree/abv.c) works in double; in float the same stable
// formulations are used (the offset from the closest point instead of
// |oc|^2 - b^2, the quadratic's stable root) and the caller widens the
// result, because an interval that is too short would clip a surface away
// while one that is a little long only costs a step.

struct bc_span {
	float lo, hi;
};

bool bc_span_empty(bc_span s)
{
	return !(s.lo <= s.hi);
}

bc_span bc_span_none()
{
	return bc_span(BC_INF, -BC_INF);
}

bc_span bc_span_hull(bc_span a, bc_span b)
{
	if (bc_span_empty(a)) {
		return b;
	}
	if (bc_span_empty(b)) {
		return a;
	}
	return bc_span(min(a.lo, b.lo), max(a.hi, b.hi));
}

// The line o + t d (d unit) inside the ball (c, r).
bc_span bc_ball_span(vec3 c, float r, vec3 o, vec3 d)
{
	vec3 oc = o - c;
	float b = dot(oc, d);
	vec3 v = oc - b * d;
	float h2 = r * r - dot(v, v);
	if (h2 < 0.0) {
		return bc_span_none();
	}
	float h = sqrt(h2);
	return bc_span(-b - h, -b + h);
}

// The slab lo <= s0 + t ds <= hi.
bc_span bc_slab_span(float s0, float ds, float lo, float hi)
{
	if (ds == 0.0) {
		if (s0 < lo || s0 > hi) {
			return bc_span_none();
		}
		return bc_span(-BC_INF, BC_INF);
	}
	float ta = (lo - s0) / ds, tb = (hi - s0) / ds;
	return bc_span(min(ta, tb), max(ta, tb));
}

bc_span bc_cut(bc_span a, bc_span b)
{
	return bc_span(max(a.lo, b.lo), min(a.hi, b.hi));
}

bc_span bc_box_span(bc_abv_rec a, vec3 o, vec3 d)
{
	vec3 oc = o - a.a.xyz;
	bc_span s = bc_slab_span(dot(oc, a.ax0.xyz), dot(d, a.ax0.xyz),
				 -a.b.x, a.b.x);
	s = bc_cut(s, bc_slab_span(dot(oc, a.ax1.xyz), dot(d, a.ax1.xyz),
				   -a.b.y, a.b.y));
	return bc_cut(s, bc_slab_span(dot(oc, a.ax2.xyz), dot(d, a.ax2.xyz),
				      -a.b.z, a.b.z));
}

// A capsule is convex: the hull of its end balls' and its finite
// cylinder's intervals.
bc_span bc_capsule_span(bc_abv_rec a, vec3 o, vec3 d)
{
	float r = a.hi.w;
	vec3 pa = a.a.xyz, pb = a.b.xyz;
	bc_span s = bc_span_hull(bc_ball_span(pa, r, o, d),
				 bc_ball_span(pb, r, o, d));
	vec3 w = pb - pa;
	float l = length(w);
	if (l == 0.0) {
		return s;
	}
	w /= l;
	vec3 oc = o - pa;
	float ow = dot(oc, w), dw = dot(d, w);
	vec3 dp = d - dw * w, op = oc - ow * w;
	float qa = dot(dp, dp), qb = dot(op, dp), qc = dot(op, op) - r * r;
	bc_span cyl;
	if (qa == 0.0) {
		cyl = qc <= 0.0 ? bc_span(-BC_INF, BC_INF) : bc_span_none();
	} else {
		float disc = qb * qb - qa * qc;
		if (disc < 0.0) {
			cyl = bc_span_none();
		} else {
			float sq = sqrt(disc);
			float q = -(qb + (qb < 0.0 ? -sq : sq));
			if (q == 0.0) {
				cyl = bc_span(0.0, 0.0);
			} else {
				float t0 = q / qa, t1 = qc / q;
				cyl = bc_span(min(t0, t1), max(t0, t1));
			}
		}
	}
	if (!bc_span_empty(cyl)) {
		cyl = bc_cut(cyl, bc_slab_span(ow, dw, 0.0, l));
	}
	return bc_span_hull(s, cyl);
}

// The interval of the ray o + t d (d unit) inside ABV a, empty on a miss.
bc_span bc_abv_span(bc_abv_rec a, vec3 o, vec3 d)
{
	uint shape = uint(a.lo.w + 0.5);
	if (shape == BC_ABV_SPHERE) {
		return bc_ball_span(a.a.xyz, a.hi.w, o, d);
	}
	if (shape == BC_ABV_BOX) {
		return bc_box_span(a, o, d);
	}
	if (shape == BC_ABV_CAPSULE) {
		return bc_capsule_span(a, o, d);
	}
	return bc_span_none();
}
