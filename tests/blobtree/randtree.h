/*
 * Random blobtrees for property tests: every operator kind, a few primitive
 * kinds with random rigid transforms, nested up to a small depth. Built with
 * the public builder; deterministic from a seed.
 */
#ifndef BLOBCAST_TESTS_RANDTREE_H
#define BLOBCAST_TESTS_RANDTREE_H

#include <stdint.h>

#include "blobcast/blobtree.h"

static uint64_t rt_state;

static uint64_t rt_next(void)
{
	uint64_t z = (rt_state += 0x9e3779b97f4a7c15ull);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

/* Uniform in [lo, hi). */
static float rt_float(float lo, float hi)
{
	return lo + (hi - lo) * (float)(rt_next() >> 40) / (float)(1u << 24);
}

static uint32_t rt_below(uint32_t n)
{
	return (uint32_t)(rt_next() % n);
}

static void rt_random_quat(float q[4])
{
	float n = 0.0f;
	do {
		n = 0.0f;
		for (int i = 0; i < 4; i++) {
			q[i] = rt_float(-1.0f, 1.0f);
			n += q[i] * q[i];
		}
	} while (n < 0.05f || n > 1.0f);
	n = sqrtf(n);
	for (int i = 0; i < 4; i++) {
		q[i] /= n;
	}
}

/* The share of primitives drawn from every kind below; the others are
 * spheres (a layout of spheres alone keeps sphere ABVs alone). */
static float rt_other_kinds = 1.0f;

static void rt_random_prim(struct bc_prim_data *p)
{
	static const enum bc_prim kinds[] = {BC_PRIM_SPHERE, BC_PRIM_BOX,
	                                     BC_PRIM_CAPSULE, BC_PRIM_TORUS};
	enum bc_prim kind = kinds[rt_below(4)];
	if (rt_other_kinds < 1.0f && rt_float(0.0f, 1.0f) >= rt_other_kinds) {
		kind = BC_PRIM_SPHERE;
	}
	memset(p, 0, sizeof(*p));
	p->kind = kind;
	p->rotate[3] = 1.0f;
	switch (kind) {
	case BC_PRIM_SPHERE:
		p->params[0] = rt_float(0.2f, 0.7f);
		break;
	case BC_PRIM_BOX:
		for (int i = 0; i < 3; i++) {
			p->params[i] = rt_float(0.15f, 0.6f);
		}
		p->params[3] = rt_below(2) ? 0.05f : 0.0f;
		rt_random_quat(p->rotate);
		break;
	case BC_PRIM_CAPSULE:
		for (int i = 0; i < 3; i++) {
			p->params[i] = rt_float(-0.5f, 0.5f);
			p->params[3 + i] = rt_float(-0.5f, 0.5f);
		}
		p->params[6] = rt_float(0.1f, 0.3f);
		break;
	default:
		p->params[0] = rt_float(0.3f, 0.6f);
		p->params[1] = rt_float(0.08f, 0.2f);
		rt_random_quat(p->rotate);
		break;
	}
	for (int i = 0; i < 3; i++) {
		p->translate[i] = rt_float(-1.2f, 1.2f);
	}
	p->has_color = true;
	p->color[0] = rt_float(0.0f, 1.0f);
	p->color[1] = rt_float(0.0f, 1.0f);
	p->color[2] = rt_float(0.0f, 1.0f);
}

/* Whether the binary operators drawn are unions alone (sharp or smooth);
 * false: any binary kind. */
static bool rt_unions_only;

static void rt_random_op(struct bc_op_data *op)
{
	op->kind = rt_unions_only
	               ? (rt_below(2) ? BC_OP_UNION : BC_OP_SMOOTH_UNION)
	               : (enum bc_op)(1 + rt_below(BC_OP_FIRST_UNARY - 1));
	op->blend = bc_op_is_smooth(op->kind) ? rt_float(0.05f, 0.4f) : 0.0f;
	op->range =
	    bc_op_is_smooth(op->kind) ? op->blend * rt_float(1.2f, 2.0f) : 0.0f;
}

/* Probability that a subtree is wrapped in a random unary node (0: the
 * random stream, and so every tree, is the one without unary nodes). */
static float rt_unary_rate;
/* Unary kinds drawn: bit (kind - BC_OP_FIRST_UNARY); 0 means all. */
static uint32_t rt_unary_kinds;

static void rt_random_unary(struct bc_unary *u)
{
	enum bc_op kind;
	do {
		kind = (enum bc_op)(BC_OP_FIRST_UNARY +
		                    rt_below(BC_OP_COUNT - BC_OP_FIRST_UNARY));
	} while (rt_unary_kinds &&
	         !(rt_unary_kinds & (1u << (kind - BC_OP_FIRST_UNARY))));
	bc_unary_init(u, kind);
	switch (kind) {
	case BC_OP_OFFSET:
		u->u[0] = rt_float(-0.05f, 0.2f);
		break;
	case BC_OP_ONION:
		u->u[0] = rt_float(0.02f, 0.1f);
		break;
	case BC_OP_ELONGATE:
		for (int i = 0; i < 3; i++) {
			u->u[i] = rt_below(2) ? rt_float(0.0f, 0.4f) : 0.0f;
		}
		break;
	case BC_OP_TWIST:
		u->u[0] = rt_float(-1.5f, 1.5f);
		break;
	case BC_OP_BEND:
		u->u[0] = rt_float(-0.8f, 0.8f);
		break;
	case BC_OP_MIRROR:
		u->u[0] = (float)(1 + rt_below(7));
		break;
	case BC_OP_REPEAT:
		for (int i = 0; i < 3; i++) {
			u->u[i] = rt_float(1.0f, 2.0f);
			u->u[3 + i] = (float)(1 + rt_below(3));
		}
		break;
	default:
		u->u[0] = rt_float(0.5f, 1.5f);
		break;
	}
}

static int rt_emit_node(struct bc_tree *t, uint32_t budget, uint32_t depth);

/* Emits a subtree with `budget` primitives (>= 1), wrapped in a random
 * unary node at rate rt_unary_rate. Returns 0 or an error. */
static int rt_emit(struct bc_tree *t, uint32_t budget, uint32_t depth)
{
	struct bc_unary u;
	int rc;
	if (rt_unary_rate > 0.0f && rt_float(0.0f, 1.0f) < rt_unary_rate) {
		rt_random_unary(&u);
		if ((rc = bc_tree_push_unary(t, 0, &u, NULL)) ||
		    (rc = rt_emit_node(t, budget, depth))) {
			return rc;
		}
		return bc_tree_pop_op(t, NULL);
	}
	return rt_emit_node(t, budget, depth);
}

static int rt_emit_node(struct bc_tree *t, uint32_t budget, uint32_t depth)
{
	int rc;
	if (budget == 1 || depth >= 6) {
		struct bc_prim_data p;
		rt_random_prim(&p);
		if (budget > 1) {
			/* Depth exhausted: fold the rest into one union. */
			struct bc_op_data u = {BC_OP_UNION, 0, 0};
			if ((rc = bc_tree_push_op(t, 0, &u, NULL))) {
				return rc;
			}
			for (uint32_t i = 0; i < budget; i++) {
				rt_random_prim(&p);
				if ((rc = bc_tree_put_prim(t, 0, &p, NULL))) {
					return rc;
				}
			}
			return bc_tree_pop_op(t, NULL);
		}
		return bc_tree_put_prim(t, 0, &p, NULL);
	}
	{
		struct bc_op_data op;
		uint32_t nchild = 2 + rt_below(budget < 4 ? budget - 1 : 3);
		uint32_t left = budget;
		rt_random_op(&op);
		if ((rc = bc_tree_push_op(t, 0, &op, NULL))) {
			return rc;
		}
		for (uint32_t c = 0; c < nchild; c++) {
			uint32_t share =
			    (c + 1 == nchild)
			        ? left
			        : 1 + rt_below(left - (nchild - c - 1));
			if ((rc = rt_emit(t, share, depth + 1))) {
				return rc;
			}
			left -= share;
		}
		return bc_tree_pop_op(t, NULL);
	}
}

/* A random tree of nprims primitives from seed. */
static int rt_build(struct bc_tree *t, uint64_t seed, uint32_t nprims)
{
	int rc;
	rt_state = seed;
	bc_tree_begin(t);
	if ((rc = rt_emit(t, nprims, 0))) {
		return rc;
	}
	return bc_tree_end(t, NULL);
}

#endif
