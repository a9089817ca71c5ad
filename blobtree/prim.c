/*
 * Primitives of the blobtree: the table that names every kind and lays out
 * its parameters, the defaults and validation rules, the packing of shape
 * parameters into the evaluator's record, the distance fields themselves and
 * each kind's tight local bounding shape.
 *
 * Every field is evaluated in the primitive's local frame (the caller has
 * applied the world-to-local map already). Each one is written from the
 * closed-form geometry of its shape: symmetric shapes are folded into one
 * chamber of their symmetry group, where the nearest part of the surface is
 * a known segment, triangle or arc; solids of revolution are reduced to their
 * 2D profile in (distance from the axis, height). docs/primitives.md lists
 * the parameters, defaults, exactness and bounding shape of each kind.
 *
 * bc_prim_sdf is the innermost loop of every renderer: it switches on the
 * kind, allocates nothing and stays in float. Anything that depends on the
 * parameters only (sines, reciprocals, slant lengths) is computed once in
 * bc_prim_pack.
 */
#include "blobcast/blobtree.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ---- Parameter tables --------------------------------------------------- */

#define POS BC_PARAM_POSITIVE
#define NONNEG BC_PARAM_NONNEG
#define OPT BC_PARAM_OPTIONAL

/*
 * Required parameters carry a default too: bc_prim_data_init uses it, so a
 * freshly initialized primitive is a valid unit-sized shape rather than a
 * degenerate one. Readers of scene files still insist on every parameter
 * that is not BC_PARAM_OPTIONAL.
 */
static const struct bc_param_desc p_sphere[] = {
    {"radius", 0, 1, POS, 1.0f},
};
static const struct bc_param_desc p_box[] = {
    {"half_extents", 0, 3, POS, 1.0f},
    {"round", 3, 1, OPT | NONNEG, 0.0f},
};
static const struct bc_param_desc p_capsule[] = {
    {"a", 0, 3, 0, -0.5f},
    {"b", 3, 3, 0, 0.5f},
    {"radius", 6, 1, POS, 0.5f},
};
static const struct bc_param_desc p_cylinder[] = {
    {"radius", 0, 1, POS, 0.5f},
    {"half_height", 1, 1, POS, 1.0f},
};
static const struct bc_param_desc p_torus[] = {
    {"major", 0, 1, POS, 1.0f},
    {"minor", 1, 1, POS, 0.25f},
};
static const struct bc_param_desc p_cone[] = {
    {"half_height", 0, 1, POS, 1.0f},
    {"radius_bottom", 1, 1, NONNEG, 1.0f},
    {"radius_top", 2, 1, NONNEG, 0.0f},
};
static const struct bc_param_desc p_round_cone[] = {
    {"a", 0, 3, 0, -0.5f},
    {"b", 3, 3, 0, 0.5f},
    {"radius_a", 6, 1, NONNEG, 0.5f},
    {"radius_b", 7, 1, NONNEG, 0.25f},
};
static const struct bc_param_desc p_ellipsoid[] = {
    {"radii", 0, 3, POS, 1.0f},
};
static const struct bc_param_desc p_hex_prism[] = {
    {"radius", 0, 1, POS, 1.0f},
    {"half_depth", 1, 1, POS, 0.5f},
};
static const struct bc_param_desc p_octahedron[] = {
    {"size", 0, 1, POS, 1.0f},
};
static const struct bc_param_desc p_box_frame[] = {
    {"half_extents", 0, 3, POS, 1.0f},
    {"thickness", 3, 1, POS, 0.1f},
};
static const struct bc_param_desc p_capped_torus[] = {
    {"major", 0, 1, POS, 1.0f},
    {"minor", 1, 1, POS, 0.25f},
    {"angle_deg", 2, 1, 0, 90.0f},
};
static const struct bc_param_desc p_link[] = {
    {"half_length", 0, 1, NONNEG, 0.5f},
    {"major", 1, 1, POS, 0.5f},
    {"minor", 2, 1, POS, 0.15f},
};
static const struct bc_param_desc p_solid_angle[] = {
    {"radius", 0, 1, POS, 1.0f},
    {"angle_deg", 1, 1, 0, 30.0f},
};
static const struct bc_param_desc p_pyramid[] = {
    {"half_base", 0, 1, POS, 1.0f},
    {"height", 1, 1, POS, 1.0f},
};
static const struct bc_param_desc p_tri_prism[] = {
    {"radius", 0, 1, POS, 0.5f},
    {"half_depth", 1, 1, POS, 0.5f},
};
static const struct bc_param_desc p_cut_sphere[] = {
    {"radius", 0, 1, POS, 1.0f},
    {"cut_height", 1, 1, 0, 0.5f},
};
static const struct bc_param_desc p_cut_hollow_sphere[] = {
    {"radius", 0, 1, POS, 1.0f},
    {"cut_height", 1, 1, 0, 0.5f},
    {"thickness", 2, 1, POS, 0.1f},
};
static const struct bc_param_desc p_death_star[] = {
    {"ra", 0, 1, POS, 1.0f},
    {"rb", 1, 1, POS, 0.8f},
    {"d", 2, 1, POS, 1.0f},
};
static const struct bc_param_desc p_rounded_cylinder[] = {
    {"radius", 0, 1, POS, 0.5f},
    {"round", 1, 1, NONNEG, 0.1f},
    {"half_height", 2, 1, POS, 1.0f},
};
static const struct bc_param_desc p_capped_cylinder[] = {
    {"a", 0, 3, 0, -0.5f},
    {"b", 3, 3, 0, 0.5f},
    {"radius", 6, 1, POS, 0.5f},
};
static const struct bc_param_desc p_capped_cone[] = {
    {"a", 0, 3, 0, -0.5f},
    {"b", 3, 3, 0, 0.5f},
    {"ra", 6, 1, NONNEG, 0.5f},
    {"rb", 7, 1, NONNEG, 0.25f},
};
static const struct bc_param_desc p_rhombus[] = {
    {"la", 0, 1, POS, 1.0f},
    {"lb", 1, 1, POS, 0.5f},
    {"half_height", 2, 1, POS, 0.2f},
    {"round", 3, 1, OPT | NONNEG, 0.0f},
};
static const struct bc_param_desc p_vesica_segment[] = {
    {"a", 0, 3, 0, -0.5f},
    {"b", 3, 3, 0, 0.5f},
    {"w", 6, 1, POS, 0.3f},
};
static const struct bc_param_desc p_extrude_circle[] = {
    {"radius", 0, 1, POS, 0.5f},
    {"half_depth", 1, 1, POS, 0.5f},
};
static const struct bc_param_desc p_extrude_rect[] = {
    {"half_width", 0, 1, POS, 0.5f},
    {"half_height", 1, 1, POS, 0.25f},
    {"half_depth", 2, 1, POS, 0.5f},
};
static const struct bc_param_desc p_extrude_polygon[] = {
    {"radius", 0, 1, POS, 0.5f},
    {"sides", 1, 1, POS, 5.0f},
    {"half_depth", 2, 1, POS, 0.5f},
};
static const struct bc_param_desc p_extrude_star[] = {
    {"radius", 0, 1, POS, 0.5f},
    {"points", 1, 1, POS, 5.0f},
    {"inner_ratio", 2, 1, POS, 0.5f},
    {"half_depth", 3, 1, POS, 0.25f},
};
static const struct bc_param_desc p_revolve_circle[] = {
    {"radius", 0, 1, POS, 0.25f},
    {"offset", 1, 1, NONNEG, 0.75f},
};
static const struct bc_param_desc p_revolve_rect[] = {
    {"half_width", 0, 1, POS, 0.25f},
    {"half_height", 1, 1, POS, 0.5f},
    {"offset", 2, 1, NONNEG, 0.75f},
};
static const struct bc_param_desc p_revolve_polygon[] = {
    {"radius", 0, 1, POS, 0.3f},
    {"sides", 1, 1, POS, 6.0f},
    {"offset", 2, 1, NONNEG, 0.75f},
};
static const struct bc_param_desc p_revolve_star[] = {
    {"radius", 0, 1, POS, 0.35f},
    {"points", 1, 1, POS, 5.0f},
    {"inner_ratio", 2, 1, POS, 0.5f},
    {"offset", 3, 1, NONNEG, 0.75f},
};

#undef POS
#undef NONNEG
#undef OPT

#define DESC(name, tab, exact)                                                 \
	{                                                                      \
		name, (uint8_t)(sizeof(tab) / sizeof(tab[0])), tab, exact      \
	}

/*
 * exact: the field is the Euclidean signed distance outside the solid, and
 * inside too except where docs/primitives.md notes otherwise (tubes that
 * overlap themselves, the box frame's concave edges: there it is a bound
 * with the right sign). The ellipsoid is a bound everywhere.
 */
static const struct bc_prim_info prim_table[BC_PRIM_COUNT] = {
    [BC_PRIM_SPHERE] = DESC("sphere", p_sphere, true),
    [BC_PRIM_BOX] = DESC("box", p_box, true),
    [BC_PRIM_CAPSULE] = DESC("capsule", p_capsule, true),
    [BC_PRIM_CYLINDER] = DESC("cylinder", p_cylinder, true),
    [BC_PRIM_TORUS] = DESC("torus", p_torus, true),
    [BC_PRIM_CONE] = DESC("cone", p_cone, true),
    [BC_PRIM_ROUND_CONE] = DESC("round_cone", p_round_cone, true),
    [BC_PRIM_ELLIPSOID] = DESC("ellipsoid", p_ellipsoid, false),
    [BC_PRIM_HEX_PRISM] = DESC("hex_prism", p_hex_prism, true),
    [BC_PRIM_OCTAHEDRON] = DESC("octahedron", p_octahedron, true),
    [BC_PRIM_BOX_FRAME] = DESC("box_frame", p_box_frame, true),
    [BC_PRIM_CAPPED_TORUS] = DESC("capped_torus", p_capped_torus, true),
    [BC_PRIM_LINK] = DESC("link", p_link, true),
    [BC_PRIM_SOLID_ANGLE] = DESC("solid_angle", p_solid_angle, true),
    [BC_PRIM_PYRAMID] = DESC("pyramid", p_pyramid, true),
    [BC_PRIM_TRI_PRISM] = DESC("tri_prism", p_tri_prism, true),
    [BC_PRIM_CUT_SPHERE] = DESC("cut_sphere", p_cut_sphere, true),
    [BC_PRIM_CUT_HOLLOW_SPHERE] =
        DESC("cut_hollow_sphere", p_cut_hollow_sphere, true),
    [BC_PRIM_DEATH_STAR] = DESC("death_star", p_death_star, true),
    [BC_PRIM_ROUNDED_CYLINDER] =
        DESC("rounded_cylinder", p_rounded_cylinder, true),
    [BC_PRIM_CAPPED_CYLINDER] =
        DESC("capped_cylinder", p_capped_cylinder, true),
    [BC_PRIM_CAPPED_CONE] = DESC("capped_cone", p_capped_cone, true),
    [BC_PRIM_RHOMBUS] = DESC("rhombus", p_rhombus, true),
    [BC_PRIM_VESICA_SEGMENT] = DESC("vesica_segment", p_vesica_segment, true),
    [BC_PRIM_EXTRUDE_CIRCLE] = DESC("extrude_circle", p_extrude_circle, true),
    [BC_PRIM_EXTRUDE_RECT] = DESC("extrude_rect", p_extrude_rect, true),
    [BC_PRIM_EXTRUDE_POLYGON] =
        DESC("extrude_polygon", p_extrude_polygon, true),
    [BC_PRIM_EXTRUDE_STAR] = DESC("extrude_star", p_extrude_star, true),
    [BC_PRIM_REVOLVE_CIRCLE] = DESC("revolve_circle", p_revolve_circle, true),
    [BC_PRIM_REVOLVE_RECT] = DESC("revolve_rect", p_revolve_rect, true),
    [BC_PRIM_REVOLVE_POLYGON] =
        DESC("revolve_polygon", p_revolve_polygon, true),
    [BC_PRIM_REVOLVE_STAR] = DESC("revolve_star", p_revolve_star, true),
};

#undef DESC

const struct bc_prim_info *bc_prim_info(enum bc_prim kind)
{
	if (kind <= BC_PRIM_INVALID || kind >= BC_PRIM_COUNT) {
		return NULL;
	}
	return &prim_table[kind];
}

enum bc_prim bc_prim_from_name(const char *name)
{
	if (!name) {
		return BC_PRIM_INVALID;
	}
	for (int k = BC_PRIM_INVALID + 1; k < BC_PRIM_COUNT; k++) {
		if (strcmp(name, prim_table[k].name) == 0) {
			return (enum bc_prim)k;
		}
	}
	return BC_PRIM_INVALID;
}

void bc_prim_data_init(struct bc_prim_data *p, enum bc_prim kind)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	memset(p, 0, sizeof(*p));
	p->kind = kind;
	p->rotate[3] = 1.0f;
	if (!info) {
		return;
	}
	for (uint32_t i = 0; i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		for (uint32_t c = 0; c < d->count; c++) {
			p->params[d->offset + c] = d->def;
		}
	}
}

/* ---- Validation --------------------------------------------------------- */

/*
 * Smallest value of a BC_PARAM_POSITIVE size (world units). With
 * BC_PARAM_MAX_ABS it keeps reciprocals of squared sizes (<= 1e12) and
 * squared coordinates over squared sizes far from float overflow, and a
 * shape this small is still above float resolution at coordinates near 1.
 */
#define PRIM_MIN_SIZE 1e-6f
/* Most sides of a regular polygon profile, points of a star: past this a
 * polygon is a circle to within 1e-4 of its radius. */
#define PRIM_MAX_SIDES 256.0f

/* Writes "name" or "name[i]" for messages about one component. */
static const char *comp_name(char *buf, size_t cap, const char *name,
                             uint32_t count, uint32_t i)
{
	if (count == 1) {
		return name;
	}
	snprintf(buf, cap, "%s[%u]", name, (unsigned)i);
	return buf;
}

static const char *nonfinite_word(float v)
{
	return isnan(v) ? "NaN" : "infinite";
}

/* Checks one float against the finiteness and magnitude limits. */
static int check_float(struct bc_errinfo *ei, const char *prim,
                       const char *what, float v)
{
	if (!isfinite(v)) {
		return bc_errinfo_set(ei, BC_ENONFINITE, "%s: %s is %s", prim,
		                      what, nonfinite_word(v));
	}
	if (fabsf(v) > BC_PARAM_MAX_ABS) {
		return bc_errinfo_set(
		    ei, BC_ERANGE, "%s: %s %g exceeds the limit %g", prim, what,
		    (double)v, (double)BC_PARAM_MAX_ABS);
	}
	return 0;
}

static float min3(const float *v)
{
	float m = v[0] < v[1] ? v[0] : v[1];
	return m < v[2] ? m : v[2];
}

/* Rules that tie several parameters of one kind together. */
static int check_shape(const struct bc_prim_data *p, const char *name,
                       struct bc_errinfo *ei)
{
	const float *v = p->params;
	switch (p->kind) {
	case BC_PRIM_BOX:
		if (v[3] > min3(v)) {
			return bc_errinfo_set(
			    ei, BC_ERANGE,
			    "%s: round %g exceeds the smallest half extent %g",
			    name, (double)v[3], (double)min3(v));
		}
		break;
	case BC_PRIM_BOX_FRAME:
		if (v[3] > min3(v)) {
			return bc_errinfo_set(
			    ei, BC_ERANGE,
			    "%s: thickness %g exceeds the smallest half "
			    "extent %g",
			    name, (double)v[3], (double)min3(v));
		}
		break;
	case BC_PRIM_CONE:
		if (v[1] == 0.0f && v[2] == 0.0f) {
			return bc_errinfo_set(
			    ei, BC_ERANGE,
			    "%s: radius_bottom and radius_top "
			    "are both 0 (a cone needs one)",
			    name);
		}
		break;
	case BC_PRIM_ROUND_CONE:
		if (v[6] == 0.0f && v[7] == 0.0f) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: radius_a and radius_b are "
			                      "both 0 (a round cone needs one)",
			                      name);
		}
		break;
	case BC_PRIM_CAPPED_TORUS:
		if (!(v[2] > 0.0f && v[2] <= 180.0f)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: angle_deg %g is outside "
			                      "(0, 180]",
			                      name, (double)v[2]);
		}
		break;
	case BC_PRIM_SOLID_ANGLE:
		if (!(v[1] > 0.0f && v[1] < 180.0f)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: angle_deg %g is outside "
			                      "(0, 180)",
			                      name, (double)v[1]);
		}
		break;
	case BC_PRIM_CUT_SPHERE:
	case BC_PRIM_CUT_HOLLOW_SPHERE:
		if (!(fabsf(v[1]) < v[0])) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: cut_height %g is outside "
			                      "(-radius, radius)",
			                      name, (double)v[1]);
		}
		break;
	case BC_PRIM_DEATH_STAR:
		/* The surfaces must cut each other: otherwise the solid is
		 * a plain ball, empty, or a ball with a hidden cavity. */
		if (!(v[2] > fabsf(v[0] - v[1]) && v[2] < v[0] + v[1])) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: d %g must lie between |ra - "
			                      "rb| and ra + rb (the spheres "
			                      "must intersect)",
			                      name, (double)v[2]);
		}
		break;
	case BC_PRIM_ROUNDED_CYLINDER:
		if (v[1] > v[0] || v[1] > v[2]) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: round %g exceeds the radius "
			                      "or the half height",
			                      name, (double)v[1]);
		}
		break;
	case BC_PRIM_CAPPED_CYLINDER:
	case BC_PRIM_CAPPED_CONE:
	case BC_PRIM_VESICA_SEGMENT: {
		double l2 = 0.0;
		for (int i = 0; i < 3; i++) {
			double e = (double)v[3 + i] - (double)v[i];
			l2 += e * e;
		}
		if (!(l2 >= (double)PRIM_MIN_SIZE * PRIM_MIN_SIZE)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: a and b coincide (the axis "
			                      "needs a length)",
			                      name);
		}
		if (p->kind == BC_PRIM_CAPPED_CONE && v[6] == 0.0f &&
		    v[7] == 0.0f) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: ra and rb are both 0 (a "
			                      "cone needs one)",
			                      name);
		}
		if (p->kind == BC_PRIM_VESICA_SEGMENT &&
		    !((double)v[6] <= 0.5 * sqrt(l2))) {
			return bc_errinfo_set(
			    ei, BC_ERANGE,
			    "%s: w %g exceeds half the length "
			    "of a-b (%g)",
			    name, (double)v[6], 0.5 * sqrt(l2));
		}
		break;
	}
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_REVOLVE_POLYGON:
	case BC_PRIM_EXTRUDE_STAR:
	case BC_PRIM_REVOLVE_STAR: {
		bool star = p->kind == BC_PRIM_EXTRUDE_STAR ||
		            p->kind == BC_PRIM_REVOLVE_STAR;
		float lo = star ? 2.0f : 3.0f;
		if (!(v[1] >= lo && v[1] <= PRIM_MAX_SIDES &&
		      v[1] == floorf(v[1]))) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: %s %g is not a whole number "
			                      "in [%g, %g]",
			                      name, star ? "points" : "sides",
			                      (double)v[1], (double)lo,
			                      (double)PRIM_MAX_SIDES);
		}
		if (star && !(v[2] < 1.0f)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: inner_ratio %g is outside "
			                      "(0, 1)",
			                      name, (double)v[2]);
		}
		break;
	}
	default:
		break;
	}
	return 0;
}

int bc_prim_validate(struct bc_prim_data *p, struct bc_errinfo *ei)
{
	const struct bc_prim_info *info = bc_prim_info(p->kind);
	char buf[64];
	double n2 = 0.0, n;
	int rc;

	if (!info) {
		return bc_errinfo_set(ei, BC_EENUM, "unknown primitive kind %d",
		                      (int)p->kind);
	}
	for (uint32_t i = 0; i < info->nparams; i++) {
		const struct bc_param_desc *d = &info->params[i];
		for (uint32_t c = 0; c < d->count; c++) {
			float v = p->params[d->offset + c];
			const char *what;
			bool pos = (d->flags & BC_PARAM_POSITIVE) != 0;
			bool nonneg = (d->flags & BC_PARAM_NONNEG) != 0;
			/* Names are formatted only for a message: validation
			 * runs for every node a decoder reads. */
			if (isfinite(v) && fabsf(v) <= BC_PARAM_MAX_ABS &&
			    (!pos || v >= PRIM_MIN_SIZE) &&
			    (!nonneg || v >= 0.0f)) {
				continue;
			}
			what =
			    comp_name(buf, sizeof(buf), d->name, d->count, c);
			if ((rc = check_float(ei, info->name, what, v))) {
				return rc;
			}
			if ((d->flags & BC_PARAM_POSITIVE) && !(v > 0.0f)) {
				return bc_errinfo_set(
				    ei, BC_ERANGE, "%s: %s %g must be > 0",
				    info->name, what, (double)v);
			}
			if ((d->flags & BC_PARAM_POSITIVE) &&
			    v < PRIM_MIN_SIZE) {
				return bc_errinfo_set(
				    ei, BC_ERANGE,
				    "%s: %s %g is below the smallest size %g",
				    info->name, what, (double)v,
				    (double)PRIM_MIN_SIZE);
			}
			if ((d->flags & BC_PARAM_NONNEG) && !(v >= 0.0f)) {
				return bc_errinfo_set(
				    ei, BC_ERANGE, "%s: %s %g must be >= 0",
				    info->name, what, (double)v);
			}
		}
	}
	if ((rc = check_shape(p, info->name, ei))) {
		return rc;
	}
	for (int i = 0; i < 3; i++) {
		const char *what;
		if (isfinite(p->translate[i]) &&
		    fabsf(p->translate[i]) <= BC_PARAM_MAX_ABS) {
			continue;
		}
		what = comp_name(buf, sizeof(buf), "translate", 3, (uint32_t)i);
		if ((rc = check_float(ei, info->name, what, p->translate[i]))) {
			return rc;
		}
	}
	for (int i = 0; i < 4; i++) {
		if (!isfinite(p->rotate[i])) {
			return bc_errinfo_set(
			    ei, BC_ENONFINITE, "%s: rotate[%d] is %s",
			    info->name, i, nonfinite_word(p->rotate[i]));
		}
		n2 += (double)p->rotate[i] * (double)p->rotate[i];
	}
	n = sqrt(n2);
	/* Scene files carry quaternions with a few printed digits; anything
	 * further from unit length is a mistake, not rounding. */
	if (!(fabs(n - 1.0) <= 1e-3)) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "%s: rotate has norm %g, not within 1e-3 "
		                      "of 1 (a unit quaternion)",
		                      info->name, n);
	}
	/* Renormalize only what is not unit to float precision already, so
	 * that validating a validated quaternion changes no bit (scenes
	 * round-trip exactly). */
	if (fabs(n - 1.0) > 0x1p-22) {
		for (int i = 0; i < 4; i++) {
			p->rotate[i] = (float)((double)p->rotate[i] / n);
		}
	}
	if (p->has_color) {
		for (int i = 0; i < 3; i++) {
			float c = p->color[i];
			if (!isfinite(c)) {
				return bc_errinfo_set(
				    ei, BC_ENONFINITE, "%s: color[%d] is %s",
				    info->name, i, nonfinite_word(c));
			}
			if (c < 0.0f || c > 1.0f) {
				return bc_errinfo_set(ei, BC_ERANGE,
				                      "%s: color[%d] %g is "
				                      "outside [0, 1]",
				                      info->name, i, (double)c);
			}
		}
	}
	return 0;
}

/* ---- Packing ------------------------------------------------------------ */

#define DEG2RAD 0.017453292519943295
#define SQRT3 1.7320508075688772
#define PI 3.141592653589793

/* Below this squared length a segment is a point: its reciprocal would
 * overflow float, and the shape differs from a sphere by < 1e-15. */
#define TINY_LEN2 1e-30

void bc_prim_pack(const struct bc_prim_data *p, float packed[BC_PRIM_PACKED])
{
	const float *v = p->params;
	memset(packed, 0, BC_PRIM_PACKED * sizeof(float));
	switch (p->kind) {
	case BC_PRIM_SPHERE:
	case BC_PRIM_OCTAHEDRON:
		packed[0] = v[0];
		break;
	case BC_PRIM_BOX:
		/* The rounded box keeps its outer size: the core box shrinks
		 * by the rounding radius. */
		for (int i = 0; i < 3; i++) {
			packed[i] = v[i] - v[3];
		}
		packed[3] = v[3];
		break;
	case BC_PRIM_CAPSULE: {
		double l2 = 0.0;
		for (int i = 0; i < 3; i++) {
			double e = (double)v[3 + i] - (double)v[i];
			packed[i] = v[i];
			packed[3 + i] = (float)e;
			l2 += e * e;
		}
		packed[6] = v[6];
		/* a == b is a sphere: a zero reciprocal pins the segment
		 * parameter to a. */
		packed[7] = l2 > TINY_LEN2 ? (float)(1.0 / l2) : 0.0f;
		break;
	}
	case BC_PRIM_CYLINDER:
	case BC_PRIM_TORUS:
		packed[0] = v[0];
		packed[1] = v[1];
		break;
	case BC_PRIM_CONE: {
		double h = v[0], dr = (double)v[2] - (double)v[1];
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = v[2];
		packed[3] = (float)dr;
		packed[4] = (float)(2.0 * h);
		packed[5] = (float)(1.0 / (dr * dr + 4.0 * h * h));
		break;
	}
	case BC_PRIM_ROUND_CONE: {
		double l2 = 0.0, rr = (double)v[6] - (double)v[7];
		for (int i = 0; i < 3; i++) {
			double e = (double)v[3 + i] - (double)v[i];
			l2 += e * e;
		}
		if (rr * rr >= l2 || l2 <= TINY_LEN2) {
			/* One sphere holds the other: the hull is the larger
			 * sphere, encoded as a zero-length axis. */
			int big = v[7] > v[6] ? 3 : 0;
			float r = v[7] > v[6] ? v[7] : v[6];
			for (int i = 0; i < 3; i++) {
				packed[i] = v[big + i];
			}
			packed[6] = r;
			packed[7] = r;
		} else {
			for (int i = 0; i < 3; i++) {
				packed[i] = v[i];
				packed[3 + i] =
				    (float)((double)v[3 + i] - (double)v[i]);
			}
			packed[6] = v[6];
			packed[7] = v[7];
		}
		break;
	}
	case BC_PRIM_ELLIPSOID: {
		float m = min3(v);
		for (int i = 0; i < 3; i++) {
			packed[i] = v[i];
			packed[3 + i] = (float)(1.0 / (double)v[i]);
		}
		packed[6] = m;
		break;
	}
	case BC_PRIM_HEX_PRISM:
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = (float)((double)v[0] / SQRT3);
		break;
	case BC_PRIM_BOX_FRAME:
		for (int i = 0; i < 3; i++) {
			packed[i] = v[i];
		}
		/* The field works with the bars' half width. */
		packed[3] = 0.5f * v[3];
		break;
	case BC_PRIM_CAPPED_TORUS: {
		double a = (double)v[2] * DEG2RAD;
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = (float)sin(a);
		packed[3] = (float)cos(a);
		/* The arc's end, precomputed for points past it. */
		packed[4] = (float)((double)v[0] * sin(a));
		packed[5] = (float)((double)v[0] * cos(a));
		break;
	}
	case BC_PRIM_LINK:
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = v[2];
		break;
	case BC_PRIM_SOLID_ANGLE: {
		double a = (double)v[1] * DEG2RAD;
		packed[0] = v[0];
		packed[1] = (float)sin(a);
		packed[2] = (float)cos(a);
		break;
	}
	case BC_PRIM_PYRAMID: {
		double b = v[0], h = v[1], l = sqrt(b * b + h * h);
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = (float)l;
		packed[3] = (float)(h / l);
		packed[4] = (float)(b / l);
		packed[5] = (float)(1.0 / (b * b + l * l));
		break;
	}
	case BC_PRIM_TRI_PRISM: {
		double r = v[0];
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = (float)(SQRT3 * r);
		packed[3] = (float)(1.0 / (12.0 * r * r));
		break;
	}
	case BC_PRIM_CUT_SPHERE:
	case BC_PRIM_CUT_HOLLOW_SPHERE: {
		double r = v[0], h = v[1];
		packed[0] = v[0];
		packed[1] = v[1];
		/* The rim of the cut: radius w at height h. */
		packed[2] = (float)sqrt(fmax(r * r - h * h, 0.0));
		packed[3] = v[2]; /* hollow: the shell's thickness */
		break;
	}
	case BC_PRIM_DEATH_STAR: {
		double ra = v[0], rb = v[1], d = v[2];
		double a = (ra * ra - rb * rb + d * d) / (2.0 * d);
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = v[2];
		/* The circle where the spheres meet: at x = a, radius b. */
		packed[3] = (float)a;
		packed[4] = (float)sqrt(fmax(ra * ra - a * a, 0.0));
		break;
	}
	case BC_PRIM_ROUNDED_CYLINDER:
		/* A cylinder shrunk by the rounding, then offset by it. */
		packed[0] = v[0] - v[1];
		packed[1] = v[2] - v[1];
		packed[2] = v[1];
		break;
	case BC_PRIM_CAPPED_CYLINDER:
	case BC_PRIM_CAPPED_CONE:
	case BC_PRIM_VESICA_SEGMENT: {
		/* Midpoint, then the half axis (b - a) / 2. */
		for (int i = 0; i < 3; i++) {
			packed[i] =
			    (float)(0.5 * ((double)v[i] + (double)v[3 + i]));
			packed[3 + i] =
			    (float)(0.5 * ((double)v[3 + i] - (double)v[i]));
		}
		packed[6] = v[6];
		packed[7] = v[7]; /* the cone's rb */
		break;
	}
	case BC_PRIM_RHOMBUS: {
		double la = v[0], lb = v[1];
		/* The core rhombus keeps its size; round grows it. */
		packed[0] = v[0];
		packed[1] = v[1];
		packed[2] = v[2];
		packed[3] = v[3];
		packed[4] = (float)(1.0 / (la * la + lb * lb));
		break;
	}
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_REVOLVE_CIRCLE:
		packed[0] = v[0];
		packed[7] = v[1];
		break;
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_REVOLVE_RECT:
		packed[0] = v[0];
		packed[1] = v[1];
		packed[7] = v[2];
		break;
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_REVOLVE_POLYGON: {
		double an = PI / (double)v[1];
		/* Apothem, half an edge, the sector's half and whole angle. */
		packed[0] = (float)((double)v[0] * cos(an));
		packed[1] = (float)((double)v[0] * sin(an));
		packed[2] = (float)an;
		packed[3] = (float)(2.0 * an);
		packed[7] = v[2];
		break;
	}
	case BC_PRIM_EXTRUDE_STAR:
	case BC_PRIM_REVOLVE_STAR: {
		double an = PI / (double)v[1], r = v[0], ri = r * v[2];
		/* In a folded sector the edge runs from the tip (0, r) to
		 * the inner corner ri (sin an, cos an). */
		double ex = ri * sin(an), ey = ri * cos(an) - r;
		packed[0] = v[0];
		packed[1] = (float)an;
		packed[2] = (float)(2.0 * an);
		packed[3] = (float)ex;
		packed[4] = (float)ey;
		packed[5] = (float)(1.0 / (ex * ex + ey * ey));
		packed[7] = v[3];
		break;
	}
	default:
		break;
	}
}

/* ---- Fields ------------------------------------------------------------- */

static inline float mnf(float a, float b)
{
	return a < b ? a : b;
}

static inline float mxf(float a, float b)
{
	return a > b ? a : b;
}

static inline float clampf(float v, float lo, float hi)
{
	return v < lo ? lo : (v > hi ? hi : v);
}

static inline float len2f(float x, float y)
{
	return sqrtf(x * x + y * y);
}

static inline float len3f(float x, float y, float z)
{
	return sqrtf(x * x + y * y + z * z);
}

/* Signed distance to the box [-h, h] given d = |p| - h per axis. */
static inline float box_d(float dx, float dy, float dz)
{
	float out = len3f(mxf(dx, 0.0f), mxf(dy, 0.0f), mxf(dz, 0.0f));
	return out + mnf(mxf(dx, mxf(dy, dz)), 0.0f);
}

/* Signed distance of an extrusion: d2 is the exact 2D distance of the
 * profile, dz the distance past the slab's faces. */
static inline float extrude(float d2, float dz)
{
	return mnf(mxf(d2, dz), 0.0f) + len2f(mxf(d2, 0.0f), mxf(dz, 0.0f));
}

/* Squared distance from (x, y) to the segment from (ax, ay) along (ex, ey),
 * with inv_e2 = 1 / |e|^2. */
static inline float seg2(float x, float y, float ax, float ay, float ex,
                         float ey, float inv_e2)
{
	float wx = x - ax, wy = y - ay;
	float t = clampf((wx * ex + wy * ey) * inv_e2, 0.0f, 1.0f);
	wx -= ex * t;
	wy -= ey * t;
	return wx * wx + wy * wy;
}

/*
 * Capped cone about the y axis. In the profile plane (rho, y) the solid is
 * the trapezoid (0,-h) (r1,-h) (r2,h) (0,h); its boundary is the two caps
 * and the slanted side (the axis is not boundary), and inside means between
 * the caps and behind the side's outward normal (2h, r1 - r2).
 */
static inline float sdf_cone(const float *k, float x, float y, float z)
{
	float h = k[0], r1 = k[1], r2 = k[2], ex = k[3], ey = k[4];
	float rho = len2f(x, z);
	float bx = mxf(rho - r1, 0.0f), by = y + h;
	float tx = mxf(rho - r2, 0.0f), ty = y - h;
	float d2 = mnf(bx * bx + by * by, tx * tx + ty * ty);
	float wx = rho - r1, wy = y + h;
	d2 = mnf(d2, seg2(rho, y, r1, -h, ex, ey, k[5]));
	bool inside = fabsf(y) < h && wx * ey - wy * ex < 0.0f;
	float d = sqrtf(d2);
	return inside ? -d : d;
}

/*
 * Round cone: the convex hull of the spheres (a, ra) and (b, rb). In the
 * profile plane (X off the axis, Y along it from a) the boundary is an arc of
 * each circle joined by their common tangent, whose outward normal is
 * (cos t, sin t) with sin t = (ra - rb) / L. The normals at the tangent
 * points split the plane into the three parts each piece is nearest to, for
 * inside and outside points alike. Lengths here are scaled by L (y = Y L) so
 * that one square root gives L cos t.
 */
static inline float sdf_round_cone(const float *k, float x, float y, float z)
{
	float px = x - k[0], py = y - k[1], pz = z - k[2];
	float ex = k[3], ey = k[4], ez = k[5], ra = k[6], rb = k[7];
	float l2 = ex * ex + ey * ey + ez * ez;
	float p2 = px * px + py * py + pz * pz;
	if (l2 == 0.0f) {
		return sqrtf(p2) - ra;
	}
	float yl = px * ex + py * ey + pz * ez;
	/* |pa x ba| rather than sqrt(p2 l2 - yl^2), which cancels to noise
	 * of sqrt(float eps) near the axis. */
	float xl =
	    len3f(py * ez - pz * ey, pz * ex - px * ez, px * ey - py * ex);
	float rr = ra - rb;
	float c = sqrtf(mxf(l2 - rr * rr, 0.0f));
	float s = yl * c - xl * rr;
	if (s < 0.0f) {
		return sqrtf(p2) - ra;
	}
	if (s > c * l2) {
		return len3f(px - ex, py - ey, pz - ez) - rb;
	}
	return (xl * c + yl * rr) / l2 - ra;
}

/*
 * Ellipsoid, radii r. The nearest surface point to an outside point p is
 * x_i = r_i^2 p_i / (r_i^2 + t) for the root t > 0 of
 * F(t) = sum (r_i p_i / (r_i^2 + t))^2 = 1. For any direction n, the
 * distance from p to the tangent plane with normal n, n.p - |r n|, is at
 * most the distance to the (convex) ellipsoid, and equals it at the true
 * normal. So a few Newton steps on F^(-1/2) = 1 (nearly linear in t, so it
 * converges fast even far away) give a normal n ~ p / (r^2 + t) whose plane
 * distance is a guaranteed lower bound however far the iteration got: 1 - 1e-5
 * of the distance for aspect ratios up to 16, Lipschitz ~1.01 at 50
 * (docs/primitives.md). t starts at min(r)^2 (k0 - 1) <= the root.
 * Inside, scaling by 1/r shrinks distances by at most 1/min(r), so
 * min(r) (k0 - 1) is a bound with k0 = |p / r|. The max with the bounding
 * box's distance keeps the field at or above the ABV's.
 */
#define ELLIPSOID_STEPS 4

static inline float sdf_ellipsoid(const float *k, float x, float y, float z)
{
	float p[3] = {fabsf(x), fabsf(y), fabsf(z)};
	float r2[3] = {k[0] * k[0], k[1] * k[1], k[2] * k[2]};
	float k0 = len3f(p[0] * k[3], p[1] * k[4], p[2] * k[5]), f;
	if (k0 < 1.0f) {
		f = k[6] * (k0 - 1.0f);
	} else if (!(k0 < 1e18f)) {
		/* So far out that the squares below would overflow: the
		 * box's distance is as good a bound at this range. */
		f = -INFINITY;
	} else {
		float t = k[6] * k[6] * (k0 - 1.0f);
		float w[3], wp = 0.0f, wl = 0.0f, rw = 0.0f;
		for (int it = 0; it < ELLIPSOID_STEPS; it++) {
			float fv = 0.0f, dv = 0.0f;
			for (int i = 0; i < 3; i++) {
				float inv = 1.0f / (r2[i] + t);
				float u = k[i] * p[i] * inv;
				fv += u * u;
				dv += u * u * inv;
			}
			/* Newton on F^(-1/2) - 1: dt = (sqrt F - 1) F /
			 * (-F'/2). The root is > 0, so t >= 0 loses nothing and
			 * keeps every r_i^2 + t positive. */
			t = mxf(t + (sqrtf(fv) - 1.0f) * fv / dv, 0.0f);
		}
		for (int i = 0; i < 3; i++) {
			w[i] = p[i] / (r2[i] + t);
			wp += w[i] * p[i];
			wl += w[i] * w[i];
			rw += r2[i] * w[i] * w[i];
		}
		f = (wp - sqrtf(rw)) / sqrtf(wl);
	}
	return mxf(f, box_d(p[0] - k[0], p[1] - k[1], p[2] - k[2]));
}

/*
 * Hexagonal prism along z, flat sides at y = +-a. Folding by |x|, |y| and
 * the mirror line at 60 degrees through the corner (a/sqrt3, a) maps every
 * point into the sector whose boundary is the top side alone.
 */
static inline float sdf_hex_prism(const float *k, float x, float y, float z)
{
	const float nx = -0.86602540378f, ny = 0.5f;
	float a = k[0], half_side = k[2];
	float px = fabsf(x), py = fabsf(y);
	float m = mnf(nx * px + ny * py, 0.0f);
	px -= 2.0f * m * nx;
	py -= 2.0f * m * ny;
	float dx = px - clampf(px, -half_side, half_side), dy = py - a;
	float d2 = len2f(dx, dy);
	return extrude(dy < 0.0f ? -d2 : d2, fabsf(z) - k[1]);
}

/*
 * Octahedron |x| + |y| + |z| <= s. In the positive octant the surface is the
 * triangle with vertices s e_x, s e_y, s e_z. If the point's projection on
 * its plane falls outside across the edge where coordinate i is 0, the
 * nearest point lies on that edge (the triangle is acute); otherwise the
 * plane distance is the answer.
 */
static inline float sdf_octahedron(const float *k, float x, float y, float z)
{
	float s = k[0];
	float px = fabsf(x), py = fabsf(y), pz = fabsf(z);
	float m = px + py + pz - s;
	float a, b, c; /* a: the coordinate that is 0 on the edge */
	if (3.0f * px < m) {
		a = px, b = py, c = pz;
	} else if (3.0f * py < m) {
		a = py, b = pz, c = px;
	} else if (3.0f * pz < m) {
		a = pz, b = px, c = py;
	} else {
		return m * 0.57735026919f;
	}
	/* Edge points (0, s - t, t), t in [0, s], in (a, b, c) order. */
	float t = clampf(0.5f * (c - b + s), 0.0f, s);
	return len3f(a, b - s + t, c - t);
}

/*
 * Box frame: the twelve square bars of width 2e along the box's edges. In
 * the positive octant three bars meet at the corner; the field is the
 * smallest of their box distances (exact outside; inside the bars' overlap
 * at concave edges it is a bound).
 */
static inline float sdf_box_frame(const float *k, float x, float y, float z)
{
	float e = k[3];
	float px = fabsf(x) - k[0], py = fabsf(y) - k[1], pz = fabsf(z) - k[2];
	/* Distance past the bar's square section, per axis. */
	float qx = fabsf(px + e) - e, qy = fabsf(py + e) - e,
	      qz = fabsf(pz + e) - e;
	float d = box_d(px, qy, qz);
	d = mnf(d, box_d(qx, py, qz));
	return mnf(d, box_d(qx, qy, pz));
}

/*
 * Capped torus: a tube of radius r around the arc of radius R in the xz
 * plane that spans the azimuths within angle_deg of +z. Points whose
 * azimuth (folded by |x|) is past the arc's end are nearest to the end.
 */
static inline float sdf_capped_torus(const float *k, float x, float y, float z)
{
	float big = k[0], sn = k[2], cs = k[3];
	float u = fabsf(x);
	float d;
	if (cs * u > sn * z) {
		d = len3f(u - k[4], y, z - k[5]);
	} else {
		d = len2f(len2f(u, z) - big, y);
	}
	return d - k[1];
}

/* Solid angle: the ball of radius ra cut by the cone of half angle t about
 * +y, tip at the origin. Profile boundary: the cap's arc and the side
 * segment from the tip to the rim ra (sin t, cos t). */
static inline float sdf_solid_angle(const float *k, float x, float y, float z)
{
	float ra = k[0], sn = k[1], cs = k[2];
	float rho = len2f(x, z);
	float l = len2f(rho, y) - ra;
	float t = clampf(rho * sn + y * cs, 0.0f, ra);
	float m = len2f(rho - sn * t, y - cs * t);
	if (cs * rho - sn * y > 0.0f) {
		/* Outside the cone: the rim is the side's end, so the side
		 * is nearest. */
		return m;
	}
	/* Inside the cone: the cap (in the point's direction) or the side. */
	return l >= 0.0f ? l : mxf(l, -m);
}

/*
 * Pyramid with the square base [-b, b]^2 on y = 0 and its apex at (0, h, 0).
 * Folding by |x|, |z| and x <-> z leaves the chamber x >= z >= 0, where the
 * surface is the +x face and the base. The face is handled in its own
 * plane: u along the base edge, v up the slant from the edge's midpoint,
 * w along the outward normal (h, b, 0) / L.
 */
static inline float sdf_pyramid(const float *k, float x, float y, float z)
{
	float b = k[0], l = k[2], nx = k[3], ny = k[4];
	float ax = fabsf(x), az = fabsf(z);
	if (az > ax) {
		float t = ax;
		ax = az;
		az = t;
	}
	float bx = mxf(ax - b, 0.0f), bz = mxf(az - b, 0.0f);
	float base2 = bx * bx + bz * bz + y * y;
	float dx = ax - b;
	float w = dx * nx + y * ny;
	float v = y * nx - dx * ny;
	float u = az;
	float face2;
	if (v >= 0.0f && u * l + v * b <= b * l) {
		face2 = 0.0f; /* projects inside the triangle */
	} else {
		float ub = mxf(u - b, 0.0f);
		face2 = mnf(ub * ub + v * v, seg2(u, v, b, 0.0f, -b, l, k[5]));
	}
	face2 += w * w;
	float d = sqrtf(mnf(face2, base2));
	return (y > 0.0f && w < 0.0f) ? -d : d;
}

/*
 * Triangular prism along z: the equilateral triangle with inradius r, apex
 * (0, 2r) and base y = -r, folded by |x| to the right side and half base.
 */
static inline float sdf_tri_prism(const float *k, float x, float y, float z)
{
	float r = k[0], hb = k[2];
	float ax = fabsf(x);
	float side2 = seg2(ax, y, 0.0f, 2.0f * r, hb, -3.0f * r, k[3]);
	float bx = mxf(ax - hb, 0.0f), by = y + r;
	float d = sqrtf(mnf(side2, bx * bx + by * by));
	bool inside = y > -r && 0.86602540378f * ax + 0.5f * y < r;
	return extrude(inside ? -d : d, fabsf(z) - k[1]);
}

/* ---- The new kinds: cut and carved spheres, axis-between-points solids,
 * 2D profiles extruded and revolved. Each is written as the distance to
 * the pieces of its boundary (arcs, segments, discs), signed by a
 * membership test, so it is exact by construction. */

/*
 * The ball of radius r below the plane y = h, in its profile (q = distance
 * from the y axis, y). Its boundary is the arc of the circle below the rim
 * (w, h) and the disc of the cut. A point sees the arc's nearest point when
 * its direction from the centre is below the rim's (w y <= h q), else the
 * rim.
 */
static inline float sdf_cut_sphere(const float *k, float x, float y, float z)
{
	float r = k[0], h = k[1], w = k[2];
	float q = len2f(x, z), l = len2f(q, y);
	float arc = w * y <= h * q ? fabsf(l - r) : len2f(q - w, y - h);
	float disc = len2f(mxf(q - w, 0.0f), y - h);
	float d = mnf(arc, disc);
	return (l < r && y < h) ? -d : d;
}

/* The spherical shell's arc below the rim, thickened by t on both sides. */
static inline float sdf_cut_hollow_sphere(const float *k, float x, float y,
                                          float z)
{
	float r = k[0], h = k[1], w = k[2];
	float q = len2f(x, z);
	float arc =
	    w * y <= h * q ? fabsf(len2f(q, y) - r) : len2f(q - w, y - h);
	return arc - k[3];
}

/*
 * The ball A (radius ra, centre 0) less the ball B (radius rb, centre
 * (d, 0, 0)), in the profile (x, distance from the x axis). The two arcs of
 * the boundary meet on the circle (a, b): A's arc where a point's direction
 * from A's centre is beyond the rim's, B's arc where its direction from B's
 * centre is; otherwise the rim is nearest.
 */
static inline float sdf_death_star(const float *k, float x, float y, float z)
{
	float ra = k[0], rb = k[1], d = k[2], a = k[3], b = k[4];
	float q = len2f(y, z);
	float la = len2f(x, q), lb = len2f(x - d, q);
	float rim = len2f(x - a, q - b);
	float da = a * q - b * x >= 0.0f ? fabsf(la - ra) : rim;
	float db = (a - d) * q - b * (x - d) >= 0.0f ? fabsf(lb - rb) : rim;
	float dist = mnf(da, db);
	return (la < ra && lb > rb) ? -dist : dist;
}

/* Axial coordinate and distance from the axis of a point about the segment
 * with midpoint k[0..2] and half axis k[3..5]; *hl gets the half length. */
static inline void seg_frame(const float *k, float x, float y, float z,
                             float *along, float *radial, float *hl)
{
	float px = x - k[0], py = y - k[1], pz = z - k[2];
	float l = len3f(k[3], k[4], k[5]), inv = 1.0f / l;
	float t = (px * k[3] + py * k[4] + pz * k[5]) * inv;
	float r2 = px * px + py * py + pz * pz - t * t;
	*along = t;
	*radial = sqrtf(mxf(r2, 0.0f));
	*hl = l;
}

/* The capped cone of the profile: radius r1 at y = -h, r2 at y = h (as
 * sdf_cone, with its derived values computed here). */
static inline float cone2(float rho, float y, float h, float r1, float r2)
{
	float ex = r2 - r1, ey = 2.0f * h;
	float k[6] = {h, r1, r2, ex, ey, 1.0f / (ex * ex + ey * ey)};
	return sdf_cone(k, rho, y, 0.0f);
}

/*
 * Vesica: the lens swept about the axis, in the profile (distance from the
 * axis, |axial|): the arc of the circle centred at (-c, 0) through (w, 0)
 * and the tip (0, hl), c = (hl^2 - w^2) / (2 w). Points beyond the line
 * from that centre through the tip are nearest to the tip.
 */
static inline float vesica2(float q, float y, float hl, float w)
{
	float c = 0.5f * (hl * hl - w * w) / w;
	y = fabsf(y);
	if (hl * q < c * (y - hl)) {
		return len2f(q, y - hl);
	}
	return len2f(q + c, y) - (c + w);
}

/* Rhombus of half diagonals la (x) and lb (z), grown by round, extruded by
 * the half height along y. In the folded quadrant the boundary is the edge
 * from (la, 0) to (0, lb). */
static inline float sdf_rhombus(const float *k, float x, float y, float z)
{
	float la = k[0], lb = k[1];
	float px = fabsf(x), pz = fabsf(z);
	float d2 = sqrtf(seg2(px, pz, la, 0.0f, -la, lb, k[4]));
	float side = px * lb + pz * la - la * lb;
	return extrude((side < 0.0f ? -d2 : d2) - k[3], fabsf(y) - k[2]);
}

/* x mod m into [0, m) (GLSL's mod). */
static inline float modp(float x, float m)
{
	return x - m * floorf(x / m);
}

/* Regular polygon of n sides, one vertex on +y: folded into half a sector,
 * whose boundary is half an edge at the apothem. */
static inline float polygon2(const float *k, float x, float y)
{
	float apo = k[0], half = k[1];
	float b = modp(atan2f(x, y), k[3]) - k[2];
	float l = len2f(x, y);
	float px = l * cosf(b) - apo, py = l * fabsf(sinf(b)) - half;
	py += clampf(-py, 0.0f, half);
	float d = len2f(px, py);
	return px < 0.0f ? -d : d;
}

/* Star of n points (tips at radius r, one on +y) whose inner corners are at
 * inner_ratio r: folded into half a sector, the boundary is the edge from
 * the tip (0, r) to the inner corner. */
static inline float star2(const float *k, float x, float y)
{
	float r = k[0], ex = k[3], ey = k[4];
	float b = fabsf(modp(atan2f(x, y) + k[1], k[2]) - k[1]);
	float l = len2f(x, y);
	float px = l * sinf(b), py = l * cosf(b);
	float d = sqrtf(seg2(px, py, 0.0f, r, ex, ey, k[5]));
	return ex * (py - r) - ey * px < 0.0f ? -d : d;
}

/* The 2D profile of an extruded or revolved kind at (x, y). */
static inline float profile2(enum bc_prim kind, const float *k, float x,
                             float y)
{
	switch (kind) {
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_REVOLVE_CIRCLE:
		return len2f(x, y) - k[0];
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_REVOLVE_RECT: {
		float dx = fabsf(x) - k[0], dy = fabsf(y) - k[1];
		return len2f(mxf(dx, 0.0f), mxf(dy, 0.0f)) +
		       mnf(mxf(dx, dy), 0.0f);
	}
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_REVOLVE_POLYGON:
		return polygon2(k, x, y);
	default:
		return star2(k, x, y);
	}
}

/* Revolution about y: the profile meets the meridian plane on both sides
 * of the axis, so a profile wider than its offset is the union of the two
 * (exact outside, a bound inside where they overlap). */
static inline float revolve(enum bc_prim kind, const float *k, float x, float y,
                            float z)
{
	float q = len2f(x, z);
	float d = profile2(kind, k, q - k[7], y);
	return mnf(d, profile2(kind, k, -q - k[7], y));
}

static float sdf_new(enum bc_prim kind, const float *k, float x, float y,
                     float z)
{
	float t, q, hl;
	switch (kind) {
	case BC_PRIM_CUT_SPHERE:
		return sdf_cut_sphere(k, x, y, z);
	case BC_PRIM_CUT_HOLLOW_SPHERE:
		return sdf_cut_hollow_sphere(k, x, y, z);
	case BC_PRIM_DEATH_STAR:
		return sdf_death_star(k, x, y, z);
	case BC_PRIM_ROUNDED_CYLINDER:
		return extrude(len2f(x, z) - k[0], fabsf(y) - k[1]) - k[2];
	case BC_PRIM_CAPPED_CYLINDER:
		seg_frame(k, x, y, z, &t, &q, &hl);
		return extrude(q - k[6], fabsf(t) - hl);
	case BC_PRIM_CAPPED_CONE:
		seg_frame(k, x, y, z, &t, &q, &hl);
		return cone2(q, t, hl, k[6], k[7]);
	case BC_PRIM_VESICA_SEGMENT:
		seg_frame(k, x, y, z, &t, &q, &hl);
		return vesica2(q, t, hl, k[6]);
	case BC_PRIM_RHOMBUS:
		return sdf_rhombus(k, x, y, z);
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_EXTRUDE_STAR:
		return extrude(profile2(kind, k, x, y), fabsf(z) - k[7]);
	case BC_PRIM_REVOLVE_CIRCLE:
	case BC_PRIM_REVOLVE_RECT:
	case BC_PRIM_REVOLVE_POLYGON:
	case BC_PRIM_REVOLVE_STAR:
		return revolve(kind, k, x, y, z);
	default:
		/* Not a primitive: absent everywhere. */
		return INFINITY;
	}
}

float bc_prim_sdf(enum bc_prim kind, const float k[BC_PRIM_PACKED], float x,
                  float y, float z)
{
	switch (kind) {
	case BC_PRIM_SPHERE:
		return len3f(x, y, z) - k[0];
	case BC_PRIM_BOX:
		return box_d(fabsf(x) - k[0], fabsf(y) - k[1],
		             fabsf(z) - k[2]) -
		       k[3];
	case BC_PRIM_CAPSULE: {
		float px = x - k[0], py = y - k[1], pz = z - k[2];
		float t = clampf((px * k[3] + py * k[4] + pz * k[5]) * k[7],
		                 0.0f, 1.0f);
		return len3f(px - k[3] * t, py - k[4] * t, pz - k[5] * t) -
		       k[6];
	}
	case BC_PRIM_CYLINDER:
		return extrude(len2f(x, z) - k[0], fabsf(y) - k[1]);
	case BC_PRIM_TORUS:
		return len2f(len2f(x, z) - k[0], y) - k[1];
	case BC_PRIM_CONE:
		return sdf_cone(k, x, y, z);
	case BC_PRIM_ROUND_CONE:
		return sdf_round_cone(k, x, y, z);
	case BC_PRIM_ELLIPSOID:
		return sdf_ellipsoid(k, x, y, z);
	case BC_PRIM_HEX_PRISM:
		return sdf_hex_prism(k, x, y, z);
	case BC_PRIM_OCTAHEDRON:
		return sdf_octahedron(k, x, y, z);
	case BC_PRIM_BOX_FRAME:
		return sdf_box_frame(k, x, y, z);
	case BC_PRIM_CAPPED_TORUS:
		return sdf_capped_torus(k, x, y, z);
	case BC_PRIM_LINK: {
		float qy = mxf(fabsf(y) - k[0], 0.0f);
		return len2f(len2f(x, qy) - k[1], z) - k[2];
	}
	case BC_PRIM_SOLID_ANGLE:
		return sdf_solid_angle(k, x, y, z);
	case BC_PRIM_PYRAMID:
		return sdf_pyramid(k, x, y, z);
	case BC_PRIM_TRI_PRISM:
		return sdf_tri_prism(k, x, y, z);
	default:
		return sdf_new(kind, k, x, y, z);
	}
}

/* ---- Bounding shapes ---------------------------------------------------- */

static void bound_box(struct bc_abv *out, float cx, float cy, float cz,
                      float hx, float hy, float hz)
{
	out->shape = BC_ABV_BOX;
	out->center[0] = cx;
	out->center[1] = cy;
	out->center[2] = cz;
	out->half[0] = hx;
	out->half[1] = hy;
	out->half[2] = hz;
	for (int i = 0; i < 3; i++) {
		out->axis[i][i] = 1.0f;
	}
}

static void bound_sphere(struct bc_abv *out, float cy, float r)
{
	out->shape = BC_ABV_SPHERE;
	out->center[1] = cy;
	out->radius = r;
}

static void bound_capsule(struct bc_abv *out, const float *a, const float *b,
                          float r)
{
	out->shape = BC_ABV_CAPSULE;
	memcpy(out->center, a, 3 * sizeof(float));
	memcpy(out->end, b, 3 * sizeof(float));
	out->radius = r;
}

/*
 * The smallest sphere around a solid angle's profile (tip, cap, rim): for
 * t <= 45 degrees it passes through the tip and the rim; up to 90 it is
 * centred at the rim's height; wider sectors need the whole ball.
 */
static void bound_solid_angle(struct bc_abv *out, float ra, float deg)
{
	double t = (double)deg * DEG2RAD;
	if (deg <= 45.0f) {
		double c = (double)ra / (2.0 * cos(t));
		bound_sphere(out, (float)c, (float)c);
	} else if (deg <= 90.0f) {
		bound_sphere(out, (float)((double)ra * cos(t)),
		             (float)((double)ra * sin(t)));
	} else {
		bound_sphere(out, 0.0f, ra);
	}
}

/* The box of a 2D profile: e = x0, x1, y0, y1. A polygon's or a star's
 * extreme points are among its corners (tips at radius r, a star's inner
 * corners at inner_ratio r between them, one tip on +y). */
static void profile_extent(enum bc_prim kind, const float *v, double e[4])
{
	int n, corners;
	bool star =
	    kind == BC_PRIM_EXTRUDE_STAR || kind == BC_PRIM_REVOLVE_STAR;
	switch (kind) {
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_REVOLVE_CIRCLE:
		e[0] = e[2] = -(double)v[0];
		e[1] = e[3] = v[0];
		return;
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_REVOLVE_RECT:
		e[0] = -(double)v[0];
		e[1] = v[0];
		e[2] = -(double)v[1];
		e[3] = v[1];
		return;
	default:
		break;
	}
	n = (int)v[1];
	corners = star ? 2 * n : n;
	e[0] = e[2] = INFINITY;
	e[1] = e[3] = -INFINITY;
	for (int i = 0; i < corners; i++) {
		double a = 2.0 * PI * i / corners;
		double r = star && i % 2 ? (double)v[0] * v[2] : v[0];
		double x = r * sin(a), y = r * cos(a);
		e[0] = fmin(e[0], x);
		e[1] = fmax(e[1], x);
		e[2] = fmin(e[2], y);
		e[3] = fmax(e[3], y);
	}
	/* Rounding of sin and cos: a hair more, never less. */
	for (int i = 0; i < 4; i++) {
		e[i] += (i % 2 ? 1e-6 : -1e-6) * v[0];
	}
}

void bc_prim_bound(const struct bc_prim_data *p, struct bc_abv *out)
{
	const float *v = p->params;
	memset(out, 0, sizeof(*out));
	switch (p->kind) {
	case BC_PRIM_SPHERE:
	case BC_PRIM_OCTAHEDRON:
		/* The octahedron's vertices are at distance size. */
		bound_sphere(out, 0.0f, v[0]);
		break;
	case BC_PRIM_BOX:
	case BC_PRIM_BOX_FRAME:
	case BC_PRIM_ELLIPSOID:
		bound_box(out, 0.0f, 0.0f, 0.0f, v[0], v[1], v[2]);
		break;
	case BC_PRIM_CAPSULE:
		bound_capsule(out, v, v + 3, v[6]);
		break;
	case BC_PRIM_ROUND_CONE:
		/* Both spheres fit in the capsule of the larger radius, and
		 * so does their hull. */
		bound_capsule(out, v, v + 3, mxf(v[6], v[7]));
		break;
	case BC_PRIM_CYLINDER:
		bound_box(out, 0.0f, 0.0f, 0.0f, v[0], v[1], v[0]);
		break;
	case BC_PRIM_TORUS: {
		float e = v[0] + v[1];
		bound_box(out, 0.0f, 0.0f, 0.0f, e, v[1], e);
		break;
	}
	case BC_PRIM_CONE: {
		float r = mxf(v[1], v[2]);
		bound_box(out, 0.0f, 0.0f, 0.0f, r, v[0], r);
		break;
	}
	case BC_PRIM_HEX_PRISM:
		bound_box(out, 0.0f, 0.0f, 0.0f,
		          (float)(2.0 * (double)v[0] / SQRT3), v[0], v[1]);
		break;
	case BC_PRIM_CAPPED_TORUS: {
		/* The arc spans x in [-R sin t, R sin t] (all of [-R, R] past
		 * 90 degrees) and z in [R cos t, R]; the tube adds r. */
		double big = v[0], r = v[1], t = (double)v[2] * DEG2RAD;
		double hx = (v[2] >= 90.0f ? big : big * sin(t)) + r;
		double z0 = big * cos(t) - r, z1 = big + r;
		bound_box(out, 0.0f, 0.0f, (float)(0.5 * (z0 + z1)), (float)hx,
		          v[1], (float)(0.5 * (z1 - z0)));
		break;
	}
	case BC_PRIM_LINK: {
		float e = v[1] + v[2];
		bound_box(out, 0.0f, 0.0f, 0.0f, e, v[0] + e, v[2]);
		break;
	}
	case BC_PRIM_SOLID_ANGLE:
		bound_solid_angle(out, v[0], v[1]);
		break;
	case BC_PRIM_PYRAMID:
		bound_box(out, 0.0f, 0.5f * v[1], 0.0f, v[0], 0.5f * v[1],
		          v[0]);
		break;
	case BC_PRIM_TRI_PRISM:
		bound_box(out, 0.0f, 0.5f * v[0], 0.0f,
		          (float)(SQRT3 * (double)v[0]), 1.5f * v[0], v[1]);
		break;
	case BC_PRIM_CUT_SPHERE:
	case BC_PRIM_CUT_HOLLOW_SPHERE: {
		/* Below the equator the cut is the widest part. */
		double r = v[0], h = v[1];
		double t = p->kind == BC_PRIM_CUT_HOLLOW_SPHERE ? v[2] : 0.0;
		double wide =
		    (h >= 0.0 ? r : sqrt(fmax(r * r - h * h, 0.0))) + t;
		double y0 = -r - t, y1 = h + t;
		bound_box(out, 0.0f, (float)(0.5 * (y0 + y1)), 0.0f,
		          (float)wide, (float)(0.5 * (y1 - y0)), (float)wide);
		break;
	}
	case BC_PRIM_DEATH_STAR:
		bound_sphere(out, 0.0f, v[0]);
		break;
	case BC_PRIM_ROUNDED_CYLINDER:
		bound_box(out, 0.0f, 0.0f, 0.0f, v[0], v[2], v[0]);
		break;
	case BC_PRIM_CAPPED_CYLINDER:
	case BC_PRIM_VESICA_SEGMENT:
		bound_capsule(out, v, v + 3, v[6]);
		break;
	case BC_PRIM_CAPPED_CONE:
		bound_capsule(out, v, v + 3, mxf(v[6], v[7]));
		break;
	case BC_PRIM_RHOMBUS:
		bound_box(out, 0.0f, 0.0f, 0.0f, v[0] + v[3], v[2],
		          v[1] + v[3]);
		break;
	case BC_PRIM_EXTRUDE_CIRCLE:
	case BC_PRIM_EXTRUDE_RECT:
	case BC_PRIM_EXTRUDE_POLYGON:
	case BC_PRIM_EXTRUDE_STAR: {
		double e[4];
		float depth = v[bc_prim_info(p->kind)->nparams - 1];
		profile_extent(p->kind, v, e);
		bound_box(out, (float)(0.5 * (e[0] + e[1])),
		          (float)(0.5 * (e[2] + e[3])), 0.0f,
		          (float)(0.5 * (e[1] - e[0])),
		          (float)(0.5 * (e[3] - e[2])), depth);
		break;
	}
	case BC_PRIM_REVOLVE_CIRCLE:
	case BC_PRIM_REVOLVE_RECT:
	case BC_PRIM_REVOLVE_POLYGON:
	case BC_PRIM_REVOLVE_STAR: {
		/* The profile at offset from the axis reaches out to the
		 * farther of its sides. */
		double e[4], off = v[bc_prim_info(p->kind)->nparams - 1];
		double reach;
		profile_extent(p->kind, v, e);
		reach = fmax(fabs(off + e[1]), fabs(off + e[0]));
		bound_box(out, 0.0f, (float)(0.5 * (e[2] + e[3])), 0.0f,
		          (float)reach, (float)(0.5 * (e[3] - e[2])),
		          (float)reach);
		break;
	}
	default:
		break;
	}
}
