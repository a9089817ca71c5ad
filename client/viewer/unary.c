/*
 * Alt+wheel on the unary and domain nodes (docs/scene-format.md, "Unary and
 * domain nodes"): which node above the selection it edits, and what one
 * notch does to that node's main parameter. The rules follow the browser
 * page's sliders (client/web/prims.js, unaryRange): sizes that must stay
 * positive or non-negative (onion's thickness, elongate's half extents,
 * repeat's spacing, scale's factor) scale, so that a notch means the same
 * at every size and never crosses 0; signed values (offset's amount,
 * twist's and bend's rates) move by steps proportioned to the shape the
 * node wraps, so that a few notches show on any scene.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "viewer.h"

/* The smallest scale factor bc_unary_validate accepts. */
#define BC_VIEWER_SCALE_MIN 1e-3f

bool bc_viewer_unary_param(enum bc_op kind, struct bc_viewer_unary_param *out)
{
	const struct bc_unary_info *info = bc_unary_info(kind);
	memset(out, 0, sizeof(*out));
	if (!info || kind == BC_OP_MIRROR) {
		return false;
	}
	out->name = info->param;
	out->count = 1;
	switch (kind) {
	case BC_OP_OFFSET:
	case BC_OP_TWIST:
	case BC_OP_BEND:
		out->rule = BC_VIEWER_NOTCH_ADD;
		break;
	case BC_OP_ELONGATE:
	case BC_OP_REPEAT: /* its spacing; the counts stay */
		out->rule = BC_VIEWER_NOTCH_SCALE;
		out->count = 3;
		out->lo = BC_VIEWER_NOTCH_MIN;
		break;
	case BC_OP_SCALE:
		out->rule = BC_VIEWER_NOTCH_SCALE;
		out->lo = BC_VIEWER_SCALE_MIN;
		break;
	default: /* onion */
		out->rule = BC_VIEWER_NOTCH_SCALE;
		out->lo = BC_VIEWER_NOTCH_MIN;
		break;
	}
	return true;
}

uint32_t bc_viewer_unary_target(const struct bc_tree *t, uint32_t id,
                                struct bc_unary *out)
{
	struct bc_viewer_unary_param p;
	memset(out, 0, sizeof(*out));
	if (!t) {
		return 0;
	}
	/* bc_tree_parent is 0 at the root: the climb ends there. */
	for (uint32_t a = bc_tree_parent(t, id); a; a = bc_tree_parent(t, a)) {
		if (bc_tree_get_unary(t, a, out) &&
		    bc_viewer_unary_param(out->kind, &p)) {
			return a;
		}
	}
	memset(out, 0, sizeof(*out));
	return 0;
}

float bc_viewer_unary_extent(const struct bc_tree *t, uint32_t id)
{
	float lo[3], hi[3], d[3], e;
	struct bc_unary u;
	/* A unary node takes no slot: its primitives are its child's. */
	if (!t || bc_tree_child_count(t, id) != 1 ||
	    !bc_viewer_node_box(t, bc_tree_child(t, id, 0), lo, hi)) {
		return 1.0f;
	}
	for (int i = 0; i < 3; i++) {
		d[i] = hi[i] - lo[i];
	}
	e = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
	/* The parameter is in the node's units: a scale node above
	 * magnifies what the world box shows. */
	for (uint32_t a = bc_tree_parent(t, id); a; a = bc_tree_parent(t, a)) {
		if (bc_tree_get_unary(t, a, &u) && u.kind == BC_OP_SCALE &&
		    u.u[0] > 0.0f) {
			e /= u.u[0];
		}
	}
	return isfinite(e) ? fmaxf(e, 1e-3f) : 1.0f;
}

static float clampf(float v, float lo, float hi)
{
	return fminf(fmaxf(v, lo), hi);
}

void bc_viewer_unary_notch(enum bc_op kind, float *v, float notches,
                           float extent)
{
	struct bc_viewer_unary_param p;
	float step;
	bool zero = true;
	if (!bc_viewer_unary_param(kind, &p) || !(extent > 0.0f)) {
		return;
	}
	if (p.rule == BC_VIEWER_NOTCH_ADD) {
		step = kind == BC_OP_OFFSET ? BC_VIEWER_OFFSET_STEP * extent
		                            : BC_VIEWER_RATE_STEP / extent;
		v[0] = clampf(v[0] + notches * step, -BC_PARAM_MAX_ABS,
		              BC_PARAM_MAX_ABS);
		return;
	}
	for (uint32_t i = 0; i < p.count; i++) {
		zero = zero && v[i] == 0.0f;
	}
	if (zero && notches > 0.0f) {
		/* Nothing to scale yet: start from a small size. */
		for (uint32_t i = 0; i < p.count; i++) {
			v[i] = clampf(BC_VIEWER_SEED_STEP * extent, p.lo,
			              BC_PARAM_MAX_ABS);
		}
		return;
	}
	for (uint32_t i = 0; i < p.count; i++) {
		/* A 0 stays 0 (an axis not elongated, a repeat's single
		 * copy); the others never reach it. */
		if (v[i] != 0.0f) {
			v[i] = clampf(v[i] * expf(notches * 0.1f), p.lo,
			              BC_PARAM_MAX_ABS);
		}
	}
}

const char *bc_viewer_unary_text(const struct bc_unary *u, char *out, size_t n)
{
	const struct bc_unary_info *info = bc_unary_info(u->kind);
	struct bc_viewer_unary_param p;
	if (!n) {
		return out;
	}
	out[0] = '\0';
	if (!info) {
		return out;
	}
	if (u->kind == BC_OP_MIRROR) {
		char axes[4];
		bc_mirror_axes_name((uint32_t)clampf(u->u[0], 0.0f, 7.0f),
		                    axes);
		snprintf(out, n, "%s %s %s", info->name, info->param, axes);
	} else if (bc_viewer_unary_param(u->kind, &p) && p.count == 3) {
		snprintf(out, n, "%s %s %.3g,%.3g,%.3g", info->name, p.name,
		         (double)u->u[0], (double)u->u[1], (double)u->u[2]);
	} else {
		snprintf(out, n, "%s %s %.3g", info->name, info->param,
		         (double)u->u[0]);
	}
	return out;
}
