/*
 * The catalogue's later kinds (cut and carved spheres, solids between two
 * points, the rhombus, extruded and revolved profiles) against definitions
 * written here independently of blobtree/prim.c: each solid as a membership
 * test from its geometric description (a ball less another, a lens as the
 * intersection of two balls, polygons as vertex lists), and the profiles'
 * distances by brute force over their edges. At random points around each
 * shape the field's sign matches membership, and where a brute-force
 * distance exists the field equals it; everywhere the field never exceeds
 * the distance to the independent solid's boundary found by bisection.
 */
#include "blobcast/blobtree.h"

#include <math.h>
#include <string.h>

#include "test.h"

static const double PI = 3.14159265358979324;

static uint64_t rng_state = 1;

static double rnd(double lo, double hi)
{
	rng_state ^= rng_state >> 12;
	rng_state ^= rng_state << 25;
	rng_state ^= rng_state >> 27;
	return lo + (hi - lo) *
	                (double)((rng_state * 0x2545f4914f6cdd1dull) >> 11) /
	                9007199254740992.0;
}

struct prim {
	struct bc_prim_data d;
	float k[BC_PRIM_PACKED];
	float lo[3], hi[3]; /* local AABB of the bound */
};

static void prim_make(struct prim *p, enum bc_prim kind, const float *v, int n)
{
	struct bc_errinfo ei = {0};
	struct bc_abv b;
	bc_prim_data_init(&p->d, kind);
	for (int i = 0; i < n; i++) {
		p->d.params[i] = v[i];
	}
	REQUIRE(bc_prim_validate(&p->d, &ei) == 0);
	bc_prim_pack(&p->d, p->k);
	bc_prim_bound(&p->d, &b);
	bc_abv_aabb(&b, p->lo, p->hi);
}

static double field(const struct prim *p, const double q[3])
{
	return bc_prim_sdf(p->d.kind, p->k, (float)q[0], (float)q[1],
	                   (float)q[2]);
}

/* ---- Independent definitions --------------------------------------------- */

static double len3(double x, double y, double z)
{
	return sqrt(x * x + y * y + z * z);
}

/* Polygon vertices of a profile (a vertex or tip on +y, angles clockwise
 * from +y towards +x); returns the count. */
static int profile_vertices(enum bc_prim kind, const float *v, double (*out)[2])
{
	int n = 0;
	switch (kind) {
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_REVOLVE_RECT:
		out[0][0] = v[0], out[0][1] = v[1];
		out[1][0] = -v[0], out[1][1] = v[1];
		out[2][0] = -v[0], out[2][1] = -v[1];
		out[3][0] = v[0], out[3][1] = -v[1];
		return 4;
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_REVOLVE_POLYGON:
		n = (int)v[1];
		for (int i = 0; i < n; i++) {
			double a = 2.0 * PI * i / n;
			out[i][0] = v[0] * sin(a);
			out[i][1] = v[0] * cos(a);
		}
		return n;
	default: /* star */
		n = (int)v[1];
		for (int i = 0; i < 2 * n; i++) {
			double a = PI * i / n, r = i % 2 ? v[0] * v[2] : v[0];
			out[i][0] = r * sin(a);
			out[i][1] = r * cos(a);
		}
		return 2 * n;
	}
}

/* Signed distance to a polygon by brute force: the nearest edge, signed by
 * the crossing number. */
static double poly_sd(const double (*vt)[2], int n, double x, double y)
{
	double best = INFINITY;
	bool in = false;
	for (int i = 0, j = n - 1; i < n; j = i++) {
		double ax = vt[j][0], ay = vt[j][1], ex = vt[i][0] - ax,
		       ey = vt[i][1] - ay;
		double t =
		    ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey);
		t = t < 0 ? 0 : (t > 1 ? 1 : t);
		double dx = x - ax - t * ex, dy = y - ay - t * ey;
		best = fmin(best, sqrt(dx * dx + dy * dy));
		if ((vt[i][1] > y) != (vt[j][1] > y) &&
		    x < ax + (y - ay) * ex / ey) {
			in = !in;
		}
	}
	return in ? -best : best;
}

/* The profile's signed distance, brute force (circles in closed form). */
static double profile_sd(enum bc_prim kind, const float *v, double x, double y)
{
	double vt[520][2];
	if (kind == BC_PRIM_EXTRUDE_CIRCLE || kind == BC_PRIM_REVOLVE_CIRCLE) {
		return sqrt(x * x + y * y) - v[0];
	}
	return poly_sd(vt, profile_vertices(kind, v, vt), x, y);
}

/* The exact signed distance where this file can write one independently:
 * extrusions (2D distance and slab combined as the Euclidean norm of the
 * outside parts) and revolutions clear of the axis. NAN elsewhere. */
static double reference_sd(const struct prim *p, const double q[3])
{
	const float *v = p->d.params;
	enum bc_prim k = p->d.kind;
	const struct bc_prim_info *info = bc_prim_info(k);
	float last = v[info->params[info->nparams - 1].offset];
	if (k >= BC_PRIM_EXTRUDE_CIRCLE && k <= BC_PRIM_EXTRUDE_STAR) {
		double a = profile_sd(k, v, q[0], q[1]);
		double b = fabs(q[2]) - last;
		if (a <= 0 && b <= 0) {
			return fmax(a, b);
		}
		return sqrt(fmax(a, 0) * fmax(a, 0) + fmax(b, 0) * fmax(b, 0));
	}
	if (k >= BC_PRIM_REVOLVE_CIRCLE && k <= BC_PRIM_REVOLVE_STAR) {
		double rho = sqrt(q[0] * q[0] + q[2] * q[2]);
		return profile_sd(k, v, rho - last, q[1]);
	}
	return NAN;
}

/* Membership in the solid, from its description. */
static bool inside(const struct prim *p, const double q[3])
{
	const float *v = p->d.params;
	double x = q[0], y = q[1], z = q[2];
	switch (p->d.kind) {
	case BC_PRIM_CUT_SPHERE:
		return len3(x, y, z) < v[0] && y < v[1];
	case BC_PRIM_CUT_HOLLOW_SPHERE: {
		/* Within t of the sphere's part below the cut plane: the
		 * nearest point of that cap, by dense sampling of its arc in
		 * the point's meridian. */
		double rho = sqrt(x * x + z * z), best = INFINITY;
		double top = asin(v[1] / v[0]);
		for (int i = 0; i <= 4000; i++) {
			double a = -PI / 2 + (top + PI / 2) * i / 4000.0;
			double ax = v[0] * cos(a) - rho, ay = v[0] * sin(a) - y;
			best = fmin(best, ax * ax + ay * ay);
		}
		return sqrt(best) < v[2];
	}
	case BC_PRIM_DEATH_STAR:
		return len3(x, y, z) < v[0] && len3(x - v[2], y, z) > v[1];
	case BC_PRIM_ROUNDED_CYLINDER: {
		/* Within the rounding of the inner cylinder. */
		double r = v[1], rho = sqrt(x * x + z * z);
		double dr = fmax(rho - (v[0] - r), 0);
		double dy = fmax(fabs(y) - (v[2] - r), 0);
		return sqrt(dr * dr + dy * dy) < r;
	}
	case BC_PRIM_CAPPED_CYLINDER:
	case BC_PRIM_CAPPED_CONE:
	case BC_PRIM_VESICA_SEGMENT: {
		double e[3], w[3], l2 = 0, t = 0, r2 = 0;
		for (int i = 0; i < 3; i++) {
			e[i] = (double)v[3 + i] - v[i];
			w[i] = q[i] - v[i];
			l2 += e[i] * e[i];
			t += w[i] * e[i];
		}
		t /= l2;
		for (int i = 0; i < 3; i++) {
			double c = w[i] - t * e[i];
			r2 += c * c;
		}
		if (p->d.kind == BC_PRIM_CAPPED_CYLINDER) {
			return t > 0 && t < 1 && r2 < (double)v[6] * v[6];
		}
		if (p->d.kind == BC_PRIM_CAPPED_CONE) {
			double r = v[6] + t * ((double)v[7] - v[6]);
			return t > 0 && t < 1 && sqrt(r2) < r;
		}
		{
			/* A lens: the points of the meridian disc (radius
			 * R = c + w, centre c off the axis on the far side)
			 * that pass through both tips. */
			double hl = 0.5 * sqrt(l2), wd = v[6];
			double c = (hl * hl - wd * wd) / (2 * wd);
			double ax = (t - 0.5) * 2 * hl, rho = sqrt(r2);
			return (rho + c) * (rho + c) + ax * ax <
			       (c + wd) * (c + wd);
		}
	}
	case BC_PRIM_RHOMBUS: {
		double la = v[0], lb = v[1], h = v[2], r = v[3];
		/* Within r of the sharp rhombus, in the slab. */
		double vt[4][2] = {{la, 0}, {0, lb}, {-la, 0}, {0, -lb}};
		return fabs(y) < h && poly_sd(vt, 4, x, z) < r;
	}
	default: {
		double d = reference_sd(p, q);
		return d < 0;
	}
	}
}

/* The distance to the independent solid's boundary, from above: the
 * nearest boundary point found by bisecting the membership along many
 * directions around q (an upper bound of the true distance). */
static double boundary_upper(const struct prim *p, const double q[3],
                             double reach)
{
	bool in0 = inside(p, q);
	double best = INFINITY;
	for (int i = 0; i < 120; i++) {
		double d[3], n, a = 0, b = reach;
		double e[3];
		do {
			for (int j = 0; j < 3; j++) {
				d[j] = rnd(-1, 1);
			}
			n = len3(d[0], d[1], d[2]);
		} while (n < 0.1 || n > 1);
		for (int j = 0; j < 3; j++) {
			d[j] /= n;
			e[j] = q[j] + b * d[j];
		}
		if (inside(p, e) == in0) {
			continue;
		}
		for (int it = 0; it < 40; it++) {
			double m = 0.5 * (a + b), c[3];
			for (int j = 0; j < 3; j++) {
				c[j] = q[j] + m * d[j];
			}
			if (inside(p, c) == in0) {
				a = m;
			} else {
				b = m;
			}
		}
		best = fmin(best, b);
	}
	return best;
}

struct kind_case {
	enum bc_prim kind;
	float v[8];
	int n;
};

static const struct kind_case cases[] = {
    {BC_PRIM_CUT_SPHERE, {1.0f, 0.4f}, 2},
    {BC_PRIM_CUT_SPHERE, {0.8f, -0.5f}, 2},
    {BC_PRIM_CUT_HOLLOW_SPHERE, {1.0f, 0.3f, 0.1f}, 3},
    {BC_PRIM_CUT_HOLLOW_SPHERE, {0.9f, -0.6f, 0.05f}, 3},
    {BC_PRIM_DEATH_STAR, {1.0f, 0.8f, 1.1f}, 3},
    {BC_PRIM_DEATH_STAR, {1.0f, 1.3f, 0.9f}, 3},
    {BC_PRIM_ROUNDED_CYLINDER, {0.6f, 0.2f, 0.9f}, 3},
    {BC_PRIM_CAPPED_CYLINDER, {-0.3f, -0.5f, 0.1f, 0.4f, 0.6f, -0.2f, 0.3f}, 7},
    {BC_PRIM_CAPPED_CONE,
     {-0.3f, -0.5f, 0.1f, 0.4f, 0.6f, -0.2f, 0.5f, 0.1f},
     8},
    {BC_PRIM_CAPPED_CONE,
     {0.2f, 0.7f, 0.0f, -0.1f, -0.6f, 0.3f, 0.0f, 0.4f},
     8},
    {BC_PRIM_RHOMBUS, {1.0f, 0.5f, 0.2f, 0.1f}, 4},
    {BC_PRIM_RHOMBUS, {0.4f, 0.9f, 0.5f, 0.0f}, 4},
    {BC_PRIM_VESICA_SEGMENT, {-0.5f, 0.2f, 0.1f, 0.6f, -0.3f, 0.2f, 0.25f}, 7},
    {BC_PRIM_EXTRUDE_CIRCLE, {0.5f, 0.3f}, 2},
    {BC_PRIM_EXTRUDE_RECT, {0.6f, 0.3f, 0.4f}, 3},
    {BC_PRIM_EXTRUDE_POLYGON, {0.6f, 5.0f, 0.3f}, 3},
    {BC_PRIM_EXTRUDE_POLYGON, {0.5f, 3.0f, 0.6f}, 3},
    {BC_PRIM_EXTRUDE_STAR, {0.7f, 5.0f, 0.45f, 0.2f}, 4},
    {BC_PRIM_EXTRUDE_STAR, {0.6f, 2.0f, 0.3f, 0.3f}, 4},
    {BC_PRIM_REVOLVE_CIRCLE, {0.25f, 0.7f}, 2},
    {BC_PRIM_REVOLVE_RECT, {0.2f, 0.4f, 0.6f}, 3},
    {BC_PRIM_REVOLVE_POLYGON, {0.3f, 6.0f, 0.7f}, 3},
    {BC_PRIM_REVOLVE_STAR, {0.35f, 5.0f, 0.5f, 0.8f}, 4},
    {BC_PRIM_REVOLVE_STAR, {0.4f, 7.0f, 0.7f, 0.4f}, 4},
};

/* At random points around each case: the sign is membership's, |f| never
 * exceeds the distance to the boundary, and where a brute-force distance
 * exists f equals it. */
static void catalogue_matches_independent_definitions(void)
{
	bool seen[BC_PRIM_COUNT] = {0};
	rng_state = 0x1234567;
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		struct prim p;
		int sign_bad = 0, over = 0, exact_bad = 0, nexact = 0;
		double worst = 0;
		prim_make(&p, cases[c].kind, cases[c].v, cases[c].n);
		seen[cases[c].kind] = true;
		for (int i = 0; i < 600; i++) {
			double q[3], f, ref;
			for (int j = 0; j < 3; j++) {
				double m = 0.3 * (p.hi[j] - p.lo[j]) + 0.1;
				q[j] = rnd(p.lo[j] - m, p.hi[j] + m);
			}
			f = field(&p, q);
			if (fabs(f) > 2e-4 && (f < 0) != inside(&p, q)) {
				sign_bad++;
			}
			if (i % 6 == 0 && fabs(f) > 1e-3) {
				double up = boundary_upper(&p, q, 4.0);
				if (fabs(f) > up + 1e-4) {
					over++;
				}
			}
			ref = reference_sd(&p, q);
			if (!isnan(ref)) {
				nexact++;
				worst = fmax(worst, fabs(ref - f));
				exact_bad += fabs(ref - f) > 2e-5;
			}
		}
		printf("  %-18s sign wrong %d, |f| > boundary %d, exact %d of "
		       "%d off (worst %.1e)\n",
		       bc_prim_info(cases[c].kind)->name, sign_bad, over,
		       exact_bad, nexact, worst);
		CHECK_EQ_INT(sign_bad, 0);
		CHECK_EQ_INT(over, 0);
		CHECK_EQ_INT(exact_bad, 0);
	}
	for (int k = BC_PRIM_CUT_SPHERE; k < BC_PRIM_COUNT; k++) {
		CHECK(seen[k]);
	}
}

/* The bounding shape holds the solid: no point of it lies outside the
 * local AABB of the bound, and the field at the box's faces is >= 0. */
static void catalogue_bounds_hold_the_solid(void)
{
	rng_state = 0x7654321;
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		struct prim p;
		int bad = 0;
		prim_make(&p, cases[c].kind, cases[c].v, cases[c].n);
		for (int i = 0; i < 20000; i++) {
			double q[3];
			for (int j = 0; j < 3; j++) {
				double m = 0.5 * (p.hi[j] - p.lo[j]);
				q[j] = rnd(p.lo[j] - m, p.hi[j] + m);
			}
			if (!inside(&p, q)) {
				continue;
			}
			for (int j = 0; j < 3; j++) {
				bad += q[j] < p.lo[j] - 1e-5 ||
				       q[j] > p.hi[j] + 1e-5;
			}
		}
		if (bad) {
			printf("  %s: %d points outside the bound\n",
			       bc_prim_info(cases[c].kind)->name, bad);
		}
		CHECK_EQ_INT(bad, 0);
	}
}

static const struct bc_test tests[] = {
    {"catalogue_matches_independent_definitions",
     catalogue_matches_independent_definitions},
    {"catalogue_bounds_hold_the_solid", catalogue_bounds_hold_the_solid},
};

BC_TEST_MAIN(tests)
