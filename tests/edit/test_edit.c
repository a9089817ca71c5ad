/*
 * The edit module: what a SET field means (the corner cases PROTOCOL.md
 * section 9 fixes), subtrees and removals that would make mirrors diverge
 * or empty a scene, atomic batches and their undo, the operations that
 * undo (and redo) each kind of structural edit exactly, and the key=value
 * syntax.
 */
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "test.h"

static const float T0[3] = {0, 0, 0}, R0[4] = {0, 0, 0, 1};

/* smooth_union 10 (blend 0.5) { sphere 11, union 12 { sphere 13,
 * sphere 14 } }: ids 1..9 are free. */
static struct bc_tree *scene(void)
{
	struct bc_proto_buf b;
	struct bc_tree *t = bc_tree_create();
	float r = 0.5f;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 5);
	bc_proto_scene_op(&b, BC_OP_SMOOTH_UNION, 10, 0.5f, 0.0f, 2);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 11, T0, R0, NULL, 1, &r);
	bc_proto_scene_op(&b, BC_OP_UNION, 12, 0.0f, 0.0f, 2);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 13, T0, R0, NULL, 1, &r);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 14, T0, R0, NULL, 1, &r);
	if (!t || bc_scene_decode(b.data, b.len, t, NULL, NULL, NULL)) {
		abort();
	}
	bc_proto_buf_finish(&b);
	return t;
}

/* A one-sphere subtree with the given id. */
static void sphere_bytes(struct bc_proto_buf *b, uint32_t id)
{
	float r = 0.25f;
	bc_proto_buf_init(b, 0);
	bc_proto_scene_begin(b, NULL, 1);
	bc_proto_scene_prim(b, BC_PRIM_SPHERE, id, T0, R0, NULL, 1, &r);
}

static bool same_bytes(const struct bc_tree *a, const struct bc_tree *b)
{
	uint8_t *x = NULL, *y = NULL;
	size_t nx = 0, ny = 0;
	bool same = bc_tree_encode(a, &x, &nx) == 0 &&
	            bc_tree_encode(b, &y, &ny) == 0 && nx == ny &&
	            memcmp(x, y, nx) == 0;
	bc_free(x);
	bc_free(y);
	return same;
}

static int apply1(struct bc_tree **t, struct bc_proto_edit_op op,
                  struct bc_errinfo *ei)
{
	struct bc_edit_batch b;
	int rc = bc_edit_batch_apply(&b, t, &op, 1, ei);
	bc_edit_batch_finish(&b);
	return rc;
}

static struct bc_proto_edit_op set_op(uint32_t node,
                                      const struct bc_proto_field *f, uint8_t n)
{
	return (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_SET, .node = node, .nfields = n, .fields = f};
}

/* Issue item 1: a subtree with id 0 is refused, even when id 1 is free. */
static void subtree_with_id_0_is_einval(void)
{
	struct bc_tree *t = scene(), *before = scene();
	struct bc_errinfo ei = {0};
	struct bc_proto_buf sub;
	sphere_bytes(&sub, 0);
	CHECK_EQ_INT(apply1(&t,
	                    (struct bc_proto_edit_op){
	                        .kind = BC_PROTO_EDIT_INSERT,
	                        .node = 10,
	                        .position = 0,
	                        .subtree = {sub.data, (uint32_t)sub.len}},
	                    &ei),
	             BC_EINVAL);
	CHECK_EQ_INT(apply1(&t,
	                    (struct bc_proto_edit_op){
	                        .kind = BC_PROTO_EDIT_REPLACE,
	                        .node = 11,
	                        .subtree = {sub.data, (uint32_t)sub.len}},
	                    &ei),
	             BC_EINVAL);
	CHECK(same_bytes(t, before));
	bc_proto_buf_finish(&sub);
	bc_tree_destroy(t);
	bc_tree_destroy(before);
}

/* Issue item 2: removing the root would empty the scene. */
static void remove_root_is_einval(void)
{
	struct bc_tree *t = scene();
	struct bc_errinfo ei = {0};
	CHECK_EQ_INT(apply1(&t,
	                    (struct bc_proto_edit_op){
	                        .kind = BC_PROTO_EDIT_REMOVE, .node = 10},
	                    &ei),
	             BC_EINVAL);
	CHECK_EQ_INT((int)bc_tree_node_count(t), 5);
	CHECK_EQ_INT(apply1(&t,
	                    (struct bc_proto_edit_op){
	                        .kind = BC_PROTO_EDIT_REMOVE, .node = 13},
	                    &ei),
	             0);
	bc_tree_destroy(t);
}

/* Issue item 3: an operator kind that is no kind is a (non-fatal) EENUM of
 * meaning. */
static void operator_kind_not_1_to_6_is_eenum(void)
{
	struct bc_tree *t = scene();
	struct bc_errinfo ei = {0};
	const float bad[] = {4.5f, 7.0f, 0.0f, -1.0f};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct bc_proto_field f = {
		    BC_PROTO_FIELD_OP_KIND, 1, {bad[i], 0, 0, 0}};
		CHECK_EQ_INT(apply1(&t, set_op(10, &f, 1), &ei), BC_EENUM);
	}
	bc_tree_destroy(t);
}

/* Issue item 8: turning a smooth operator sharp must not drop its blend
 * and range silently: only a SET that gives both as 0 does it. */
static void sharp_kind_keeps_or_refuses_blend(void)
{
	struct bc_tree *t = scene(), *before = scene();
	struct bc_errinfo ei = {0};
	struct bc_op_data op;
	struct bc_proto_field f[3] = {
	    {BC_PROTO_FIELD_OP_KIND, 1, {(float)BC_OP_UNION, 0, 0, 0}},
	    {BC_PROTO_FIELD_BLEND, 1, {0, 0, 0, 0}},
	    {BC_PROTO_FIELD_RANGE, 1, {0, 0, 0, 0}}};
	CHECK_EQ_INT(apply1(&t, set_op(10, f, 1), &ei), BC_EINVAL);
	CHECK(same_bytes(t, before));
	bc_tree_get(t, 10, NULL, &op);
	CHECK(op.kind == BC_OP_SMOOTH_UNION && op.blend == 0.5f);
	CHECK_EQ_INT(apply1(&t, set_op(10, f, 3), &ei), 0);
	bc_tree_get(t, 10, NULL, &op);
	CHECK(op.kind == BC_OP_UNION && op.blend == 0.0f);
	/* The key=value syntax says it for the user. */
	{
		struct bc_tree *u = scene();
		struct bc_proto_field g[BC_PROTO_MAX_SET_FIELDS];
		uint8_t n = 0;
		const char *kv[] = {"kind=union"};
		CHECK_EQ_INT(bc_edit_parse_kv(u, 10, kv, 1, g, &n, &ei), 0);
		CHECK_EQ_INT(n, 3);
		CHECK_EQ_INT(apply1(&u, set_op(10, g, n), &ei), 0);
		CHECK(same_bytes(t, u));
		bc_tree_destroy(u);
	}
	bc_tree_destroy(t);
	bc_tree_destroy(before);
}

/* Issue item 9: blend on a sharp operator is refused, not acknowledged
 * and lost; with a smooth kind in the same SET it applies. Item 11: a
 * smooth operator given range 0 gets 1.25 blend. */
static void blend_on_sharp_is_refused(void)
{
	struct bc_tree *t = scene(), *before = scene();
	struct bc_errinfo ei = {0};
	struct bc_op_data op;
	struct bc_proto_field f[2] = {
	    {BC_PROTO_FIELD_BLEND, 1, {0.3f, 0, 0, 0}},
	    {BC_PROTO_FIELD_OP_KIND, 1, {(float)BC_OP_SMOOTH_UNION, 0, 0, 0}}};
	CHECK_EQ_INT(apply1(&t, set_op(12, f, 1), &ei), BC_EINVAL);
	CHECK(same_bytes(t, before));
	CHECK_EQ_INT(apply1(&t, set_op(12, f, 2), &ei), 0);
	bc_tree_get(t, 12, NULL, &op);
	CHECK(op.kind == BC_OP_SMOOTH_UNION && op.blend == 0.3f);
	CHECK(op.range == 1.25f * 0.3f);
	bc_tree_destroy(t);
	bc_tree_destroy(before);
}

/* A batch applies whole or not at all; an applied one can be undone. */
static void batches_are_atomic_and_undo(void)
{
	struct bc_tree *t = scene(), *before = scene();
	struct bc_errinfo ei = {0};
	struct bc_edit_batch b;
	struct bc_proto_buf sub;
	struct bc_proto_field mv = {BC_PROTO_FIELD_TRANSLATE, 3, {1, 2, 3, 0}};
	struct bc_proto_field bad = {BC_PROTO_FIELD_BLEND, 1, {0.1f, 0, 0, 0}};
	struct bc_proto_edit_op ops[3];
	sphere_bytes(&sub, 20);
	ops[0] = set_op(11, &mv, 1);
	ops[1] = set_op(13, &mv, 1);
	ops[2] = set_op(14, &bad, 1); /* blend on a primitive */
	CHECK_EQ_INT(bc_edit_batch_apply(&b, &t, ops, 3, &ei), BC_EINVAL);
	CHECK(strncmp(ei.msg, "operation 2:", 12) == 0);
	CHECK(same_bytes(t, before));
	ops[2] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
	                              .node = 12,
	                              .position = 2,
	                              .subtree = {sub.data, (uint32_t)sub.len}};
	ops[1] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                   .node = 999};
	CHECK_EQ_INT(bc_edit_batch_apply(&b, &t, ops, 3, &ei), BC_ENONODE);
	CHECK(same_bytes(t, before));
	ops[1] = set_op(13, &mv, 1);
	CHECK_EQ_INT(bc_edit_batch_apply(&b, &t, ops, 3, &ei), 0);
	CHECK(!same_bytes(t, before) && bc_tree_node_count(t) == 6);
	bc_edit_batch_undo(&b, &t);
	CHECK(same_bytes(t, before));
	CHECK_EQ_INT(bc_edit_batch_apply(&b, &t, ops, 1, &ei), 0);
	bc_edit_batch_undo(&b, &t);
	CHECK(same_bytes(t, before));
	bc_proto_buf_finish(&sub);
	bc_tree_destroy(t);
	bc_tree_destroy(before);
}

static void key_value_syntax(void)
{
	struct bc_tree *t = scene();
	struct bc_errinfo ei = {0};
	struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
	uint8_t n = 9;
	const char *ok[] = {"radius=0.4", "translate=1,2,3"};
	const char *twice[] = {"radius=1", "radius=2"};
	const char *nan[] = {"radius=x"};
	const char *blend[] = {"blend=0.2"};
	CHECK_EQ_INT(bc_edit_parse_kv(t, 11, ok, 2, f, &n, &ei), 0);
	CHECK(n == 2 && f[0].field == BC_PROTO_FIELD_PARAM0 &&
	      f[1].count == 3 && f[1].v[2] == 3.0f);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 11, twice, 2, f, &n, &ei), BC_EINVAL);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 11, nan, 1, f, &n, &ei), BC_EPARSE);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 11, blend, 1, f, &n, &ei), BC_EINVAL);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 99, ok, 1, f, &n, &ei), BC_ENONODE);
	bc_tree_destroy(t);
}

/* offset(12: twist(13: repeat(14: sphere 15))). */
static struct bc_tree *unary_scene(void)
{
	struct bc_proto_buf b;
	struct bc_tree *t = bc_tree_create();
	float r = 0.3f, amount = 0.1f, rate = 1.0f;
	float rep[6] = {1.0f, 0.0f, 0.0f, 3.0f, 1.0f, 1.0f};
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 4);
	bc_proto_scene_unary(&b, BC_OP_OFFSET, 12, 1, &amount);
	bc_proto_scene_unary(&b, BC_OP_TWIST, 13, 1, &rate);
	bc_proto_scene_unary(&b, BC_OP_REPEAT, 14, 6, rep);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 15, T0, R0, NULL, 1, &r);
	if (!t || bc_scene_decode(b.data, b.len, t, NULL, NULL, NULL)) {
		bc_tree_destroy(t);
		t = NULL;
	}
	bc_proto_buf_finish(&b);
	return t;
}

/* REMOVE of a unary node's child takes the chain of unary nodes above it
 * (PROTOCOL.md 9): under offset(twist(repeat(sphere))) that chain is the
 * whole scene, so removing the sphere, or any node of the chain, would
 * leave it empty and is refused like removing the root; the tree is
 * untouched and still encodes. */
static void remove_up_a_unary_chain_to_the_root_is_einval(void)
{
	struct bc_tree *t = unary_scene();
	struct bc_errinfo ei = {0};
	uint8_t *bytes = NULL;
	size_t n = 0;
	REQUIRE(t);
	for (uint32_t id = 12; id <= 15; id++) {
		CHECK_EQ_INT(
		    apply1(&t,
		           (struct bc_proto_edit_op){
		               .kind = BC_PROTO_EDIT_REMOVE, .node = id},
		           &ei),
		    BC_EINVAL);
		CHECK(strstr(ei.msg, "never empty") != NULL);
	}
	CHECK_EQ_INT((int)bc_tree_node_count(t), 4);
	CHECK_EQ_INT(bc_tree_encode(t, &bytes, &n), 0);
	bc_free(bytes);
	CHECK_EQ_INT(apply1(&t,
	                    (struct bc_proto_edit_op){
	                        .kind = BC_PROTO_EDIT_REMOVE, .node = 99},
	                    &ei),
	             BC_ENONODE);
	bc_tree_destroy(t);
}

/* SET on unary nodes: parameters by PARAM0 (repeat: spacing and count),
 * a kind change starting from the new kind's defaults, wrong counts and
 * kinds refused, and a batch undone back to the exact state. */
static void unary_nodes_take_set_fields_and_undo(void)
{
	struct bc_tree *t = unary_scene();
	struct bc_errinfo ei = {0};
	struct bc_unary u;
	struct bc_edit_batch b;
	struct bc_proto_field amount = {BC_PROTO_FIELD_PARAM0, 1, {0.25f}};
	struct bc_proto_field count = {
	    BC_PROTO_FIELD_PARAM0 + 1, 3, {5.0f, 1.0f, 1.0f}};
	struct bc_proto_field to_onion = {
	    BC_PROTO_FIELD_OP_KIND, 1, {(float)BC_OP_ONION}};
	struct bc_proto_field to_union = {BC_PROTO_FIELD_OP_KIND, 1, {1.0f}};
	struct bc_proto_field blend = {BC_PROTO_FIELD_BLEND, 1, {0.1f}};
	struct bc_proto_field three = {BC_PROTO_FIELD_PARAM0, 3, {1, 2, 3}};
	struct bc_proto_edit_op ops[2];
	char *before, *after;
	REQUIRE(t);
	CHECK_EQ_INT(apply1(&t, set_op(12, &amount, 1), &ei), 0);
	REQUIRE(bc_tree_get_unary(t, 12, &u));
	CHECK(u.kind == BC_OP_OFFSET && u.u[0] == 0.25f);
	CHECK_EQ_INT(apply1(&t, set_op(14, &count, 1), &ei), 0);
	REQUIRE(bc_tree_get_unary(t, 14, &u));
	CHECK(u.u[0] == 1.0f && u.u[3] == 5.0f);
	CHECK_EQ_INT(apply1(&t, set_op(12, &to_onion, 1), &ei), 0);
	REQUIRE(bc_tree_get_unary(t, 12, &u));
	CHECK(u.kind == BC_OP_ONION && u.u[0] == 0.05f);
	CHECK_EQ_INT(apply1(&t, set_op(12, &to_union, 1), &ei), BC_EENUM);
	CHECK_EQ_INT(apply1(&t, set_op(12, &blend, 1), &ei), BC_EINVAL);
	CHECK_EQ_INT(apply1(&t, set_op(13, &three, 1), &ei), BC_EINVAL);
	/* Undo of a two-node batch restores the exact scene. */
	REQUIRE((before = bc_scene_to_json(t, NULL)));
	ops[0] = set_op(12, &amount, 1);
	ops[1] = set_op(14, &count, 1);
	count.v[0] = 2.0f;
	REQUIRE(bc_edit_batch_apply(&b, &t, ops, 2, &ei) == 0);
	REQUIRE(bc_tree_get_unary(t, 14, &u));
	CHECK(u.u[3] == 2.0f);
	bc_edit_batch_undo(&b, &t);
	bc_edit_batch_finish(&b);
	REQUIRE((after = bc_scene_to_json(t, NULL)));
	CHECK_STREQ(before, after);
	bc_free(before);
	bc_free(after);
	bc_tree_destroy(t);
}

/* key=value on unary nodes: amount=, spacing= count=, axes=xz, kind=. */
static void unary_key_values(void)
{
	struct bc_tree *t = unary_scene();
	struct bc_errinfo ei = {0};
	struct bc_proto_field f[BC_EDIT_MAX_KV];
	uint8_t n = 0;
	const char *off[] = {"amount=0.2"};
	const char *rep[] = {"spacing=1,1,1", "count=2,1,3"};
	const char *bad[] = {"radius=1"};
	const char *kind[] = {"kind=mirror"};
	REQUIRE(t);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 12, off, 1, f, &n, &ei), 0);
	CHECK(n == 1 && f[0].field == BC_PROTO_FIELD_PARAM0 &&
	      f[0].v[0] == 0.2f);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 14, rep, 2, f, &n, &ei), 0);
	CHECK(n == 2 && f[1].field == BC_PROTO_FIELD_PARAM0 + 1 &&
	      f[1].count == 3 && f[1].v[2] == 3.0f);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 12, bad, 1, f, &n, &ei), BC_EINVAL);
	CHECK(strstr(ei.msg, "amount") != NULL);
	CHECK_EQ_INT(bc_edit_parse_kv(t, 13, kind, 1, f, &n, &ei), 0);
	CHECK_EQ_INT(apply1(&t, set_op(13, f, n), &ei), 0);
	{
		const char *axes[] = {"axes=xz"};
		struct bc_unary u;
		CHECK_EQ_INT(bc_edit_parse_kv(t, 13, axes, 1, f, &n, &ei), 0);
		CHECK(n == 1 && f[0].v[0] == 5.0f);
		CHECK_EQ_INT(apply1(&t, set_op(13, f, n), &ei), 0);
		REQUIRE(bc_tree_get_unary(t, 13, &u));
		CHECK(u.kind == BC_OP_MIRROR && u.u[0] == 5.0f);
	}
	bc_tree_destroy(t);
}

/* smooth_union 10 { sphere 11 (red), union 12 { sphere 13, sphere 14 },
 * union 15 { sphere 16, sphere 17, sphere 18 },
 * offset 19 { onion 20 { sphere 21 } } }: every structural case. */
static struct bc_tree *wide_scene(void)
{
	static const float red[3] = {1, 0, 0};
	struct bc_proto_buf b;
	struct bc_tree *t = bc_tree_create();
	float r = 0.5f, amount = 0.1f, thick = 0.05f;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 12);
	bc_proto_scene_op(&b, BC_OP_SMOOTH_UNION, 10, 0.5f, 0.0f, 4);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 11, T0, R0, red, 1, &r);
	bc_proto_scene_op(&b, BC_OP_UNION, 12, 0.0f, 0.0f, 2);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 13, T0, R0, NULL, 1, &r);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 14, T0, R0, NULL, 1, &r);
	bc_proto_scene_op(&b, BC_OP_UNION, 15, 0.0f, 0.0f, 3);
	for (uint32_t id = 16; id <= 18; id++) {
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id, T0, R0, NULL, 1,
		                    &r);
	}
	bc_proto_scene_unary(&b, BC_OP_OFFSET, 19, 1, &amount);
	bc_proto_scene_unary(&b, BC_OP_ONION, 20, 1, &thick);
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 21, T0, R0, NULL, 1, &r);
	if (!t || bc_scene_decode(b.data, b.len, t, NULL, NULL, NULL)) {
		abort();
	}
	bc_proto_buf_finish(&b);
	return t;
}

static struct bc_tree *copy_of(const struct bc_tree *t)
{
	struct bc_tree *c = bc_tree_create();
	if (!c || bc_tree_copy(c, t, NULL)) {
		abort();
	}
	return c;
}

/* Replays ops into mirror as an EDIT_APPLIED. */
static int replay(struct bc_tree **mirror, const struct bc_edit_inverse *inv)
{
	struct bc_msg_edit_applied ea = {.order = 1, .author = 1};
	struct bc_errinfo ei = {0};
	ea.nops = (uint16_t)inv->nops;
	ea.ops = inv->ops;
	return bc_edit_replay(mirror, &ea, &ei);
}

static size_t subtree_bytes(const struct bc_edit_inverse *inv)
{
	size_t n = 0;
	for (uint32_t i = 0; i < inv->nops; i++) {
		n += inv->ops[i].subtree.len;
	}
	return n;
}

/* Applies ops (n) to the wide scene, then what undoes them, then what
 * undoes that (the redo): the undo gives the scene before back node for
 * node, ids included, the redo the scene after, and a mirror replaying
 * the same operations ends alike each time. The undo's first operation
 * is of kind first, and its subtrees take at most max_bytes. */
static void undo_redo_exact(const struct bc_proto_edit_op *ops, uint32_t n,
                            enum bc_proto_edit_kind first, size_t max_bytes)
{
	struct bc_tree *t = wide_scene(), *before = copy_of(t), *after;
	struct bc_tree *mirror;
	struct bc_errinfo ei = {0};
	struct bc_edit_batch b, u, r;
	REQUIRE(bc_edit_batch_apply_undoable(&b, &t, ops, n, &ei) == 0);
	after = copy_of(t);
	mirror = copy_of(t);
	CHECK(!same_bytes(before, after));
	CHECK_EQ_INT(b.inv.nops, n);
	CHECK_EQ_INT(b.inv.ops[0].kind, first);
	CHECK(subtree_bytes(&b.inv) <= max_bytes);
	/* Undo, on the tree and on the mirror. */
	CHECK_EQ_INT(
	    bc_edit_batch_apply_undoable(&u, &t, b.inv.ops, b.inv.nops, &ei),
	    0);
	CHECK(same_bytes(t, before));
	CHECK_EQ_INT(replay(&mirror, &b.inv), 0);
	CHECK(same_bytes(mirror, before));
	/* Redo. */
	CHECK_EQ_INT(u.inv.nops, n);
	CHECK_EQ_INT(
	    bc_edit_batch_apply_undoable(&r, &t, u.inv.ops, u.inv.nops, &ei),
	    0);
	CHECK(same_bytes(t, after));
	CHECK_EQ_INT(replay(&mirror, &u.inv), 0);
	CHECK(same_bytes(mirror, after));
	/* And the undo again. */
	CHECK_EQ_INT(replay(&mirror, &r.inv), 0);
	CHECK(same_bytes(mirror, before));
	bc_edit_batch_finish(&b);
	bc_edit_batch_finish(&u);
	bc_edit_batch_finish(&r);
	bc_tree_destroy(t);
	bc_tree_destroy(before);
	bc_tree_destroy(after);
	bc_tree_destroy(mirror);
}

/* An INSERT is undone by a REMOVE of what it inserted: no subtree. */
static void insert_is_undone_by_remove(void)
{
	struct bc_proto_buf sub, grp;
	float rad = 0.2f;
	sphere_bytes(&sub, 30);
	undo_redo_exact(
	    &(struct bc_proto_edit_op){
	        .kind = BC_PROTO_EDIT_INSERT,
	        .node = 15,
	        .position = 1,
	        .subtree = {sub.data, (uint32_t)sub.len}},
	    1, BC_PROTO_EDIT_REMOVE, 0);
	/* An operator with its children, appended to the root. */
	bc_proto_buf_init(&grp, 0);
	bc_proto_scene_begin(&grp, NULL, 3);
	bc_proto_scene_op(&grp, BC_OP_INTERSECTION, 31, 0, 0, 2);
	bc_proto_scene_prim(&grp, BC_PRIM_SPHERE, 32, T0, R0, NULL, 1, &rad);
	bc_proto_scene_prim(&grp, BC_PRIM_SPHERE, 33, T0, R0, NULL, 1, &rad);
	undo_redo_exact(
	    &(struct bc_proto_edit_op){
	        .kind = BC_PROTO_EDIT_INSERT,
	        .node = 10,
	        .position = 4,
	        .subtree = {grp.data, (uint32_t)grp.len}},
	    1, BC_PROTO_EDIT_REMOVE, 0);
	bc_proto_buf_finish(&sub);
	bc_proto_buf_finish(&grp);
}

/* A REMOVE is undone by an INSERT of the removed subtree at its place:
 * the middle child of three, the chain of unary nodes above a sphere
 * (which the REMOVE takes with it); an operator left with one child goes
 * too, and is put back by a REPLACE of that child by the operator's
 * subtree (three nodes here). */
static void remove_is_undone_by_insert_at_its_place(void)
{
	/* One sphere node: 39 bytes, plus the scene's flags and count. */
	undo_redo_exact(&(struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                           .node = 17},
	                1, BC_PROTO_EDIT_INSERT, 5 + 39);
	undo_redo_exact(&(struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                           .node = 21},
	                1, BC_PROTO_EDIT_INSERT, 5 + 10 + 10 + 39);
	undo_redo_exact(&(struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                           .node = 11},
	                1, BC_PROTO_EDIT_INSERT, 5 + 51);
	undo_redo_exact(&(struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                           .node = 13},
	                1, BC_PROTO_EDIT_REPLACE, 5 + 17 + 2 * 39);
}

/* A REPLACE is undone by a REPLACE of the new subtree by the old one: by
 * a node of the same id, and by a new operator over the old children in
 * another order (ids of the replaced subtree reused below its root). */
static void replace_is_undone_by_replace(void)
{
	struct bc_proto_buf sub, swap;
	float rad = 0.2f;
	sphere_bytes(&sub, 15);
	undo_redo_exact(
	    &(struct bc_proto_edit_op){
	        .kind = BC_PROTO_EDIT_REPLACE,
	        .node = 15,
	        .subtree = {sub.data, (uint32_t)sub.len}},
	    1, BC_PROTO_EDIT_REPLACE, 5 + 17 + 3 * 39);
	bc_proto_buf_init(&swap, 0);
	bc_proto_scene_begin(&swap, NULL, 3);
	bc_proto_scene_op(&swap, BC_OP_DIFFERENCE, 40, 0, 0, 2);
	bc_proto_scene_prim(&swap, BC_PRIM_SPHERE, 14, T0, R0, NULL, 1, &rad);
	bc_proto_scene_prim(&swap, BC_PRIM_SPHERE, 13, T0, R0, NULL, 1, &rad);
	undo_redo_exact(
	    &(struct bc_proto_edit_op){
	        .kind = BC_PROTO_EDIT_REPLACE,
	        .node = 12,
	        .subtree = {swap.data, (uint32_t)swap.len}},
	    1, BC_PROTO_EDIT_REPLACE, 5 + 17 + 2 * 39);
	bc_proto_buf_finish(&sub);
	bc_proto_buf_finish(&swap);
}

/* A move to another group (REMOVE, then INSERT of the same ids), a SET
 * and a first colour in one batch: undone newest first, the colour by a
 * one-node REPLACE (no SET takes a colour away). */
static void regroup_batch_is_undone_newest_first(void)
{
	struct bc_proto_buf moved;
	struct bc_proto_field mv = {BC_PROTO_FIELD_TRANSLATE, 3, {1, 2, 3, 0}};
	struct bc_proto_field red = {BC_PROTO_FIELD_COLOR, 3, {1, 0, 0, 0}};
	struct bc_proto_edit_op ops[4];
	sphere_bytes(&moved, 16);
	ops[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 16};
	ops[1] = (struct bc_proto_edit_op){
	    .kind = BC_PROTO_EDIT_INSERT,
	    .node = 12,
	    .position = 0,
	    .subtree = {moved.data, (uint32_t)moved.len}};
	ops[2] = set_op(11, &mv, 1);
	ops[3] = set_op(16, &red, 1);
	undo_redo_exact(ops, 4, BC_PROTO_EDIT_REPLACE, 3 * (5 + 51));
	bc_proto_buf_finish(&moved);
}

/* A parameter step's states come back as SETs, and a first colour as a
 * one-node REPLACE; a batch refused part way keeps no inverse. */
static void saved_states_come_back_as_operations(void)
{
	struct bc_tree *t = wide_scene(), *before = copy_of(t);
	struct bc_errinfo ei = {0};
	struct bc_edit_batch b;
	struct bc_edit_inverse inv;
	struct bc_proto_field red = {BC_PROTO_FIELD_COLOR, 3, {1, 0, 0, 0}};
	struct bc_proto_field mv = {BC_PROTO_FIELD_TRANSLATE, 3, {1, 2, 3, 0}};
	struct bc_proto_edit_op ops[2] = {set_op(13, &red, 1),
	                                  set_op(11, &mv, 1)};
	REQUIRE(bc_edit_batch_apply_undoable(&b, &t, ops, 2, &ei) == 0);
	CHECK(!b.structural && b.inv.nops == 0 && b.nsaved == 2);
	REQUIRE(bc_edit_inverse_of_states(&inv, t, b.saved, b.nsaved) == 0);
	CHECK_EQ_INT(inv.nops, 2);
	CHECK_EQ_INT(inv.ops[0].kind, BC_PROTO_EDIT_REPLACE);
	CHECK_EQ_INT(inv.ops[1].kind, BC_PROTO_EDIT_SET);
	CHECK_EQ_INT(replay(&t, &inv), 0);
	CHECK(same_bytes(t, before));
	bc_edit_inverse_finish(&inv);
	bc_edit_batch_finish(&b);
	ops[1] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 99};
	ops[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 17};
	CHECK_EQ_INT(bc_edit_batch_apply_undoable(&b, &t, ops, 2, &ei),
	             BC_ENONODE);
	CHECK(b.inv.nops == 0 && b.inv.ops == NULL);
	CHECK(same_bytes(t, before));
	bc_tree_destroy(t);
	bc_tree_destroy(before);
}

/* union 50 { sphere 51, union 52 { sphere 53, union 54 { sphere 55,
 * union 56 { sphere 57, sphere 58 } } } }: removing 51, 53 and 55 takes
 * an operator each time, and each would be put back with all below it,
 * more than the scene: the inverse is one REPLACE of the root by the
 * scene before, and is exact. */
static void inverse_is_never_bigger_than_the_scene(void)
{
	struct bc_proto_buf b;
	struct bc_tree *t = bc_tree_create(), *before, *after, *mirror;
	struct bc_errinfo ei = {0};
	struct bc_edit_batch e, u;
	struct bc_proto_edit_op ops[3];
	float r = 0.5f;
	bc_proto_buf_init(&b, 0);
	bc_proto_scene_begin(&b, NULL, 9);
	for (uint32_t id = 50; id <= 56; id += 2) {
		bc_proto_scene_op(&b, BC_OP_UNION, id, 0, 0, 2);
		bc_proto_scene_prim(&b, BC_PRIM_SPHERE, id + 1, T0, R0, NULL, 1,
		                    &r);
	}
	bc_proto_scene_prim(&b, BC_PRIM_SPHERE, 58, T0, R0, NULL, 1, &r);
	REQUIRE(t && bc_scene_decode(b.data, b.len, t, NULL, NULL, NULL) == 0);
	bc_proto_buf_finish(&b);
	before = copy_of(t);
	for (uint32_t i = 0; i < 3; i++) {
		ops[i] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
		                                   .node = 51 + 2 * i};
	}
	REQUIRE(bc_edit_batch_apply_undoable(&e, &t, ops, 3, &ei) == 0);
	after = copy_of(t);
	mirror = copy_of(t);
	CHECK_EQ_INT(e.inv.nops, 1);
	CHECK_EQ_INT(e.inv.ops[0].kind, BC_PROTO_EDIT_REPLACE);
	CHECK_EQ_INT(e.inv.ops[0].node, 56);
	CHECK(e.inv.ops[0].subtree.len <= 5 + 4 * 17 + 5 * 39);
	CHECK_EQ_INT(replay(&mirror, &e.inv), 0);
	CHECK(same_bytes(mirror, before));
	REQUIRE(bc_edit_batch_apply_undoable(&u, &t, e.inv.ops, e.inv.nops,
	                                     &ei) == 0);
	CHECK(same_bytes(t, before));
	CHECK_EQ_INT(replay(&mirror, &u.inv), 0);
	CHECK(same_bytes(mirror, after));
	bc_edit_batch_finish(&e);
	bc_edit_batch_finish(&u);
	bc_tree_destroy(t);
	bc_tree_destroy(before);
	bc_tree_destroy(after);
	bc_tree_destroy(mirror);
}

/* A structural batch with its Nth allocation failing, for N up to past
 * what it and its undo allocate: a refused batch leaves the tree as it
 * was, or says that it could not (b.lost, BC_ENOMEM); an undo puts it
 * back, or says BC_ENOMEM. The batch inserts a sphere and removes a
 * subtree; putting that subtree back decodes it again, which can run out
 * of memory, whether the batch's third operation is refused or the
 * batch is undone. */
static void failures_say_when_the_tree_is_not_put_back(void)
{
	struct bc_tree *t = scene(), *before = scene();
	struct bc_edit_batch b;
	struct bc_errinfo ei = {0};
	struct bc_proto_buf sub;
	struct bc_proto_edit_op ops[3];
	uint32_t lost = 0, undo_lost = 0, refused = 0, undone = 0;
	sphere_bytes(&sub, 20);
	ops[0] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_INSERT,
	                              .node = 10,
	                              .position = 0,
	                              .subtree = {sub.data, (uint32_t)sub.len}};
	ops[1] =
	    (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE, .node = 12};
	ops[2] = (struct bc_proto_edit_op){.kind = BC_PROTO_EDIT_REMOVE,
	                                   .node = 999}; /* refused */
	for (uint32_t nops = 2; nops <= 3; nops++) {
		for (unsigned long n = 1; n < 400; n++) {
			int urc = 0;
			bc_alloc_fail_after(n);
			int rc = bc_edit_batch_apply(&b, &t, ops, nops, &ei);
			if (rc == 0) {
				urc = bc_edit_batch_undo(&b, &t);
			}
			bc_alloc_fail_after(0);
			CHECK(rc == 0 || rc == BC_ENOMEM ||
			      (nops == 3 && rc == BC_ENONODE));
			refused += rc == BC_ENONODE;
			undone += rc == 0 && urc == 0;
			if (rc && b.lost) {
				CHECK_EQ_INT(rc, BC_ENOMEM);
				lost++;
			} else if (urc) {
				CHECK_EQ_INT(urc, BC_ENOMEM);
				undo_lost++;
			} else {
				CHECK(same_bytes(t, before));
			}
			if ((rc && b.lost) || urc) {
				bc_tree_destroy(t);
				t = scene();
			}
		}
	}
	/* Every outcome came up, and the tree not put back among them. */
	CHECK(refused > 0 && undone > 0);
	CHECK(lost > 0 && undo_lost > 0);
	bc_proto_buf_finish(&sub);
	bc_tree_destroy(t);
	bc_tree_destroy(before);
}

static const struct bc_test tests[] = {
    {"subtree_with_id_0_is_einval", subtree_with_id_0_is_einval},
    {"remove_root_is_einval", remove_root_is_einval},
    {"operator_kind_not_1_to_6_is_eenum", operator_kind_not_1_to_6_is_eenum},
    {"sharp_kind_keeps_or_refuses_blend", sharp_kind_keeps_or_refuses_blend},
    {"blend_on_sharp_is_refused", blend_on_sharp_is_refused},
    {"batches_are_atomic_and_undo", batches_are_atomic_and_undo},
    {"key_value_syntax", key_value_syntax},
    {"unary_nodes_take_set_fields_and_undo",
     unary_nodes_take_set_fields_and_undo},
    {"unary_key_values", unary_key_values},
    {"remove_up_a_unary_chain_to_the_root_is_einval",
     remove_up_a_unary_chain_to_the_root_is_einval},
    {"insert_is_undone_by_remove", insert_is_undone_by_remove},
    {"remove_is_undone_by_insert_at_its_place",
     remove_is_undone_by_insert_at_its_place},
    {"replace_is_undone_by_replace", replace_is_undone_by_replace},
    {"regroup_batch_is_undone_newest_first",
     regroup_batch_is_undone_newest_first},
    {"saved_states_come_back_as_operations",
     saved_states_come_back_as_operations},
    {"inverse_is_never_bigger_than_the_scene",
     inverse_is_never_bigger_than_the_scene},
    {"failures_say_when_the_tree_is_not_put_back",
     failures_say_when_the_tree_is_not_put_back},
};

BC_TEST_MAIN(tests)
