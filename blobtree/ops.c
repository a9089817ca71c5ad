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
};

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
	return kind == BC_OP_SMOOTH_UNION || kind == BC_OP_SMOOTH_INTERSECTION ||
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
	if (!isfinite(op->blend) || !isfinite(op->range)) {
		return bc_errinfo_set(ei, BC_ENONFINITE,
				      "%s: blend and range must be finite",
				      name);
	}
	if (!bc_op_is_smooth(op->kind)) {
		return 0;
	}
	if (!(op->blend > 0.0f) || op->blend > BC_PARAM_MAX_ABS) {
		return bc_errinfo_set(ei, BC_ERANGE,
				      "%s: blend %g must be in (0, %g]", name,
				      (double)op->blend,
				      (double)BC_PARAM_MAX_ABS);
	}
	/* b_r divides by 6 r_o - beta: the range must exceed beta / 6. */
	if (!(6.0f * op->range - op->blend > 0.0f) ||
	    op->range > BC_PARAM_MAX_ABS) {
		return bc_errinfo_set(ei, BC_ERANGE,
				      "%s: range %g must exceed blend / 6 = %g",
				      name, (double)op->range,
				      (double)(op->blend / 6.0f));
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
	return fminf(f0, f1) - blend_amount(f0, f1, beta);
}

static float g_inter(float f0, float f1, float beta)
{
	return fmaxf(f0, f1) + blend_amount(f0, f1, beta);
}

static float g_diff(float f0, float f1, float beta)
{
	return fmaxf(f0, -f1) + blend_amount(f0, -f1, beta);
}

float bc_op_eval(enum bc_op kind, float blend, float range, float f0, float f1)
{
	switch (kind) {
	case BC_OP_UNION:
		return fminf(f0, f1);
	case BC_OP_INTERSECTION:
		return fmaxf(f0, f1);
	case BC_OP_DIFFERENCE:
		return fmaxf(f0, -f1);
	case BC_OP_SMOOTH_UNION:
		/* R_o = (-inf, r_o]: eq. 12 and 17. */
		if (f0 <= range && f1 <= range) {
			float b = transition(g_union(f0, f1, blend), blend,
					     range);
			return g_union(f0, f1, b);
		}
		return fminf(f0, f1);
	case BC_OP_SMOOTH_INTERSECTION:
		/* R_o = [-r_o, r_o]; b_r takes |g| (§4). */
		if (fabsf(f0) <= range && fabsf(f1) <= range) {
			float b = transition(fabsf(g_inter(f0, f1, blend)),
					     blend, range);
			return g_inter(f0, f1, b);
		}
		return fmaxf(f0, f1);
	case BC_OP_SMOOTH_DIFFERENCE:
		if (fabsf(f0) <= range && fabsf(f1) <= range) {
			float b = transition(fabsf(g_diff(f0, f1, blend)),
					     blend, range);
			return g_diff(f0, f1, b);
		}
		return fmaxf(f0, -f1);
	default:
		return INFINITY;
	}
}
