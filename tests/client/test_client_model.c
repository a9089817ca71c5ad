/*
 * libblobcast's modelling actions (model.h) against a real blobcastd: each
 * action as one EDIT, checked on the author's mirror and on a second
 * member's; each refusal made in the client before anything is sent (no
 * message leaves), and the same edits sent raw, which the daemon refuses
 * with its own ERROR codes; two editors adding at once, where the second
 * is refused whole (EDUPID) and succeeds when tried again.
 */
#include <math.h>

#include "blobcast/alloc.h"
#include "blobcast/model.h"
#include "blobcast/scene.h"
#include "test.h" /* before daemon.h: its test runner needs it */
/* Not every helper of daemon.h is used here. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include "daemon.h"
#pragma GCC diagnostic pop

static char base_dir[96];

/* union 1 [sphere 2, twist 3 (sphere 4), smooth_union 5 [box 6, sphere 7]] */
#define SCENE                                                                  \
	"{\"blobcast\": 1, \"camera\": {\"eye\": [0, 0, 6], \"target\": "      \
	"[0.5, 0.25, 0], \"up\": [0, 1, 0], \"fov_y_deg\": 45}, \"root\": "    \
	"{\"type\": \"union\", \"id\": 1, \"children\": ["                     \
	"{\"type\": \"sphere\", \"id\": 2, \"radius\": 0.5}, "                 \
	"{\"type\": \"twist\", \"id\": 3, \"rate\": 1, \"children\": "         \
	"[{\"type\": \"sphere\", \"id\": 4, \"radius\": 0.3}]}, "              \
	"{\"type\": \"smooth_union\", \"id\": 5, \"blend\": 0.2, "             \
	"\"children\": [{\"type\": \"box\", \"id\": 6, \"half_extents\": "     \
	"[0.3, 0.3, 0.3]}, {\"type\": \"sphere\", \"id\": 7, \"radius\": "     \
	"0.4}]}]}}"

/* offset 1 (onion 2 (sphere 3)): every node is on a unary chain to the
 * root. */
#define CHAIN_SCENE                                                            \
	"{\"blobcast\": 1, \"root\": {\"type\": \"offset\", \"id\": 1, "       \
	"\"amount\": 0.1, \"children\": [{\"type\": \"onion\", \"id\": 2, "    \
	"\"thickness\": 0.05, \"children\": [{\"type\": \"sphere\", \"id\": "  \
	"3, \"radius\": 0.5}]}]}}"

/* Writes text to base_dir/name and returns the path (static buffer). */
static const char *write_scene(const char *name, const char *text)
{
	static char path[200];
	FILE *f;
	snprintf(path, sizeof(path), "%s/%s", base_dir, name);
	f = fopen(path, "w");
	if (f) {
		fputs(text, f);
		fclose(f);
	}
	return path;
}

/* union 1 [sphere 2, twist 3 (twist 4 (... (sphere) ...))]: 32 domain
 * nodes on one path, the most a path may hold. */
static const char *domain_chain_scene(void)
{
	static char text[8192];
	size_t n = 0;
	n += (size_t)snprintf(text + n, sizeof(text) - n,
	                      "{\"blobcast\": 1, \"root\": {\"type\": "
	                      "\"union\", \"id\": 1, \"children\": [{\"type\": "
	                      "\"sphere\", \"id\": 2, \"radius\": 0.5}, ");
	for (unsigned i = 0; i < BC_DOMAIN_MAX_CHAIN; i++) {
		n += (size_t)snprintf(text + n, sizeof(text) - n,
		                      "{\"type\": \"twist\", \"id\": %u, "
		                      "\"rate\": 0.1, \"children\": [",
		                      3 + i);
	}
	n += (size_t)snprintf(text + n, sizeof(text) - n,
	                      "{\"type\": \"sphere\", \"id\": 100, "
	                      "\"radius\": 0.3}");
	for (unsigned i = 0; i < BC_DOMAIN_MAX_CHAIN; i++) {
		n += (size_t)snprintf(text + n, sizeof(text) - n, "]}");
	}
	snprintf(text + n, sizeof(text) - n, "]}}");
	return text;
}

/* The deepest operator of right_nested_scene(): its unions take ids
 * 101, 103, ... down 128 levels. */
#define DEEPEST_UNION (101u + 2u * 127u)

/* union 1 [union 2 [sphere 3, sphere 4], sphere 5, R(128)], where R(k) is
 * union [sphere, R(k - 1)] and R(0) a sphere: each level nests the next in
 * its right operand, so evaluating the tree needs a stack of exactly
 * BC_EVAL_STACK (130) entries. Moving union 2 under the deepest union
 * (DEEPEST_UNION) would need one more. */
static const char *right_nested_scene(void)
{
	static char text[40000];
	size_t n = 0;
	uint32_t id = 101;
	n += (size_t)snprintf(
	    text + n, sizeof(text) - n,
	    "{\"blobcast\": 1, \"root\": {\"type\": \"union\", \"id\": 1, "
	    "\"children\": [{\"type\": \"union\", \"id\": 2, \"children\": "
	    "[{\"type\": \"sphere\", \"id\": 3, \"radius\": 0.2}, {\"type\": "
	    "\"sphere\", \"id\": 4, \"radius\": 0.2}]}, {\"type\": "
	    "\"sphere\", \"id\": 5, \"radius\": 0.2}, ");
	for (unsigned i = 0; i < 128; i++, id += 2) {
		n += (size_t)snprintf(text + n, sizeof(text) - n,
		                      "{\"type\": \"union\", \"id\": %u, "
		                      "\"children\": [{\"type\": \"sphere\", "
		                      "\"id\": %u, \"radius\": 0.1}, ",
		                      id, id + 1);
	}
	n += (size_t)snprintf(text + n, sizeof(text) - n,
	                      "{\"type\": \"sphere\", \"id\": %u, "
	                      "\"radius\": 0.1}",
	                      id);
	for (unsigned i = 0; i < 128; i++) {
		n += (size_t)snprintf(text + n, sizeof(text) - n, "]}");
	}
	snprintf(text + n, sizeof(text) - n, "]}}");
	return text;
}

static int connect_to(const struct daemon *d, const char *name,
                      struct bc_client **c)
{
	char addr[128];
	struct bc_errinfo ei = {0};
	int rc;
	snprintf(addr, sizeof(addr), "unix:%s", d->sock);
	rc = bc_client_connect(
	    c, &(struct bc_client_opts){.addr = addr, .name = name}, &ei);
	if (rc) {
		fprintf(stderr, "  connect: %s\n", ei.msg);
	}
	return rc;
}

/* Joins c to session and, with scene, loads it. */
static int enter(struct bc_client *c, const char *session, const char *scene)
{
	struct bc_errinfo ei = {0};
	int rc = bc_client_join(c, session, BC_PROTO_ROLE_EDITOR,
	                        BC_CLIENT_JOIN_ANY, &ei);
	if (!rc && scene) {
		rc = bc_client_load_scene_file(c, scene, NULL, NULL, &ei);
	}
	if (rc) {
		fprintf(stderr, "  enter %s: %s\n", session, ei.msg);
	}
	return rc;
}

/* Waits for the EDIT_APPLIED of r's EDIT; reports the error if any. */
static int applied(struct bc_client *c, const struct bc_model_result *r)
{
	struct bc_errinfo ei = {0};
	int rc = bc_client_wait_applied(c, r->seq, NULL, &ei);
	if (rc) {
		fprintf(stderr, "  applied: %s (%s)\n", ei.msg,
		        bc_err_name(rc));
	}
	return rc;
}

static const struct bc_tree *mirror_of(const struct bc_client *c)
{
	return bc_client_scene(c, NULL);
}

/* Index of child among parent's children, or -1. */
static int index_in(const struct bc_tree *t, uint32_t parent, uint32_t child)
{
	for (uint32_t k = 0; k < bc_tree_child_count(t, parent); k++) {
		if (bc_tree_child(t, parent, k) == child) {
			return (int)k;
		}
	}
	return -1;
}

static enum bc_op op_kind(const struct bc_tree *t, uint32_t id)
{
	struct bc_op_data op = {0};
	bc_tree_get(t, id, NULL, &op);
	return op.kind;
}

static enum bc_prim prim_kind(const struct bc_tree *t, uint32_t id)
{
	struct bc_prim_data p = {0};
	struct bc_op_data op = {0};
	if (!bc_tree_get(t, id, &p, &op) || op.kind != BC_OP_INVALID) {
		return BC_PRIM_INVALID;
	}
	return p.kind;
}

/* Whether two clients' mirrors hold the same scene. */
static bool same_scene(struct bc_client *a, struct bc_client *b)
{
	char *ja = bc_scene_to_json(mirror_of(a), NULL);
	char *jb = bc_scene_to_json(mirror_of(b), NULL);
	bool same = ja && jb && strcmp(ja, jb) == 0;
	bc_free(ja);
	bc_free(jb);
	return same;
}

/* Receives on c until its mirror reaches order (at most 5 s). */
static bool catch_up(struct bc_client *c, uint64_t order)
{
	struct bc_msg m;
	int64_t until = t_now_ms() + 5000;
	while (bc_client_info(c)->order < order && t_now_ms() < until) {
		if (bc_client_recv(c, &m, 100) < 0) {
			return false;
		}
	}
	return bc_client_info(c)->order >= order;
}

static void every_action_is_one_edit_seen_by_every_member(void)
{
	struct daemon d = {0};
	struct bc_client *a = NULL, *b = NULL;
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	struct bc_prim_data p;
	struct bc_op_data op;
	const struct bc_tree *t;
	const char *scene = write_scene("actions.json", SCENE);
	char dir[160];
	uint32_t nodes, sphere, pair, twisted, wrapped, dup;
	uint64_t before;
	snprintf(dir, sizeof(dir), "%s/actions", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "alice", &a) == 0);
	REQUIRE(connect_to(&d, "bob", &b) == 0);
	REQUIRE(enter(a, "model", scene) == 0);
	REQUIRE(enter(b, "model", NULL) == 0);
	nodes = bc_tree_node_count(mirror_of(a));
	CHECK_EQ_INT(nodes, 7);

	/* A primitive, appended under the root, at the camera's target. */
	before = bc_client_info(a)->order;
	REQUIRE(bc_model_add(a,
	                     &(struct bc_model_add){
	                         .kind = "sphere",
	                         .kv = (const char *const[]){"radius=0.25"},
	                         .nkv = 1},
	                     &r, &ei) == 0);
	CHECK(r.seq != 0);
	CHECK_EQ_INT(r.first_id, 8); /* above the largest id, 7 */
	CHECK_EQ_INT(r.nids, 1);
	CHECK_EQ_INT(r.node, 8);
	CHECK_EQ_INT(r.parent, 1);
	CHECK_EQ_INT(r.position, 3);
	CHECK_EQ_INT(r.base_order, before);
	REQUIRE(applied(a, &r) == 0);
	/* One edit: the order moved by one. */
	CHECK_EQ_INT(bc_client_info(a)->order, before + 1);
	t = mirror_of(a);
	sphere = r.node;
	REQUIRE(bc_tree_get(t, sphere, &p, &op));
	CHECK_EQ_INT(p.kind, BC_PRIM_SPHERE);
	CHECK_NEAR(p.params[0], 0.25, 1e-6);
	CHECK_NEAR(p.translate[0], 0.5, 1e-6);
	CHECK_NEAR(p.translate[1], 0.25, 1e-6);
	CHECK_EQ_INT(bc_tree_parent(t, sphere), 1);
	CHECK_EQ_INT(index_in(t, 1, sphere), 3);

	/* Every primitive kind can be added, here at a given place and
	 * position, with its own keys. */
	for (int k = 1; k < BC_PRIM_COUNT; k++) {
		const char *name = bc_prim_info((enum bc_prim)k)->name;
		REQUIRE(
		    bc_model_add(a,
		                 &(struct bc_model_add){.kind = name,
		                                        .parent = 5,
		                                        .has_position = true,
		                                        .position = 0,
		                                        .has_at = true,
		                                        .at = {1, 2, 3}},
		                 &r, &ei) == 0);
		REQUIRE(applied(a, &r) == 0);
		t = mirror_of(a);
		CHECK_EQ_INT(prim_kind(t, r.node), k);
		CHECK_EQ_INT(index_in(t, 5, r.node), 0);
		REQUIRE(bc_tree_get(t, r.node, &p, NULL));
		CHECK_NEAR(p.translate[2], 3.0, 1e-6);
		/* And removed again, one edit each. */
		REQUIRE(bc_model_remove(a, r.node, &r, &ei) == 0);
		REQUIRE(applied(a, &r) == 0);
	}
	CHECK_EQ_INT(bc_tree_node_count(mirror_of(a)), nodes + 1);

	/* An operator comes with two primitives of child_kind, side by
	 * side; a unary node with one. */
	REQUIRE(bc_model_add(a,
	                     &(struct bc_model_add){
	                         .kind = "smooth_difference",
	                         .kv = (const char *const[]){"blend=0.3"},
	                         .nkv = 1,
	                         .child_kind = "box"},
	                     &r, &ei) == 0);
	CHECK_EQ_INT(r.nids, 3);
	REQUIRE(applied(a, &r) == 0);
	t = mirror_of(a);
	pair = r.node;
	REQUIRE(bc_tree_get(t, pair, NULL, &op));
	CHECK_EQ_INT(op.kind, BC_OP_SMOOTH_DIFFERENCE);
	CHECK_NEAR(op.blend, 0.3, 1e-6);
	CHECK_EQ_INT(bc_tree_child_count(t, pair), 2);
	CHECK_EQ_INT(bc_tree_child(t, pair, 0), r.first_id + 1);
	CHECK_EQ_INT(prim_kind(t, r.first_id + 2), BC_PRIM_BOX);
	REQUIRE(bc_model_add(a,
	                     &(struct bc_model_add){
	                         .kind = "twist",
	                         .kv = (const char *const[]){"rate=2"},
	                         .nkv = 1},
	                     &r, &ei) == 0);
	CHECK_EQ_INT(r.nids, 2);
	REQUIRE(applied(a, &r) == 0);
	twisted = r.node;
	CHECK_EQ_INT(op_kind(mirror_of(a), twisted), BC_OP_TWIST);
	CHECK_EQ_INT(bc_tree_child(mirror_of(a), twisted, 0), r.first_id + 1);

	/* Wrap: node 2 into offset, ids kept, the offset in its place. */
	REQUIRE(bc_model_wrap(a,
	                      &(struct bc_model_wrap){
	                          .node = 2,
	                          .kind = "offset",
	                          .kv = (const char *const[]){"amount=0.05"},
	                          .nkv = 1},
	                      &r, &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	t = mirror_of(a);
	wrapped = r.node;
	CHECK_EQ_INT(op_kind(t, wrapped), BC_OP_OFFSET);
	CHECK_EQ_INT(bc_tree_parent(t, 2), wrapped);
	CHECK_EQ_INT(bc_tree_parent(t, wrapped), 1);
	CHECK_EQ_INT(index_in(t, 1, wrapped), 0);
	/* Into an operator: the node first, a new primitive second. */
	REQUIRE(bc_model_wrap(a,
	                      &(struct bc_model_wrap){.node = 6,
	                                              .kind = "difference",
	                                              .child_kind = "cylinder"},
	                      &r, &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	t = mirror_of(a);
	CHECK_EQ_INT(bc_tree_child(t, r.node, 0), 6);
	CHECK_EQ_INT(prim_kind(t, bc_tree_child(t, r.node, 1)),
	             BC_PRIM_CYLINDER);
	CHECK_EQ_INT(bc_tree_parent(t, r.node), 5);

	/* Move 7 to the front of the root: REMOVE and INSERT, same ids. */
	before = bc_client_info(a)->order;
	REQUIRE(bc_model_move(a,
	                      &(struct bc_model_move){.node = 7,
	                                              .parent = 1,
	                                              .has_position = true,
	                                              .position = 0},
	                      &r, &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	CHECK_EQ_INT(bc_client_info(a)->order, before + 1);
	t = mirror_of(a);
	CHECK_EQ_INT(bc_tree_parent(t, 7), 1);
	CHECK_EQ_INT(index_in(t, 1, 7), 0);
	/* 5 kept one child, so it dissolved into it (the difference). */
	CHECK(!bc_tree_get(t, 5, NULL, NULL));
	/* A sphere inside twist 4's chain moves with its twist. */
	REQUIRE(
	    bc_model_move(a, &(struct bc_model_move){.node = 4, .parent = pair},
	                  &r, &ei) == 0);
	CHECK_EQ_INT(r.node, 3);
	REQUIRE(applied(a, &r) == 0);
	t = mirror_of(a);
	CHECK_EQ_INT(bc_tree_parent(t, 3), pair);
	CHECK_EQ_INT(bc_tree_parent(t, 4), 3);
	CHECK_EQ_INT(index_in(t, pair, 3), 2);
	/* Reordering inside an operator, forwards. */
	REQUIRE(bc_model_move(a,
	                      &(struct bc_model_move){.node = 3,
	                                              .parent = pair,
	                                              .has_position = true,
	                                              .position = 0},
	                      &r, &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	CHECK_EQ_INT(index_in(mirror_of(a), pair, 3), 0);
	/* Two children swapped: a REPLACE of the operator by itself. */
	REQUIRE(bc_model_remove(a, 3, &r, &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	t = mirror_of(a);
	REQUIRE(bc_tree_child_count(t, pair) == 2);
	{
		uint32_t first = bc_tree_child(t, pair, 0);
		REQUIRE(bc_model_move(a,
		                      &(struct bc_model_move){.node = first,
		                                              .parent = pair},
		                      &r, &ei) == 0);
		REQUIRE(applied(a, &r) == 0);
		CHECK_EQ_INT(index_in(mirror_of(a), pair, first), 1);
		CHECK_EQ_INT(op_kind(mirror_of(a), pair),
		             BC_OP_SMOOTH_DIFFERENCE);
	}

	/* Duplicate: a copy with fresh ids right after the original; a
	 * node in a unary chain is copied with the chain. */
	nodes = bc_tree_node_count(mirror_of(a));
	REQUIRE(bc_model_duplicate(
	            a,
	            &(struct bc_model_duplicate){.node = twisted + 1,
	                                         .has_offset = true,
	                                         .offset = {0, 1, 0}},
	            &r, &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	t = mirror_of(a);
	dup = r.node;
	CHECK_EQ_INT(r.nids, 2);
	CHECK_EQ_INT(bc_tree_node_count(t), nodes + 2);
	CHECK_EQ_INT(op_kind(t, dup), BC_OP_TWIST);
	CHECK_EQ_INT(index_in(t, 1, dup), index_in(t, 1, twisted) + 1);
	{
		struct bc_prim_data orig, copy;
		REQUIRE(bc_tree_get(t, twisted + 1, &orig, NULL));
		REQUIRE(bc_tree_get(t, bc_tree_child(t, dup, 0), &copy, NULL));
		CHECK_NEAR(copy.translate[1], orig.translate[1] + 1.0f, 1e-6);
	}

	/* The operator's kind and blend: sharp, then smooth again. */
	REQUIRE(bc_model_set_operator(a, pair, "intersection", 0, 0, &r, &ei) ==
	        0);
	REQUIRE(applied(a, &r) == 0);
	REQUIRE(bc_tree_get(mirror_of(a), pair, NULL, &op));
	CHECK_EQ_INT(op.kind, BC_OP_INTERSECTION);
	CHECK(op.blend == 0.0f && op.range == 0.0f);
	REQUIRE(bc_model_set_operator(a, pair, "smooth_union", 0.2f, 0, &r,
	                              &ei) == 0);
	REQUIRE(applied(a, &r) == 0);
	REQUIRE(bc_tree_get(mirror_of(a), pair, NULL, &op));
	CHECK_EQ_INT(op.kind, BC_OP_SMOOTH_UNION);
	CHECK_NEAR(op.blend, 0.2, 1e-6);

	/* Removing the child of a unary node takes the node with it. */
	REQUIRE(bc_model_remove(a, twisted + 1, &r, &ei) == 0);
	CHECK_EQ_INT(r.node, twisted);
	REQUIRE(applied(a, &r) == 0);
	CHECK(!bc_tree_get(mirror_of(a), twisted, NULL, NULL));
	CHECK(!bc_tree_get(mirror_of(a), twisted + 1, NULL, NULL));

	/* The other member's mirror followed every step. */
	CHECK(catch_up(b, bc_client_info(a)->order));
	CHECK(same_scene(a, b));
	bc_client_destroy(a);
	bc_client_destroy(b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* rc is code, nothing was sent, and the sentence says what to do (it
 * contains hint). */
static void refused(struct bc_client *c, int rc, int code,
                    const struct bc_errinfo *ei, uint64_t sent_before,
                    const char *hint)
{
	CHECK_EQ_INT(rc, code);
	CHECK_EQ_INT(bc_client_info(c)->msgs_out, sent_before);
	CHECK(strstr(ei->msg, hint) != NULL);
	if (rc != code || !strstr(ei->msg, hint)) {
		fprintf(stderr, "  got %s: %s\n", bc_err_name(rc), ei->msg);
	}
}

static void refusals_are_made_before_sending(void)
{
	struct daemon d = {0};
	struct bc_client *a = NULL;
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	char dir[160];
	uint64_t out;
	int rc;
	snprintf(dir, sizeof(dir), "%s/refusals", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "carol", &a) == 0);

	/* Not in a session: no mirror. */
	rc = bc_model_remove(a, 2, &r, &ei);
	CHECK_EQ_INT(rc, BC_ESTATE);
	REQUIRE(enter(a, "refuse", write_scene("refuse.json", SCENE)) == 0);
	out = bc_client_info(a)->msgs_out;

	rc = bc_model_add(
	    a, &(struct bc_model_add){.kind = "sphere", .parent = 2}, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "wrap it in one first");
	CHECK_EQ_INT(r.seq, 0);
	rc = bc_model_add(
	    a, &(struct bc_model_add){.kind = "sphere", .parent = 3}, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "exactly one child");
	rc = bc_model_add(
	    a, &(struct bc_model_add){.kind = "sphere", .parent = 99}, &r, &ei);
	refused(a, rc, BC_ENONODE, &ei, out, "no node 99");
	rc = bc_model_add(a, &(struct bc_model_add){.kind = "spehre"}, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "a primitive (sphere, box");
	rc = bc_model_add(
	    a,
	    &(struct bc_model_add){.kind = "box",
	                           .kv = (const char *const[]){"radius=1"},
	                           .nkv = 1},
	    &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "half_extents");
	rc = bc_model_add(
	    a,
	    &(struct bc_model_add){.kind = "sphere",
	                           .kv = (const char *const[]){"radius=-1"},
	                           .nkv = 1},
	    &r, &ei);
	CHECK_EQ_INT(rc, BC_ERANGE);
	CHECK_EQ_INT(bc_client_info(a)->msgs_out, out);
	rc = bc_model_add(a,
	                  &(struct bc_model_add){.kind = "sphere",
	                                         .has_position = true,
	                                         .position = 4},
	                  &r, &ei);
	refused(a, rc, BC_ERANGE, &ei, out, "give 0..3");
	rc = bc_model_add(
	    a, &(struct bc_model_add){.kind = "union", .child_kind = "union"},
	    &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "child primitive");

	rc = bc_model_move(a, &(struct bc_model_move){.node = 5, .parent = 5},
	                   &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "under itself");
	/* Under its own descendant (an operator made for the purpose would
	 * be the same: 7 is a primitive, the descendant rule comes first). */
	rc = bc_model_move(a, &(struct bc_model_move){.node = 5, .parent = 7},
	                   &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "descendants");
	rc = bc_model_move(a, &(struct bc_model_move){.node = 1, .parent = 5},
	                   &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "is the root");
	rc = bc_model_move(a, &(struct bc_model_move){.node = 6, .parent = 2},
	                   &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "a primitive");
	rc = bc_model_move(
	    a,
	    &(struct bc_model_move){
	        .node = 2, .parent = 1, .has_position = true, .position = 1},
	    &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "nothing to move");

	rc = bc_model_remove(a, 1, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "never empty");
	rc = bc_model_duplicate(a, &(struct bc_model_duplicate){.node = 1}, &r,
	                        &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "wrap it in one first");
	rc = bc_model_wrap(a, &(struct bc_model_wrap){.node = 2, .kind = "box"},
	                   &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "holds no other node");
	rc = bc_model_set_operator(a, 3, "union", 0, 0, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "blobcast edit");
	rc = bc_model_set_operator(a, 1, "twist", 0, 0, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "smooth_union");

	/* A unary chain up to the root: removing any of it would empty the
	 * scene. */
	REQUIRE(
	    bc_client_load_scene_file(a, write_scene("chain.json", CHAIN_SCENE),
	                              NULL, NULL, &ei) == 0);
	out = bc_client_info(a)->msgs_out;
	rc = bc_model_remove(a, 3, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "up to the root");
	rc = bc_model_remove(a, 2, &r, &ei);
	refused(a, rc, BC_EINVAL, &ei, out, "up to the root");
	rc = bc_model_add(a,
	                  &(struct bc_model_add){.kind = "sphere",
	                                         .has_position = true,
	                                         .position = 2},
	                  &r, &ei);
	refused(a, rc, BC_ERANGE, &ei, out, "give 0 (before it) or 1");
	/* With no operator at the top, a new node goes beside the root in a
	 * new union (its id the last of the run), as one REPLACE. */
	rc = bc_model_add(a, &(struct bc_model_add){.kind = "box"}, &r, &ei);
	CHECK_EQ_INT(rc, 0);
	CHECK_EQ_INT(r.nids, 2);
	CHECK_EQ_INT(r.node, r.first_id);
	CHECK_EQ_INT(r.parent, r.first_id + 1);
	CHECK_EQ_INT(r.position, 1);
	CHECK(rc || applied(a, &r) == 0);
	CHECK_EQ_INT(bc_tree_root(mirror_of(a)), r.parent);
	CHECK_EQ_INT(op_kind(mirror_of(a), r.parent), BC_OP_UNION);
	CHECK_EQ_INT(bc_tree_child(mirror_of(a), r.parent, 0), 1);
	CHECK_EQ_INT(
	    prim_kind(mirror_of(a), bc_tree_child(mirror_of(a), r.parent, 1)),
	    BC_PRIM_BOX);

	/* 32 domain nodes on a path already: one more is over the limit. */
	REQUIRE(bc_client_load_scene_file(
	            a, write_scene("domains.json", domain_chain_scene()), NULL,
	            NULL, &ei) == 0);
	out = bc_client_info(a)->msgs_out;
	rc = bc_model_wrap(
	    a, &(struct bc_model_wrap){.node = 100, .kind = "bend"}, &r, &ei);
	refused(a, rc, BC_EDEPTH, &ei, out, "domain nodes");
	rc = bc_model_move(
	    a,
	    &(struct bc_model_move){
	        .node = 2, .parent = 1, .has_position = true, .position = 2},
	    &r, &ei);
	/* A legal move still passes on that scene. */
	CHECK_EQ_INT(rc, 0);
	CHECK(rc || applied(a, &r) == 0);

	/* A regroup that would make evaluation need a deeper stack. */
	REQUIRE(bc_client_load_scene_file(
	            a, write_scene("right.json", right_nested_scene()), NULL,
	            NULL, &ei) == 0);
	out = bc_client_info(a)->msgs_out;
	rc = bc_model_move(
	    a, &(struct bc_model_move){.node = 2, .parent = DEEPEST_UNION}, &r,
	    &ei);
	refused(a, rc, BC_EDEPTH, &ei, out, "stack of 131 entries");
	/* One level up it fits. */
	rc = bc_model_move(
	    a, &(struct bc_model_move){.node = 2, .parent = DEEPEST_UNION - 2},
	    &r, &ei);
	CHECK_EQ_INT(rc, 0);
	CHECK(rc || applied(a, &r) == 0);
	bc_client_destroy(a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Sends ops raw as one EDIT and returns the daemon's answer: 0 or the
 * ERROR's code. */
static int send_raw_edit(struct bc_client *c,
                         const struct bc_proto_edit_op *ops, uint16_t n)
{
	struct bc_msg m = {.type = BC_MSG_EDIT};
	struct bc_errinfo ei = {0};
	uint32_t seq;
	int rc;
	m.edit.nops = n;
	m.edit.ops = ops;
	if ((rc = bc_client_send(c, &m, &seq))) {
		return rc;
	}
	return bc_client_wait_applied(c, seq, NULL, &ei);
}

/* One operation sent raw (sub: its subtree, or NULL); the daemon's
 * answer as send_raw_edit() gives it. */
static int send_raw_op(struct bc_client *c, enum bc_proto_edit_kind kind,
                       uint32_t node, const struct bc_proto_buf *sub)
{
	struct bc_proto_edit_op op = {.kind = kind, .node = node};
	if (sub) {
		op.subtree = (struct bc_proto_bytes){.ptr = sub->data,
		                                     .len = (uint32_t)sub->len};
	}
	return send_raw_edit(c, &op, 1);
}

/* A scene encoding of one sphere, or of twist(sphere), with these ids. */
static void sphere_bytes(struct bc_proto_buf *b, uint32_t twist_id, uint32_t id)
{
	static const float t[3] = {0}, q[4] = {0, 0, 0, 1}, radius = 0.5f;
	static const float rate = 0.5f;
	bc_proto_buf_init(b, 0);
	bc_proto_scene_begin(b, NULL, twist_id ? 2 : 1);
	if (twist_id) {
		bc_proto_scene_unary(b, BC_OP_TWIST, twist_id, 1, &rate);
	}
	bc_proto_scene_prim(b, BC_PRIM_SPHERE, id, t, q, NULL, 1, &radius);
}

static void the_daemon_refuses_the_same_edits_sent_raw(void)
{
	struct daemon d = {0};
	struct bc_client *a = NULL;
	struct bc_errinfo ei = {0};
	struct bc_proto_buf s, t;
	char dir[160];
	uint64_t order;
	snprintf(dir, sizeof(dir), "%s/raw", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "dave", &a) == 0);
	REQUIRE(enter(a, "raw", write_scene("raw.json", SCENE)) == 0);
	order = bc_client_info(a)->order;
	sphere_bytes(&s, 0, 50);
	sphere_bytes(&t, 51, 52);

	/* Under a primitive, under a unary node. */
	CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_INSERT, 2, &s), BC_EINVAL);
	CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_INSERT, 3, &s), BC_EINVAL);
	/* The root. */
	CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_REMOVE, 1, NULL), BC_EINVAL);
	/* Under its own descendant: the REMOVE takes 7 with 5, so the
	 * INSERT names a node that is gone, and none of it applies. */
	{
		struct bc_proto_edit_op ops[2] = {
		    {.kind = BC_PROTO_EDIT_REMOVE, .node = 5},
		    {.kind = BC_PROTO_EDIT_INSERT, .node = 7}};
		struct bc_tree *sub = bc_tree_create();
		uint8_t *bytes = NULL;
		size_t len = 0;
		REQUIRE(sub != NULL);
		/* 5's subtree as the mirror holds it, same ids. */
		bc_tree_begin(sub);
		{
			struct bc_op_data op;
			struct bc_prim_data p;
			bc_tree_get(mirror_of(a), 5, NULL, &op);
			bc_tree_push_op(sub, 5, &op, &ei);
			bc_tree_get(mirror_of(a), 6, &p, NULL);
			bc_tree_put_prim(sub, 6, &p, &ei);
			bc_tree_get(mirror_of(a), 7, &p, NULL);
			bc_tree_put_prim(sub, 7, &p, &ei);
			bc_tree_pop_op(sub, &ei);
		}
		REQUIRE(bc_tree_end(sub, &ei) == 0);
		REQUIRE(bc_scene_encode(sub, NULL, &bytes, &len) == 0);
		ops[1].subtree =
		    (struct bc_proto_bytes){.ptr = bytes, .len = (uint32_t)len};
		CHECK_EQ_INT(send_raw_edit(a, ops, 2), BC_ENONODE);
		bc_free(bytes);
		bc_tree_destroy(sub);
	}
	/* A subtree with id 0, and an id the scene has. */
	{
		struct bc_proto_buf zero;
		sphere_bytes(&zero, 0, 0);
		CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_INSERT, 1, &zero),
		             BC_EINVAL);
		bc_proto_buf_finish(&zero);
		sphere_bytes(&zero, 0, 7);
		CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_INSERT, 1, &zero),
		             BC_EDUPID);
		bc_proto_buf_finish(&zero);
	}
	/* Nothing of it was applied. */
	CHECK_EQ_INT(bc_client_info(a)->order, order);
	CHECK_EQ_INT(bc_tree_node_count(mirror_of(a)), 7);

	/* A unary chain up to the root. */
	REQUIRE(bc_client_load_scene_file(
	            a, write_scene("rawchain.json", CHAIN_SCENE), NULL, NULL,
	            &ei) == 0);
	CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_REMOVE, 3, NULL), BC_EINVAL);
	/* A 33rd domain node on a path. */
	REQUIRE(bc_client_load_scene_file(
	            a, write_scene("rawdomains.json", domain_chain_scene()),
	            NULL, NULL, &ei) == 0);
	{
		struct bc_proto_buf deep;
		sphere_bytes(&deep, 101, 100);
		CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_REPLACE, 100, &deep),
		             BC_EDEPTH);
		bc_proto_buf_finish(&deep);
	}
	/* A regroup under the deepest operator of a tree whose evaluation
	 * already needs the longest stack. */
	REQUIRE(bc_client_load_scene_file(
	            a, write_scene("rawright.json", right_nested_scene()), NULL,
	            NULL, &ei) == 0);
	{
		struct bc_proto_buf two;
		struct bc_proto_edit_op ops[2] = {
		    {.kind = BC_PROTO_EDIT_REMOVE, .node = 2},
		    {.kind = BC_PROTO_EDIT_INSERT,
		     .node = DEEPEST_UNION,
		     .position = 2}};
		static const float at[3] = {0}, q[4] = {0, 0, 0, 1};
		static const float radius = 0.2f;
		bc_proto_buf_init(&two, 0);
		bc_proto_scene_begin(&two, NULL, 3);
		bc_proto_scene_op(&two, BC_OP_UNION, 2, 0, 0, 2);
		bc_proto_scene_prim(&two, BC_PRIM_SPHERE, 3, at, q, NULL, 1,
		                    &radius);
		bc_proto_scene_prim(&two, BC_PRIM_SPHERE, 4, at, q, NULL, 1,
		                    &radius);
		ops[1].subtree = (struct bc_proto_bytes){
		    .ptr = two.data, .len = (uint32_t)two.len};
		CHECK_EQ_INT(send_raw_edit(a, ops, 2), BC_EDEPTH);
		bc_proto_buf_finish(&two);
	}
	/* The connection is still good: a legal edit applies. */
	CHECK_EQ_INT(send_raw_op(a, BC_PROTO_EDIT_INSERT, 1, &t), 0);
	bc_proto_buf_finish(&s);
	bc_proto_buf_finish(&t);
	bc_client_destroy(a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static void two_editors_adding_at_once_one_is_refused_whole(void)
{
	struct daemon d = {0};
	struct bc_client *a = NULL, *b = NULL;
	struct bc_errinfo ei = {0};
	struct bc_model_result ra, rb, again;
	char dir[160];
	int rca, rcb;
	snprintf(dir, sizeof(dir), "%s/race", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "erin", &a) == 0);
	REQUIRE(connect_to(&d, "frank", &b) == 0);
	REQUIRE(enter(a, "race", write_scene("race.json", SCENE)) == 0);
	REQUIRE(enter(b, "race", NULL) == 0);
	/* Both build on the same mirror, so both pick id 8. */
	REQUIRE(bc_model_add(a, &(struct bc_model_add){.kind = "sphere"}, &ra,
	                     &ei) == 0);
	REQUIRE(bc_model_add(b, &(struct bc_model_add){.kind = "box"}, &rb,
	                     &ei) == 0);
	CHECK_EQ_INT(ra.first_id, 8);
	CHECK_EQ_INT(rb.first_id, 8);
	rca = bc_client_wait_applied(a, ra.seq, NULL, &ei);
	rcb = bc_client_wait_applied(b, rb.seq, NULL, &ei);
	/* One applies, the other is refused whole. */
	CHECK((rca == 0 && rcb == BC_EDUPID) || (rcb == 0 && rca == BC_EDUPID));
	{
		struct bc_client *loser = rca ? a : b;
		struct bc_client *winner = rca ? b : a;
		CHECK(catch_up(loser, bc_client_info(winner)->order));
		/* Tried again, the action picks the next id and applies. */
		REQUIRE(bc_model_add(loser,
		                     &(struct bc_model_add){.kind = "torus"},
		                     &again, &ei) == 0);
		CHECK_EQ_INT(again.first_id, 9);
		CHECK_EQ_INT(applied(loser, &again), 0);
		CHECK(catch_up(winner, bc_client_info(loser)->order));
		CHECK(same_scene(a, b));
		CHECK_EQ_INT(bc_tree_node_count(mirror_of(a)), 9);
	}
	/* Two actions sent before the first is applied take different
	 * ids. */
	REQUIRE(bc_model_add(a, &(struct bc_model_add){.kind = "sphere"}, &ra,
	                     &ei) == 0);
	REQUIRE(bc_model_add(a, &(struct bc_model_add){.kind = "sphere"}, &rb,
	                     &ei) == 0);
	CHECK(rb.first_id == ra.first_id + 1);
	CHECK_EQ_INT(applied(a, &ra), 0);
	CHECK_EQ_INT(applied(a, &rb), 0);
	bc_client_destroy(a);
	bc_client_destroy(b);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* Runs action i of allocation_failures_free_everything on c. */
static int run_action(struct bc_client *c, int i, struct bc_model_result *r,
                      struct bc_errinfo *ei)
{
	switch (i) {
	case 0:
		return bc_model_add(
		    c,
		    &(struct bc_model_add){
		        .kind = "smooth_union",
		        .kv = (const char *const[]){"blend=0.2"},
		        .nkv = 1},
		    r, ei);
	case 1:
		return bc_model_wrap(
		    c, &(struct bc_model_wrap){.node = 6, .kind = "difference"},
		    r, ei);
	case 2:
		return bc_model_move(
		    c, &(struct bc_model_move){.node = 7, .parent = 1}, r, ei);
	case 3:
		return bc_model_duplicate(
		    c, &(struct bc_model_duplicate){.node = 4}, r, ei);
	default:
		return bc_model_remove(c, 2, r, ei);
	}
}

/* Whether c's mirror encodes to bytes[0..len). */
static bool mirror_is(const struct bc_client *c, const uint8_t *bytes,
                      size_t len)
{
	uint8_t *now = NULL;
	size_t n = 0;
	bool same = bc_scene_encode(mirror_of(c), NULL, &now, &n) == 0 &&
	            n == len && memcmp(now, bytes, len) == 0;
	bc_free(now);
	return same;
}

/* Each action with its Nth allocation failing, for every N until it
 * succeeds: every failure is BC_ENOMEM, sends nothing and frees what it
 * took (LeakSanitizer checks at exit), and the connection goes on. The
 * mirror, which the dry run changes and puts back, is the scene before
 * the action -- or, where putting it back ran out of memory, gone, with
 * an error that says to join again (and joining again brings it back). */
static void allocation_failures_free_everything(void)
{
	struct daemon d = {0};
	struct bc_client *a = NULL;
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	uint32_t dropped = 0;
	char dir[160];
	snprintf(dir, sizeof(dir), "%s/alloc", base_dir);
	REQUIRE(daemon_start(&d, dir) == 0);
	REQUIRE(connect_to(&d, "grace", &a) == 0);
	REQUIRE(enter(a, "alloc", write_scene("alloc.json", SCENE)) == 0);
	for (int i = 0; i < 5; i++) {
		unsigned long n;
		int rc = -1;
		for (n = 1; n < 1000 && rc != 0; n++) {
			uint64_t out = bc_client_info(a)->msgs_out;
			uint8_t *before = NULL;
			size_t len = 0;
			REQUIRE(bc_scene_encode(mirror_of(a), NULL, &before,
			                        &len) == 0);
			bc_alloc_fail_after(n);
			rc = run_action(a, i, &r, &ei);
			bc_alloc_fail_after(0);
			if (rc) {
				CHECK_EQ_INT(rc, BC_ENOMEM);
				CHECK_EQ_INT(bc_client_info(a)->msgs_out, out);
				CHECK_EQ_INT(r.seq, 0);
			}
			if (rc && !mirror_of(a)) {
				CHECK(strstr(ei.msg, "join the session again"));
				dropped++;
				bc_client_destroy(a);
				REQUIRE(connect_to(&d, "grace", &a) == 0);
				REQUIRE(enter(a, "alloc", NULL) == 0);
			}
			CHECK(!rc || mirror_is(a, before, len));
			bc_free(before);
		}
		CHECK_EQ_INT(rc, 0);
		/* Every action allocates: a scratch tree, a walk, a
		 * builder, the dry run's notes. */
		CHECK(n > 4);
		CHECK(rc || applied(a, &r) == 0);
	}
	/* Removing, moving and wrapping put back decoded subtrees. */
	CHECK(dropped > 0);
	CHECK_EQ_INT(bc_client_error(a, NULL), 0);
	bc_client_destroy(a);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

/* bc_client_read_scene_file, which blobcast load calls before it
 * connects: a JSON file and the binary file of the same scene give the
 * same bytes and node count, the bytes decode to that scene and camera;
 * a missing, damaged or invalid file is refused with nothing returned. */
static void a_scene_file_is_read_without_a_server(void)
{
	const char *json = write_scene("read.json", SCENE);
	char bin[200];
	struct bc_errinfo ei = {0};
	struct bc_tree *t = bc_tree_create(), *back = bc_tree_create();
	struct bc_camera cam, cam_back;
	bool has_cam = false;
	uint8_t *a = NULL, *b = NULL, *want = NULL, *x = (uint8_t *)1;
	size_t alen = 0, blen = 0, wlen = 0, xlen = 1;
	uint32_t anodes = 0, bnodes = 0, xnodes = 1;
	FILE *f;
	REQUIRE(t && back);
	snprintf(bin, sizeof(bin), "%s/read.bin", base_dir);
	REQUIRE(bc_scene_load_json(json, t, &cam, &ei) == 0);
	REQUIRE(bc_scene_save_binary(bin, t, &cam, &ei) == 0);
	REQUIRE(bc_scene_encode(t, &cam, &want, &wlen) == 0);
	CHECK(bc_client_read_scene_file(json, &a, &alen, &anodes, &ei) == 0);
	CHECK(bc_client_read_scene_file(bin, &b, &blen, &bnodes, &ei) == 0);
	CHECK(anodes == 7 && bnodes == 7);
	CHECK(a && alen == wlen && memcmp(a, want, wlen) == 0);
	CHECK(b && blen == wlen && memcmp(b, want, wlen) == 0);
	CHECK(a &&
	      bc_scene_decode(a, alen, back, &cam_back, &has_cam, &ei) == 0);
	CHECK(has_cam && memcmp(&cam, &cam_back, sizeof(cam)) == 0);
	CHECK(bc_tree_node_count(back) == 7);
	/* Nothing there; a flipped byte (the checksum finds it); a scene
	 * the parser refuses. */
	CHECK(bc_client_read_scene_file("/nonexistent/x.json", &x, &xlen,
	                                &xnodes, &ei) == BC_ENOTFOUND);
	CHECK(x == NULL && xlen == 0 && xnodes == 0);
	REQUIRE((f = fopen(bin, "r+b")) != NULL);
	fseek(f, 20, SEEK_SET);
	fputc(fgetc(f) ^ 0x10, f);
	fclose(f);
	xnodes = 1;
	CHECK(bc_client_read_scene_file(bin, &x, &xlen, &xnodes, &ei) != 0);
	CHECK(x == NULL && xnodes == 0 && strstr(ei.msg, "read.bin"));
	json = write_scene("bad.json", "{\"blobcast\": 1, \"root\": {}}");
	CHECK(bc_client_read_scene_file(json, &x, &xlen, NULL, &ei) != 0);
	CHECK(x == NULL && ei.msg[0]);
	bc_free(a);
	bc_free(b);
	bc_free(want);
	bc_tree_destroy(t);
	bc_tree_destroy(back);
}

static const struct bc_test tests[] = {
    {"every_action_is_one_edit_seen_by_every_member",
     every_action_is_one_edit_seen_by_every_member},
    {"refusals_are_made_before_sending", refusals_are_made_before_sending},
    {"the_daemon_refuses_the_same_edits_sent_raw",
     the_daemon_refuses_the_same_edits_sent_raw},
    {"two_editors_adding_at_once_one_is_refused_whole",
     two_editors_adding_at_once_one_is_refused_whole},
    {"allocation_failures_free_everything",
     allocation_failures_free_everything},
    {"a_scene_file_is_read_without_a_server",
     a_scene_file_is_read_without_a_server},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("model", base_dir, sizeof(base_dir), tests,
	                        sizeof(tests) / sizeof(tests[0]), argc, argv);
}
