/*
 * Operators of the blobtree (Zanni 2024, §4): the sharp CSG selectors and the
 * compact smooth operators G built from the C2 polynomial blends (eq. 8-11)
 * with the blend-closing transition b_r (eq. 17-18).
 *
 * A missing operand is +INFINITY. Every operator then degrades to its
 * operand selection without special cases: outside the operator range R_o
 * the compact operators are exactly the sharp ones, and +inf is outside any
 * finite range.
 */
#include "blobcast/blobtree.h"

#include <math.h>
#include <string.h>

static const char *const op_names[BC_OP_COUNT] = {
    [BC_OP_UNION] = "union",
    [BC_OP_INTERSECTION] = "intersection",
    [BC_OP_DIFFERENCE] = "difference",
    [BC_OP_SMOOTH_UNION] = "smooth_union",
    [BC_OP_SMOOTH_INTERSECTION] = "smooth_intersection",
    [BC_OP_SMOOTH_DIFFERENCE] = "smooth_difference",
    [BC_OP_OFFSET] = "offset",
    [BC_OP_ONION] = "onion",
    [BC_OP_ELONGATE] = "elongate",
    [BC_OP_TWIST] = "twist",
    [BC_OP_BEND] = "bend",
    [BC_OP_MIRROR] = "mirror",
    [BC_OP_REPEAT] = "repeat",
    [BC_OP_SCALE] = "scale",
};

/* Scene-file keys of the unary nodes' parameters: repeat's six floats are
 * two keys of three (json.c splits them); mirror's one float is the axes
 * mask, written as a string of axis letters. */
static const struct bc_unary_info unary_infos[BC_OP_COUNT] = {
    [BC_OP_OFFSET] = {"offset", 1, "amount"},
    [BC_OP_ONION] = {"onion", 1, "thickness"},
    [BC_OP_ELONGATE] = {"elongate", 3, "half_extents"},
    [BC_OP_TWIST] = {"twist", 1, "rate"},
    [BC_OP_BEND] = {"bend", 1, "rate"},
    [BC_OP_MIRROR] = {"mirror", 1, "axes"},
    [BC_OP_REPEAT] = {"repeat", 6, "spacing"},
    [BC_OP_SCALE] = {"scale", 1, "factor"},
};

uint32_t bc_mirror_axes_parse(const char *s)
{
	uint32_t mask = 0;
	if (!s || !*s) {
		return 0;
	}
	for (; *s; s++) {
		uint32_t bit;
		if (*s < 'x' || *s > 'z') {
			return 0;
		}
		bit = 1u << (uint32_t)(*s - 'x');
		if (mask & bit) {
			return 0;
		}
		mask |= bit;
	}
	return mask;
}

void bc_mirror_axes_name(uint32_t mask, char out[4])
{
	uint32_t n = 0;
	for (uint32_t i = 0; i < 3; i++) {
		if (mask & (1u << i)) {
			out[n++] = (char)('x' + i);
		}
	}
	out[n] = '\0';
}

bool bc_op_is_unary(enum bc_op kind)
{
	return kind >= BC_OP_FIRST_UNARY && kind < BC_OP_COUNT;
}

bool bc_op_is_domain(enum bc_op kind)
{
	return bc_op_is_unary(kind) && kind != BC_OP_OFFSET &&
	       kind != BC_OP_ONION;
}

bool bc_op_has_value(enum bc_op kind)
{
	return kind == BC_OP_OFFSET || kind == BC_OP_ONION ||
	       kind == BC_OP_TWIST || kind == BC_OP_BEND || kind == BC_OP_SCALE;
}

const struct bc_unary_info *bc_unary_info(enum bc_op kind)
{
	return bc_op_is_unary(kind) ? &unary_infos[kind] : NULL;
}

void bc_unary_init(struct bc_unary *u, enum bc_op kind)
{
	memset(u, 0, sizeof(*u));
	u->kind = kind;
	switch (kind) {
	case BC_OP_OFFSET:
		u->u[0] = 0.1f;
		break;
	case BC_OP_ONION:
		u->u[0] = 0.05f;
		break;
	case BC_OP_ELONGATE:
		u->u[0] = 0.5f;
		break;
	case BC_OP_TWIST:
		u->u[0] = 1.0f;
		break;
	case BC_OP_BEND:
		u->u[0] = 0.5f;
		break;
	case BC_OP_MIRROR:
		u->u[0] = 1.0f;
		break;
	case BC_OP_REPEAT:
		u->u[0] = u->u[1] = u->u[2] = 2.0f;
		u->u[3] = 3.0f;
		u->u[4] = u->u[5] = 1.0f;
		break;
	case BC_OP_SCALE:
		u->u[0] = 1.0f;
		break;
	default:
		break;
	}
}

int bc_unary_validate(const struct bc_unary *u, struct bc_errinfo *ei)
{
	const struct bc_unary_info *info = bc_unary_info(u->kind);
	if (!info) {
		return bc_errinfo_set(
		    ei, BC_EENUM, "unknown unary node kind %d", (int)u->kind);
	}
	for (int i = 0; i < BC_UNARY_MAX_PARAMS; i++) {
		if (!isfinite(u->u[i])) {
			return bc_errinfo_set(ei, BC_ENONFINITE,
			                      "%s: parameters must be finite",
			                      info->name);
		}
		if (fabsf(u->u[i]) > BC_PARAM_MAX_ABS) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s: |parameter| %g above %g",
			                      info->name, (double)u->u[i],
			                      (double)BC_PARAM_MAX_ABS);
		}
		if (i >= info->nparams && u->u[i] != 0.0f) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "%s takes %u parameters",
			                      info->name, info->nparams);
		}
	}
	switch (u->kind) {
	case BC_OP_ONION:
		if (!(u->u[0] >= 0.0f)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "onion: thickness %g must be "
			                      ">= 0",
			                      (double)u->u[0]);
		}
		break;
	case BC_OP_ELONGATE:
		for (int i = 0; i < 3; i++) {
			if (!(u->u[i] >= 0.0f)) {
				return bc_errinfo_set(ei, BC_ERANGE,
				                      "elongate: half_extents "
				                      "must be >= 0");
			}
		}
		break;
	case BC_OP_MIRROR:
		if (!(u->u[0] >= 1.0f && u->u[0] <= 7.0f &&
		      u->u[0] == floorf(u->u[0]))) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "mirror: axes must name 1 to 3 "
			                      "of x, y, z");
		}
		break;
	case BC_OP_REPEAT:
		for (int i = 0; i < 3; i++) {
			float c = u->u[3 + i], sp = u->u[i];
			if (!(c >= 1.0f && c <= (float)BC_REPEAT_MAX_COUNT &&
			      c == floorf(c))) {
				return bc_errinfo_set(ei, BC_ERANGE,
				                      "repeat: count %g must "
				                      "be an integer in 1..%u",
				                      (double)c,
				                      BC_REPEAT_MAX_COUNT);
			}
			if (c > 1.0f ? !(sp > 0.0f) : !(sp >= 0.0f)) {
				return bc_errinfo_set(ei, BC_ERANGE,
				                      "repeat: spacing %g must "
				                      "be > 0 where count > 1 "
				                      "(>= 0 elsewhere)",
				                      (double)sp);
			}
		}
		break;
	case BC_OP_SCALE:
		if (!(u->u[0] >= 1.0e-3f)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "scale: factor %g must be >= "
			                      "0.001",
			                      (double)u->u[0]);
		}
		break;
	default:
		break;
	}
	return 0;
}

const char *bc_op_name(enum bc_op kind)
{
	if (kind <= BC_OP_INVALID || kind >= BC_OP_COUNT) {
		return NULL;
	}
	return op_names[kind];
}

enum bc_op bc_op_from_name(const char *name)
{
	for (int k = BC_OP_INVALID + 1; k < BC_OP_COUNT; k++) {
		if (strcmp(name, op_names[k]) == 0) {
			return (enum bc_op)k;
		}
	}
	return BC_OP_INVALID;
}

enum bc_op_class bc_op_class(enum bc_op kind)
{
	switch (kind) {
	case BC_OP_INTERSECTION:
	case BC_OP_SMOOTH_INTERSECTION:
		return BC_OPCLASS_INTERSECTION;
	case BC_OP_DIFFERENCE:
	case BC_OP_SMOOTH_DIFFERENCE:
		return BC_OPCLASS_DIFFERENCE;
	default:
		return BC_OPCLASS_UNION;
	}
}

bool bc_op_is_smooth(enum bc_op kind)
{
	return kind == BC_OP_SMOOTH_UNION ||
	       kind == BC_OP_SMOOTH_INTERSECTION ||
	       kind == BC_OP_SMOOTH_DIFFERENCE;
}

/*
 * With r_o = 7/6 beta the union's blend closes exactly on the range boundary
 * (the smallest r_o for which G_union is continuous; intersection and
 * difference need r_o >= beta). The default keeps a margin above it so that
 * rounding never opens a seam. docs/operators.md derives the bound.
 */
float bc_op_default_range(float blend)
{
	return 1.25f * blend;
}

int bc_op_validate(const struct bc_op_data *op, struct bc_errinfo *ei)
{
	const char *name = bc_op_name(op->kind);
	if (!name) {
		return bc_errinfo_set(ei, BC_EENUM, "unknown operator kind %d",
		                      (int)op->kind);
	}
	if (bc_op_is_unary(op->kind)) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "%s is a unary node, not a binary "
		                      "operator",
		                      name);
	}
	if (!isfinite(op->blend) || !isfinite(op->range)) {
		return bc_errinfo_set(ei, BC_ENONFINITE,
		                      "%s: blend and range must be finite",
		                      name);
	}
	if (!bc_op_is_smooth(op->kind)) {
		return 0;
	}
	if (!(op->blend > 0.0f) || op->blend > BC_PARAM_MAX_ABS) {
		return bc_errinfo_set(
		    ei, BC_ERANGE, "%s: blend %g must be in (0, %g]", name,
		    (double)op->blend, (double)BC_PARAM_MAX_ABS);
	}
	/* b_r divides by 6 r_o - beta: the range must exceed beta / 6. */
	if (!(6.0f * op->range - op->blend > 0.0f) ||
	    op->range > BC_PARAM_MAX_ABS) {
		return bc_errinfo_set(
		    ei, BC_ERANGE, "%s: range %g must exceed blend / 6 = %g",
		    name, (double)op->range, (double)(op->blend / 6.0f));
	}
	return 0;
}

/* Eq. 9: the polynomial blend amount, 0 when beta is 0. */
static float blend_amount(float f0, float f1, float beta)
{
	float h;
	if (!(beta > 0.0f)) {
		return 0.0f;
	}
	h = 1.0f - fabsf(f0 - f1) / beta;
	if (!(h > 0.0f)) {
		return 0.0f;
	}
	return beta / 6.0f * h * h * h;
}

/* Eq. 18. Written with comparisons so that a NaN (never expected: the
 * denominator is checked) or a non-positive denominator gives 0. */
static float transition(float x, float beta, float range)
{
	float den = 6.0f * range - beta;
	float t;
	if (!(den > 0.0f)) {
		return 0.0f;
	}
	t = 1.0f - 6.0f * x / den;
	return t > 0.0f ? beta * t : 0.0f;
}

static float g_union(float f0, float f1, float beta)
{
	return bc_op_min(f0, f1) - blend_amount(f0, f1, beta);
}

static float g_inter(float f0, float f1, float beta)
{
	return bc_op_max(f0, f1) + blend_amount(f0, f1, beta);
}

static float g_diff(float f0, float f1, float beta)
{
	return bc_op_max(f0, -f1) + blend_amount(f0, -f1, beta);
}

float bc_op_eval(enum bc_op kind, float blend, float range, float f0, float f1)
{
	switch (kind) {
	case BC_OP_UNION:
		return bc_op_min(f0, f1);
	case BC_OP_INTERSECTION:
		return bc_op_max(f0, f1);
	case BC_OP_DIFFERENCE:
		return bc_op_max(f0, -f1);
	case BC_OP_SMOOTH_UNION:
		/* R_o = (-inf, r_o]: eq. 12 and 17. */
		if (f0 <= range && f1 <= range) {
			float b =
			    transition(g_union(f0, f1, blend), blend, range);
			return g_union(f0, f1, b);
		}
		return bc_op_min(f0, f1);
	case BC_OP_SMOOTH_INTERSECTION:
		/* R_o = [-r_o, r_o]; b_r takes |g| (§4). */
		if (fabsf(f0) <= range && fabsf(f1) <= range) {
			float b = transition(fabsf(g_inter(f0, f1, blend)),
			                     blend, range);
			return g_inter(f0, f1, b);
		}
		return bc_op_max(f0, f1);
	case BC_OP_SMOOTH_DIFFERENCE:
		if (fabsf(f0) <= range && fabsf(f1) <= range) {
			float b = transition(fabsf(g_diff(f0, f1, blend)),
			                     blend, range);
			return g_diff(f0, f1, b);
		}
		return bc_op_max(f0, -f1);
	default:
		return INFINITY;
	}
}
