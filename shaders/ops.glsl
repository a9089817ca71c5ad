// The blobtree operators (Zanni 2024 Sec. 4), as blobtree/ops.c computes them:
// sharp union, intersection and difference, and the compact smooth operators
// G built from the C2 polynomial blend (eq. 8-11) closed by the transition
// b_r (eq. 17-18). NaN never reaches a result: every test that could see one
// is written as a comparison that fails on NaN (!(x > 0.0)), because GLSL
// does not promise isnan() survives the compiler.

// Eq. 9: the blend amount, 0 when beta is not positive.
float bc_blend_amount(float f0, float f1, float beta)
{
	if (!(beta > 0.0)) {
		return 0.0;
	}
	float h = 1.0 - abs(f0 - f1) / beta;
	if (!(h > 0.0)) {
		return 0.0;
	}
	return beta / 6.0 * h * h * h;
}

// Eq. 18, 0 for a non-positive denominator.
float bc_transition(float x, float beta, float range)
{
	float den = 6.0 * range - beta;
	if (!(den > 0.0)) {
		return 0.0;
	}
	float t = 1.0 - 6.0 * x / den;
	return t > 0.0 ? beta * t : 0.0;
}

float bc_g_union(float f0, float f1, float beta)
{
	return min(f0, f1) - bc_blend_amount(f0, f1, beta);
}

float bc_g_inter(float f0, float f1, float beta)
{
	return max(f0, f1) + bc_blend_amount(f0, f1, beta);
}

float bc_g_diff(float f0, float f1, float beta)
{
	return max(f0, -f1) + bc_blend_amount(f0, -f1, beta);
}

// bc_op_eval: operator kind on the left operand f0 and the right one f1.
float bc_op_eval(uint kind, float blend, float range, float f0, float f1)
{
	switch (kind) {
	case BC_OP_UNION:
		return min(f0, f1);
	case BC_OP_INTERSECTION:
		return max(f0, f1);
	case BC_OP_DIFFERENCE:
		return max(f0, -f1);
	case BC_OP_SMOOTH_UNION:
		if (f0 <= range && f1 <= range) {
			float b = bc_transition(bc_g_union(f0, f1, blend),
						blend, range);
			return bc_g_union(f0, f1, b);
		}
		return min(f0, f1);
	case BC_OP_SMOOTH_INTERSECTION:
		if (abs(f0) <= range && abs(f1) <= range) {
			float b = bc_transition(abs(bc_g_inter(f0, f1, blend)),
						blend, range);
			return bc_g_inter(f0, f1, b);
		}
		return max(f0, f1);
	case BC_OP_SMOOTH_DIFFERENCE:
		if (abs(f0) <= range && abs(f1) <= range) {
			float b = bc_transition(abs(bc_g_diff(f0, f1, blend)),
						blend, range);
			return bc_g_diff(f0, f1, b);
		}
		return max(f0, -f1);
	default:
		return BC_INF;
	}
}

// Operand selection class of an operator (the node word's ignoreMod).
uint bc_op_class(uint kind)
{
	if (kind == BC_OP_INTERSECTION || kind == BC_OP_SMOOTH_INTERSECTION) {
		return BC_OPCLASS_INTERSECTION;
	}
	if (kind == BC_OP_DIFFERENCE || kind == BC_OP_SMOOTH_DIFFERENCE) {
		return BC_OPCLASS_DIFFERENCE;
	}
	return BC_OPCLASS_UNION;
}

// Whether the operator's value follows its right operand, for ids and
// colours: blobtree/eval.c's rule.
bool bc_follows_right(uint kind, float f0, float f1)
{
	uint cls = bc_op_class(kind);
	if (cls == BC_OPCLASS_UNION) {
		return f1 < f0;
	}
	if (cls == BC_OPCLASS_INTERSECTION) {
		return f1 > f0;
	}
	return -f1 > f0;
}
