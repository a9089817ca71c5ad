/* Operators: sharp selectors, the compact smooth G operators of Zanni 2024
 * eq. 8-18, missing operands, continuity across the range boundary. */
#include "blobcast/blobtree.h"
#include "test.h"

static const enum bc_op all_ops[] = {
    BC_OP_UNION,        BC_OP_INTERSECTION,        BC_OP_DIFFERENCE,
    BC_OP_SMOOTH_UNION, BC_OP_SMOOTH_INTERSECTION, BC_OP_SMOOTH_DIFFERENCE,
};
#define NOPS (sizeof(all_ops) / sizeof(all_ops[0]))

static void sharp_operators_select(void)
{
	CHECK(bc_op_eval(BC_OP_UNION, 0, 0, 1.0f, -2.0f) == -2.0f);
	CHECK(bc_op_eval(BC_OP_INTERSECTION, 0, 0, 1.0f, -2.0f) == 1.0f);
	CHECK(bc_op_eval(BC_OP_DIFFERENCE, 0, 0, 1.0f, -2.0f) == 2.0f);
	CHECK(bc_op_eval(BC_OP_DIFFERENCE, 0, 0, -1.0f, 0.5f) == -0.5f);
}

static void missing_operand_is_selected_away(void)
{
	const float inf = INFINITY;
	for (size_t i = 0; i < NOPS; i++) {
		enum bc_op op = all_ops[i];
		float r0 = bc_op_eval(op, 0.3f, 0.4f, 0.05f, inf);
		float r1 = bc_op_eval(op, 0.3f, 0.4f, inf, 0.05f);
		switch (bc_op_class(op)) {
		case BC_OPCLASS_UNION:
			CHECK(r0 == 0.05f && r1 == 0.05f);
			break;
		case BC_OPCLASS_INTERSECTION:
			CHECK(r0 == inf && r1 == inf);
			break;
		default:
			CHECK(r0 == 0.05f && r1 == inf);
			break;
		}
		CHECK(bc_op_eval(op, 0.3f, 0.4f, inf, inf) == inf);
	}
}

/* g_union(a, b, beta) = 0 on its zero set; there b_r = beta and G equals the
 * plain polynomial blend (eq. 17-18). */
static void smooth_union_keeps_the_classic_blend_on_the_surface(void)
{
	float beta = 0.6f;
	/* a = b = beta/6 gives min - d = beta/6 - beta/6 = 0. */
	float a = beta / 6.0f;
	CHECK_NEAR(bc_op_eval(BC_OP_SMOOTH_UNION, beta, 2.0f * beta, a, a),
	           0.0f, 1e-6f);
	/* Far outside the range the operators are the sharp ones. */
	CHECK(bc_op_eval(BC_OP_SMOOTH_UNION, beta, beta, 5.0f, 4.0f) == 4.0f);
	CHECK(bc_op_eval(BC_OP_SMOOTH_INTERSECTION, beta, beta, 5.0f, 4.0f) ==
	      5.0f);
	CHECK(bc_op_eval(BC_OP_SMOOTH_DIFFERENCE, beta, beta, 5.0f, 4.0f) ==
	      5.0f);
	/* Inside the blend the union is below both operands. */
	CHECK(bc_op_eval(BC_OP_SMOOTH_UNION, beta, beta, 0.1f, 0.12f) < 0.1f);
	CHECK(bc_op_eval(BC_OP_SMOOTH_INTERSECTION, beta, beta, 0.1f, 0.12f) >
	      0.12f);
}

/* Walk each edge of the range square for ranges at and above the smallest
 * continuous one (7/6 beta): the jump across the boundary must vanish with
 * the step. A range below it must show a jump (the test can fail). */
static float worst_jump(enum bc_op op, float beta, float ro)
{
	float worst = 0.0f, h = 1e-4f;
	for (int i = 0; i <= 4000; i++) {
		float t = -4.0f * ro + 8.0f * ro * (float)i / 4000.0f;
		float edges[2] = {ro, -ro};
		for (int e = 0; e < 2; e++) {
			float in = edges[e] * (1.0f - h),
			      out = edges[e] * (1.0f + h);
			float j0 = fabsf(bc_op_eval(op, beta, ro, in, t) -
			                 bc_op_eval(op, beta, ro, out, t));
			float j1 = fabsf(bc_op_eval(op, beta, ro, t, in) -
			                 bc_op_eval(op, beta, ro, t, out));
			worst = fmaxf(worst, fmaxf(j0, j1));
		}
	}
	return worst;
}

static void smooth_operators_are_continuous_across_the_range(void)
{
	float beta = 0.5f;
	for (size_t i = 3; i < NOPS; i++) {
		CHECK(worst_jump(all_ops[i], beta, bc_op_default_range(beta)) <
		      1e-3f * beta);
		CHECK(worst_jump(all_ops[i], beta, 2.0f * beta) < 1e-3f * beta);
	}
	/* Below 7/6 beta the union's blend is still open at the boundary. */
	CHECK(worst_jump(BC_OP_SMOOTH_UNION, beta, 0.5f * beta) > 1e-2f * beta);
}

static void validation_rejects_bad_parameters(void)
{
	struct bc_errinfo ei = {0};
	struct bc_op_data ok = {BC_OP_SMOOTH_UNION, 0.2f, 0.3f};
	struct bc_op_data nan = {BC_OP_SMOOTH_UNION, NAN, 0.3f};
	struct bc_op_data tiny = {BC_OP_SMOOTH_UNION, 0.6f, 0.05f};
	struct bc_op_data neg = {BC_OP_SMOOTH_INTERSECTION, -0.1f, 0.3f};
	CHECK(bc_op_validate(&ok, &ei) == 0);
	CHECK(bc_op_validate(&nan, &ei) == BC_ENONFINITE);
	CHECK(bc_op_validate(&tiny, &ei) == BC_ERANGE);
	CHECK(strstr(ei.msg, "range") != NULL);
	CHECK(bc_op_validate(&neg, &ei) == BC_ERANGE);
	CHECK(bc_op_from_name("smooth_difference") == BC_OP_SMOOTH_DIFFERENCE);
	CHECK(bc_op_from_name("smooth") == BC_OP_INVALID);
}

static const struct bc_test tests[] = {
    {"sharp_operators_select", sharp_operators_select},
    {"missing_operand_is_selected_away", missing_operand_is_selected_away},
    {"smooth_union_keeps_the_classic_blend_on_the_surface",
     smooth_union_keeps_the_classic_blend_on_the_surface},
    {"smooth_operators_are_continuous_across_the_range",
     smooth_operators_are_continuous_across_the_range},
    {"validation_rejects_bad_parameters", validation_rejects_bad_parameters},
};
BC_TEST_MAIN(tests)
