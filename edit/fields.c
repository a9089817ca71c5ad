/*
 * The meaning of SET fields (PROTOCOL.md section 9) and of one operation on
 * a tree. The daemon applies edits with these functions and every mirror
 * replays them with the same ones: one mapping, so mirrors cannot drift.
 */
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "edit_impl.h"

/* The protocol repeats blobtree's kinds and limits (it must not include
 * blobtree's headers) and this module turns one into the other, so the
 * two are held together here, in a file every build compiles. */
_Static_assert(BC_PROTO_PRIM_KIND_MAX == BC_PRIM_COUNT - 1,
               "primitive kinds differ from blobtree's");
_Static_assert(BC_PROTO_OP_KIND_MAX == BC_OP_COUNT - 1,
               "operator kinds differ from blobtree's");
_Static_assert(BC_PROTO_OP_KIND_FIRST_UNARY == BC_OP_FIRST_UNARY,
               "the first unary kind differs from blobtree's");
_Static_assert(BC_PROTO_MAX_UNARY_PARAMS == BC_UNARY_MAX_PARAMS,
               "unary parameter limit differs from blobtree's");
_Static_assert(BC_PROTO_MAX_PRIM_PARAMS == BC_PRIM_MAX_PARAMS,
               "primitive parameter limit differs from blobtree's");
/* Float constants may appear in an integer constant expression only as
 * the operand of a cast (C11 6.6); both limits are whole numbers. */
_Static_assert((long)BC_PROTO_MAX_ABS == (long)BC_PARAM_MAX_ABS,
               "coordinate limit differs from blobtree's");
_Static_assert(BC_PROTO_SCENE_MAX_NODES == BC_TREE_MAX_NODES,
               "scene node limit differs from blobtree's");
_Static_assert(BC_PROTO_SCENE_MAX_DEPTH == BC_TREE_MAX_DEPTH,
               "scene depth limit differs from blobtree's");
/* Where the fields land: a field takes as many values as its array has. */
#define NFLOATS(member) (sizeof(member) / sizeof(float))
_Static_assert(NFLOATS(((struct bc_prim_data *)0)->translate) ==
                   BC_PROTO_FIELD_TRANSLATE_VALUES,
               "translate values");
_Static_assert(NFLOATS(((struct bc_prim_data *)0)->rotate) ==
                   BC_PROTO_FIELD_ROTATE_VALUES,
               "rotate values");
_Static_assert(NFLOATS(((struct bc_prim_data *)0)->color) ==
                   BC_PROTO_FIELD_COLOR_VALUES,
               "color values");
_Static_assert(BC_PROTO_FIELD_BLEND_VALUES == 1 &&
                   BC_PROTO_FIELD_RANGE_VALUES == 1 &&
                   BC_PROTO_FIELD_OP_KIND_VALUES == 1,
               "an operator's blend, range and kind are one float each");

/* Where field f of a primitive lands and how many values it takes, or NULL
 * when it does not apply to p's kind. */
static float *prim_field(struct bc_prim_data *p, uint8_t f, uint32_t *want)
{
	const struct bc_prim_info *info = bc_prim_info(p->kind);
	switch (f) {
	case BC_PROTO_FIELD_TRANSLATE:
		*want = BC_PROTO_FIELD_TRANSLATE_VALUES;
		return p->translate;
	case BC_PROTO_FIELD_ROTATE:
		*want = BC_PROTO_FIELD_ROTATE_VALUES;
		return p->rotate;
	case BC_PROTO_FIELD_COLOR:
		*want = BC_PROTO_FIELD_COLOR_VALUES;
		return p->color;
	default:
		break;
	}
	if (info && f >= BC_PROTO_FIELD_PARAM0 &&
	    f < BC_PROTO_FIELD_PARAM0 + info->nparams) {
		const struct bc_param_desc *d =
		    &info->params[f - BC_PROTO_FIELD_PARAM0];
		*want = d->count;
		return p->params + d->offset;
	}
	return NULL;
}

static int set_op_fields(const struct bc_proto_edit_op *e,
                         struct bc_op_data *op, struct bc_errinfo *ei)
{
	bool smooth_before = bc_op_is_smooth(op->kind);
	bool gave_blend = false, gave_range = false;
	for (uint32_t i = 0; i < e->nfields; i++) {
		const struct bc_proto_field *f = &e->fields[i];
		const struct bc_proto_field_info *info =
		    bc_proto_field_info(f->field);
		float k = f->v[0];
		if (!info || !(info->flags & BC_PROTO_ON_OP)) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "node %u: field %u does not "
			                      "apply to an operator",
			                      e->node, (unsigned)f->field);
		}
		if (f->count != info->max_values) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "node %u: field %u takes %u value%s, got %u",
			    e->node, (unsigned)f->field,
			    (unsigned)info->max_values,
			    info->max_values == 1 ? "" : "s",
			    (unsigned)f->count);
		}
		if (f->field == BC_PROTO_FIELD_BLEND) {
			op->blend = k;
			gave_blend = true;
		} else if (f->field == BC_PROTO_FIELD_RANGE) {
			op->range = k;
			gave_range = true;
		} else if (!(k >= 1.0f) ||
		           !(k <= (float)(BC_OP_FIRST_UNARY - 1)) ||
		           k != floorf(k)) {
			return bc_errinfo_set(ei, BC_EENUM,
			                      "node %u: operator kind %g is "
			                      "not an integer 1..%d",
			                      e->node, (double)k,
			                      BC_OP_FIRST_UNARY - 1);
		} else {
			op->kind = (enum bc_op)(int)k;
		}
	}
	if (!bc_op_is_smooth(op->kind)) {
		/* A sharp operator has neither blend nor range (the scene
		 * encoding carries 0 for both): a value for one is refused
		 * rather than dropped, and a smooth operator turns sharp
		 * only when the SET says both go to 0. */
		if (op->blend != 0.0f || op->range != 0.0f) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "node %u: a sharp operator (%s) has no blend "
			    "or range%s",
			    e->node, bc_op_name(op->kind),
			    smooth_before && !(gave_blend && gave_range)
			        ? "; give blend 0 and range 0 with "
			          "the kind"
			        : ": they must be 0");
		}
	}
	return 0;
}

/* Where field f of a unary node lands and how many values it takes: its
 * parameter keys in order (repeat: spacing, then count), NULL otherwise. */
static float *unary_field(struct bc_unary *u, uint8_t f, uint32_t *want)
{
	const struct bc_unary_info *info = bc_unary_info(u->kind);
	uint32_t k = (uint32_t)f - BC_PROTO_FIELD_PARAM0;
	if (!info || f < BC_PROTO_FIELD_PARAM0) {
		return NULL;
	}
	if (u->kind == BC_OP_REPEAT) {
		*want = 3;
		return k < 2 ? u->u + 3 * k : NULL;
	}
	*want = info->nparams;
	return k == 0 ? u->u : NULL;
}

int bc_edit_set_unary_fields(const struct bc_proto_edit_op *e,
                             struct bc_unary *u, struct bc_errinfo *ei)
{
	/* The kind first: a new kind starts from its defaults. */
	for (uint32_t i = 0; i < e->nfields; i++) {
		const struct bc_proto_field *f = &e->fields[i];
		float k = f->v[0];
		if (f->field != BC_PROTO_FIELD_OP_KIND) {
			continue;
		}
		if (f->count != 1 || !(k >= (float)BC_OP_FIRST_UNARY) ||
		    !(k <= (float)(BC_OP_COUNT - 1)) || k != floorf(k)) {
			return bc_errinfo_set(ei, BC_EENUM,
			                      "node %u: a unary node's kind "
			                      "must be one integer %d..%d",
			                      e->node, BC_OP_FIRST_UNARY,
			                      BC_OP_COUNT - 1);
		}
		if ((enum bc_op)(int)k != u->kind) {
			bc_unary_init(u, (enum bc_op)(int)k);
		}
	}
	for (uint32_t i = 0; i < e->nfields; i++) {
		const struct bc_proto_field *f = &e->fields[i];
		uint32_t want = 0;
		float *dst;
		if (f->field == BC_PROTO_FIELD_OP_KIND) {
			continue;
		}
		if (!(dst = unary_field(u, f->field, &want))) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "node %u: field %u does not "
			                      "apply to a %s node",
			                      e->node, (unsigned)f->field,
			                      bc_op_name(u->kind));
		}
		if (f->count != want) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "node %u: field %u takes %u "
			                      "values, got %u",
			                      e->node, (unsigned)f->field, want,
			                      (unsigned)f->count);
		}
		memcpy(dst, f->v, want * sizeof(float));
	}
	return 0;
}

void bc_edit_saved_restore(struct bc_tree *t, const struct bc_edit_saved *s)
{
	if (bc_op_is_unary(s->op.kind)) {
		bc_tree_set_unary(t, s->id, &s->un, NULL);
	} else if (s->op.kind != BC_OP_INVALID) {
		bc_tree_set_op(t, s->id, &s->op, NULL);
	} else {
		bc_tree_set_prim(t, s->id, &s->p, NULL);
	}
}

static void put_field(struct bc_proto_edit_op *e, struct bc_proto_field *f,
                      uint8_t field, const float *v, uint32_t n)
{
	struct bc_proto_field *out = &f[e->nfields++];
	out->field = field;
	out->count = (uint8_t)n;
	memcpy(out->v, v, n * sizeof(float));
}

void bc_edit_state_set(const struct bc_edit_saved *s, bool is_op,
                       struct bc_proto_edit_op *e,
                       struct bc_proto_field *fields)
{
	memset(e, 0, sizeof(*e));
	e->kind = BC_PROTO_EDIT_SET;
	e->node = s->id;
	e->fields = fields;
	if (is_op && bc_op_is_unary(s->op.kind)) {
		float kind = (float)s->op.kind;
		const struct bc_unary_info *info = bc_unary_info(s->op.kind);
		put_field(e, fields, BC_PROTO_FIELD_OP_KIND, &kind, 1);
		if (s->op.kind == BC_OP_REPEAT) {
			put_field(e, fields, BC_PROTO_FIELD_PARAM0, s->un.u, 3);
			put_field(e, fields, BC_PROTO_FIELD_PARAM0 + 1,
			          s->un.u + 3, 3);
		} else {
			put_field(e, fields, BC_PROTO_FIELD_PARAM0, s->un.u,
			          info->nparams);
		}
	} else if (is_op) {
		float kind = (float)s->op.kind;
		put_field(e, fields, BC_PROTO_FIELD_OP_KIND, &kind, 1);
		put_field(e, fields, BC_PROTO_FIELD_BLEND, &s->op.blend, 1);
		put_field(e, fields, BC_PROTO_FIELD_RANGE, &s->op.range, 1);
	} else {
		const struct bc_prim_info *info = bc_prim_info(s->p.kind);
		put_field(e, fields, BC_PROTO_FIELD_TRANSLATE, s->p.translate,
		          BC_PROTO_FIELD_TRANSLATE_VALUES);
		put_field(e, fields, BC_PROTO_FIELD_ROTATE, s->p.rotate,
		          BC_PROTO_FIELD_ROTATE_VALUES);
		for (uint32_t k = 0; info && k < info->nparams; k++) {
			put_field(e, fields,
			          (uint8_t)(BC_PROTO_FIELD_PARAM0 + k),
			          s->p.params + info->params[k].offset,
			          info->params[k].count);
		}
		if (s->p.has_color) {
			put_field(e, fields, BC_PROTO_FIELD_COLOR, s->p.color,
			          BC_PROTO_FIELD_COLOR_VALUES);
		}
	}
}

int bc_edit_set_fields(const struct bc_proto_edit_op *e, bool is_op,
                       struct bc_prim_data *p, struct bc_op_data *op,
                       struct bc_errinfo *ei)
{
	if (is_op) {
		return set_op_fields(e, op, ei);
	}
	for (uint32_t i = 0; i < e->nfields; i++) {
		const struct bc_proto_field *f = &e->fields[i];
		uint32_t want = 0;
		float *dst = prim_field(p, f->field, &want);
		if (!dst) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "node %u: field %u does not "
			                      "apply to a primitive of this "
			                      "kind",
			                      e->node, (unsigned)f->field);
		}
		if (f->count != want) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "node %u: field %u takes %u "
			                      "values, got %u",
			                      e->node, (unsigned)f->field, want,
			                      (unsigned)f->count);
		}
		if (f->field == BC_PROTO_FIELD_COLOR) {
			p->has_color = true;
		}
		memcpy(dst, f->v, want * sizeof(float));
	}
	return 0;
}

static int apply_set(struct bc_tree *t, const struct bc_proto_edit_op *e,
                     struct bc_errinfo *ei)
{
	struct bc_prim_data p;
	struct bc_op_data op;
	bool is_op;
	int rc;
	if (!bc_tree_get(t, e->node, &p, &op)) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u",
		                      e->node);
	}
	is_op = op.kind != BC_OP_INVALID;
	if (bc_op_is_unary(op.kind)) {
		struct bc_unary u;
		bc_tree_get_unary(t, e->node, &u);
		if ((rc = bc_edit_set_unary_fields(e, &u, ei))) {
			return rc;
		}
		return bc_tree_set_unary(t, e->node, &u, ei);
	}
	if ((rc = bc_edit_set_fields(e, is_op, &p, &op, ei))) {
		return rc;
	}
	return is_op ? bc_tree_set_op(t, e->node, &op, ei)
	             : bc_tree_set_prim(t, e->node, &p, ei);
}

uint32_t bc__edit_removed_top(const struct bc_tree *t, uint32_t id)
{
	struct bc_op_data op;
	uint32_t parent;
	if (!bc_tree_get(t, id, NULL, NULL)) {
		return 0;
	}
	while ((parent = bc_tree_parent(t, id)) != 0 &&
	       bc_tree_get(t, parent, NULL, &op) && bc_op_is_unary(op.kind)) {
		id = parent;
	}
	return id;
}

int bc_edit_apply_op(struct bc_tree *t, const struct bc_proto_edit_op *e,
                     struct bc_errinfo *ei)
{
	struct bc_proto_scene_info info;
	struct bc_tree *sub;
	uint32_t top;
	int rc;
	switch (e->kind) {
	case BC_PROTO_EDIT_SET:
		return apply_set(t, e, ei);
	case BC_PROTO_EDIT_REMOVE:
		if ((top = bc__edit_removed_top(t, e->node)) ==
		        bc_tree_root(t) &&
		    top != 0) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    top == e->node
			        ? "node %u is the root: a scene is never empty "
			          "(REPLACE it instead)"
			        : "removing node %u takes the unary nodes "
			          "above "
			          "it up to the root: a scene is never empty "
			          "(REPLACE the root instead)",
			    e->node);
		}
		return bc_tree_remove(t, e->node, ei);
	case BC_PROTO_EDIT_NAME:
		return bc_tree_set_name(t, e->node, e->name.ptr, e->name.len,
		                        ei);
	case BC_PROTO_EDIT_INSERT:
	case BC_PROTO_EDIT_REPLACE:
		break;
	default:
		return bc_errinfo_set(ei, BC_EENUM, "operation kind %d",
		                      (int)e->kind);
	}
	/* The decoder would name id-0 nodes itself, each member's decoder
	 * alike or not: refuse them from the bytes. */
	if ((rc = bc_proto_scene_scan(e->subtree.ptr, e->subtree.len, &info,
	                              ei))) {
		return rc;
	}
	if (info.zero_ids > 0) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "every node of an inserted or replacing "
		                      "subtree needs an explicit id (%u have "
		                      "id 0)",
		                      info.zero_ids);
	}
	if (!(sub = bc_tree_create())) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	rc = bc_scene_decode(e->subtree.ptr, e->subtree.len, sub, NULL, NULL,
	                     ei);
	if (!rc) {
		rc = e->kind == BC_PROTO_EDIT_INSERT
		         ? bc_tree_insert(t, e->node, e->position, sub, ei)
		         : bc_tree_replace(t, e->node, sub, ei);
	}
	bc_tree_destroy(sub);
	return rc;
}
