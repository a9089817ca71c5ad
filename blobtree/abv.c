/*
 * Geometry of augmented bounding volumes (ABVs): the three bounding shapes a
 * primitive may have (sphere, oriented box, capsule), once placed in world
 * space. Renderers use these queries to decide which primitives a tile, a
 * ray or an octree cell has to consider, so each answer must be
 * conservative: never "no" where the shape is present.
 *
 * The queries run in double. They are called once per ray or cell and
 * primitive, not in the field's inner loop, and double keeps the slab and
 * quadratic solutions free of the cancellation that float shows for rays
 * that start far away or graze a shape.
 */
#include "blobcast/blobtree.h"

#include <math.h>

static double dot3d(const double a[3], const double b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void load3(double out[3], const float in[3])
{
	out[0] = in[0];
	out[1] = in[1];
	out[2] = in[2];
}

void bc_abv_aabb(const struct bc_abv *abv, float lo[3], float hi[3])
{
	switch (abv->shape) {
	case BC_ABV_SPHERE:
		for (int k = 0; k < 3; k++) {
			lo[k] = abv->center[k] - abv->radius;
			hi[k] = abv->center[k] + abv->radius;
		}
		break;
	case BC_ABV_BOX:
		/* Each world axis sees the box's half extents through the
		 * absolute direction cosines of its axes. */
		for (int k = 0; k < 3; k++) {
			float e = 0.0f;
			for (int i = 0; i < 3; i++) {
				e += fabsf(abv->axis[i][k]) * abv->half[i];
			}
			lo[k] = abv->center[k] - e;
			hi[k] = abv->center[k] + e;
		}
		break;
	case BC_ABV_CAPSULE:
		for (int k = 0; k < 3; k++) {
			float a = abv->center[k], b = abv->end[k];
			lo[k] = (a < b ? a : b) - abv->radius;
			hi[k] = (a > b ? a : b) + abv->radius;
		}
		break;
	default:
		/* Not a shape: an empty box (lo > hi) that meets nothing. */
		for (int k = 0; k < 3; k++) {
			lo[k] = INFINITY;
			hi[k] = -INFINITY;
		}
		break;
	}
}

/* ---- Rays --------------------------------------------------------------- */

/* The parameter interval of a line inside a solid, empty when lo > hi. */
struct span {
	double lo, hi;
};

static const struct span no_span = {INFINITY, -INFINITY};

static bool span_empty(struct span s)
{
	return !(s.lo <= s.hi);
}

static struct span span_cut(struct span a, struct span b)
{
	struct span s = {a.lo > b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi};
	return s;
}

static struct span span_hull(struct span a, struct span b)
{
	if (span_empty(a)) {
		return b;
	}
	if (span_empty(b)) {
		return a;
	}
	struct span s = {a.lo < b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi};
	return s;
}

/* Roots of A t^2 + 2 B t + C = 0 with A > 0, by the stable form, or the
 * empty span when there are none. */
static struct span quad_span(double a, double b, double c)
{
	double disc = b * b - a * c;
	if (disc < 0.0) {
		return no_span;
	}
	double s = sqrt(disc);
	double q = -(b + (b < 0.0 ? -s : s));
	if (q == 0.0) {
		/* b == 0 and disc == 0: a double root at 0. */
		struct span z = {0.0, 0.0};
		return z;
	}
	double t0 = q / a, t1 = c / q;
	struct span r = {t0 < t1 ? t0 : t1, t0 < t1 ? t1 : t0};
	return r;
}

/* The line o + t d (d != 0) inside the ball (c, r). */
static struct span ball_span(const double c[3], double r, const double o[3],
                             const double d[3], double dd)
{
	double oc[3] = {o[0] - c[0], o[1] - c[1], o[2] - c[2]};
	double b = dot3d(oc, d) / dd;
	/* The offset from the closest point of the line, computed directly
	 * rather than as |oc|^2 - b^2 dd, which cancels for far origins. */
	double v[3] = {oc[0] - b * d[0], oc[1] - b * d[1], oc[2] - b * d[2]};
	double h2 = (r * r - dot3d(v, v)) / dd;
	if (h2 < 0.0) {
		return no_span;
	}
	double h = sqrt(h2);
	struct span s = {-b - h, -b + h};
	return s;
}

/* The slab lo <= s0 + t ds <= hi; a line parallel to it is wholly in or
 * out. Division by a tiny ds gives infinities, never NaN, since ds == 0 is
 * handled apart. */
static struct span slab_span(double s0, double ds, double lo, double hi)
{
	if (ds == 0.0) {
		if (s0 < lo || s0 > hi) {
			return no_span;
		}
		struct span all = {-INFINITY, INFINITY};
		return all;
	}
	double ta = (lo - s0) / ds, tb = (hi - s0) / ds;
	struct span s = {ta < tb ? ta : tb, ta < tb ? tb : ta};
	return s;
}

static struct span box_span(const struct bc_abv *abv, const double o[3],
                            const double d[3])
{
	struct span s = {-INFINITY, INFINITY};
	double oc[3] = {o[0] - abv->center[0], o[1] - abv->center[1],
	                o[2] - abv->center[2]};
	for (int i = 0; i < 3 && !span_empty(s); i++) {
		double ax[3];
		load3(ax, abv->axis[i]);
		double h = abv->half[i];
		s = span_cut(s, slab_span(dot3d(oc, ax), dot3d(d, ax), -h, h));
	}
	return s;
}

/*
 * A capsule is convex, so the line meets it in one interval: the hull of
 * its intervals in the two end balls and in the finite cylinder between
 * them (the infinite cylinder cut by the slab of the segment).
 */
static struct span capsule_span(const struct bc_abv *abv, const double o[3],
                                const double d[3], double dd)
{
	double a[3], b[3];
	double r = abv->radius;
	load3(a, abv->center);
	load3(b, abv->end);
	struct span s =
	    span_hull(ball_span(a, r, o, d, dd), ball_span(b, r, o, d, dd));
	double w[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
	double l = sqrt(dot3d(w, w));
	if (l == 0.0) {
		return s;
	}
	for (int k = 0; k < 3; k++) {
		w[k] /= l;
	}
	double oc[3] = {o[0] - a[0], o[1] - a[1], o[2] - a[2]};
	double ow = dot3d(oc, w), dw = dot3d(d, w);
	double dp[3], op[3];
	for (int k = 0; k < 3; k++) {
		dp[k] = d[k] - dw * w[k];
		op[k] = oc[k] - ow * w[k];
	}
	double qa = dot3d(dp, dp), qb = dot3d(op, dp),
	       qc = dot3d(op, op) - r * r;
	struct span cyl;
	if (qa == 0.0) {
		/* Parallel to the axis: inside the tube everywhere or
		 * nowhere. */
		cyl.lo = qc <= 0.0 ? -INFINITY : INFINITY;
		cyl.hi = qc <= 0.0 ? INFINITY : -INFINITY;
	} else {
		cyl = quad_span(qa, qb, qc);
	}
	if (!span_empty(cyl)) {
		cyl = span_cut(cyl, slab_span(ow, dw, 0.0, l));
	}
	return span_hull(s, cyl);
}

bool bc_abv_ray(const struct bc_abv *abv, const float of[3], const float df[3],
                float *t0, float *t1)
{
	double o[3], d[3], dd;
	struct span s;
	*t0 = 0.0f;
	*t1 = 0.0f;
	load3(o, of);
	load3(d, df);
	dd = dot3d(d, d);
	if (!(dd > 0.0)) {
		return false; /* no direction, no ray */
	}
	switch (abv->shape) {
	case BC_ABV_SPHERE: {
		double c[3];
		load3(c, abv->center);
		s = ball_span(c, abv->radius, o, d, dd);
		break;
	}
	case BC_ABV_BOX:
		s = box_span(abv, o, d);
		break;
	case BC_ABV_CAPSULE:
		s = capsule_span(abv, o, d, dd);
		break;
	default:
		return false;
	}
	/* The ray is t >= 0: a shape wholly behind the origin is a miss. */
	if (span_empty(s) || s.hi < 0.0) {
		return false;
	}
	/* Round outwards so that float callers never clip a hit away. */
	*t0 = nextafterf((float)s.lo, -INFINITY);
	*t1 = nextafterf((float)s.hi, INFINITY);
	return true;
}

/* ---- Boxes -------------------------------------------------------------- */

static bool aabbs_meet(const float alo[3], const float ahi[3],
                       const float blo[3], const float bhi[3])
{
	for (int k = 0; k < 3; k++) {
		if (ahi[k] < blo[k] || alo[k] > bhi[k]) {
			return false;
		}
	}
	return true;
}

/* Separating axis test on the box's three axes (the world axes are the
 * caller's AABB test). Skipping the nine edge-cross axes keeps it
 * conservative. */
static bool obb_axes_meet(const struct bc_abv *abv, const float lo[3],
                          const float hi[3])
{
	double c[3], e[3];
	for (int k = 0; k < 3; k++) {
		c[k] = 0.5 * ((double)lo[k] + (double)hi[k]) - abv->center[k];
		e[k] = 0.5 * ((double)hi[k] - (double)lo[k]);
	}
	for (int i = 0; i < 3; i++) {
		double ax[3];
		load3(ax, abv->axis[i]);
		double reach = fabs(ax[0]) * e[0] + fabs(ax[1]) * e[1] +
		               fabs(ax[2]) * e[2];
		if (fabs(dot3d(c, ax)) > (double)abv->half[i] + reach) {
			return false;
		}
	}
	return true;
}

bool bc_abv_meets_box(const struct bc_abv *abv, const float lo[3],
                      const float hi[3])
{
	float alo[3], ahi[3];
	bc_abv_aabb(abv, alo, ahi);
	if (!aabbs_meet(alo, ahi, lo, hi)) {
		return false;
	}
	switch (abv->shape) {
	case BC_ABV_SPHERE: {
		/* Exact: the squared distance from the centre to the box. */
		double d2 = 0.0, r = abv->radius;
		for (int k = 0; k < 3; k++) {
			double c = abv->center[k], e = 0.0;
			if (c < lo[k]) {
				e = (double)lo[k] - c;
			} else if (c > hi[k]) {
				e = c - (double)hi[k];
			}
			d2 += e * e;
		}
		return d2 <= r * r;
	}
	case BC_ABV_BOX:
		return obb_axes_meet(abv, lo, hi);
	case BC_ABV_CAPSULE: {
		/* The capsule meets the box when its segment comes within the
		 * radius, hence when the segment meets the box grown by the
		 * radius on every side (a superset of the rounded box). */
		struct span s = {0.0, 1.0};
		double r = abv->radius;
		for (int k = 0; k < 3 && !span_empty(s); k++) {
			double a = abv->center[k];
			double d = (double)abv->end[k] - a;
			s = span_cut(s, slab_span(a, d, (double)lo[k] - r,
			                          (double)hi[k] + r));
		}
		return !span_empty(s);
	}
	default:
		return false;
	}
}
