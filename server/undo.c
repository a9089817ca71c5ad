/*
 * Undo and redo (loop thread). Each session keeps a bounded history of the
 * changes applied to its scene since it was loaded: for each, what puts the
 * scene back -- the earlier states of the nodes a parameter edit changed,
 * or the whole tree before a structural edit. UNDO applies the newest
 * step's reverse as an ordinary edit (SETs of the saved states, or a
 * REPLACE of the root by the saved tree), so it is journaled and broadcast
 * as EDIT_APPLIED (flag UNDO, naming the edit undone and its author) and
 * every mirror, and a restart, sees a plain edit. What that edit's own
 * batch saved is the REDO step, and the other way round.
 *
 * The history is linear and the session's, not a member's: undo takes back
 * the newest change whoever made it. A new edit clears the redo steps; the
 * edits of one member's drag (INTERACTING, up to the release) make one
 * step; a SCENE_LOAD clears the history. It lives in memory: after a
 * restart, undo starts from the restored scene.
 *
 * A structural step of a big scene (BC_SRV_HEAVY_NODES) is encoded on a
 * task and applied on another (edits.c), the session busy throughout, so
 * neither holds the loop.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

/* Memory a structural step holds per node of its saved tree (the model and
 * its layout), for the history's byte bound. */
#define TREE_BYTES_PER_NODE 256u

struct step {
	uint64_t order; /* the edit this step undoes (or, redo, redoes) */
	char author[BC_PROTO_MAX_NAME + 1];
	uint32_t member; /* who made it: a drag's edits join its step */
	bool open;       /* that drag still adds to it */
	struct bc_edit_saved *nodes; /* parameter step: states to restore */
	uint32_t n, cap;
	struct bc_tree *old; /* structural step: the tree to restore */
	size_t bytes;
};

struct bc_undo {
	uv_loop_t *loop; /* frees big trees off it */
	struct step undo[BC_SRV_UNDO_STEPS], redo[BC_SRV_UNDO_STEPS];
	uint32_t nundo, nredo;
	size_t bytes;
};

static void step_free(struct bc_undo *u, struct step *st)
{
	u->bytes -= st->bytes;
	bc_free(st->nodes);
	bc__tree_free_later(u->loop, st->old);
	memset(st, 0, sizeof(*st));
}

/* Drops the i-th of n steps in a stack, oldest first. */
static void drop(struct bc_undo *u, struct step *stack, uint32_t *n, uint32_t i)
{
	step_free(u, &stack[i]);
	memmove(&stack[i], &stack[i + 1], (*n - i - 1) * sizeof(*stack));
	(*n)--;
	memset(&stack[*n], 0, sizeof(*stack));
}

void bc__undo_clear(struct bc_session *s)
{
	struct bc_undo *u = s->undo;
	if (!u) {
		return;
	}
	while (u->nundo) {
		drop(u, u->undo, &u->nundo, u->nundo - 1);
	}
	while (u->nredo) {
		drop(u, u->redo, &u->nredo, u->nredo - 1);
	}
	bc_free(u);
	s->undo = NULL;
}

/* The saved nodes of a step by id, for step_add: a drag of 1024-SET edits
 * merges into a step of thousands of nodes, and a linear search per node
 * (and a look at every saved node per edit) took the loop milliseconds
 * per edit. Open addressing; keys are id + 1 (0: empty), values the
 * node's index in the step. */
struct id_set {
	uint64_t *keys;
	uint32_t *at;
	uint32_t mask;
};

static bool id_set_init(struct id_set *s, uint32_t n)
{
	uint32_t cap = 16;
	while (cap < 2u * n) {
		cap <<= 1;
	}
	s->mask = cap - 1u;
	s->keys = bc_calloc(cap, sizeof(*s->keys));
	s->at = bc_calloc(cap, sizeof(*s->at));
	if (!s->keys || !s->at) {
		bc_free(s->keys);
		bc_free(s->at);
		return false;
	}
	return true;
}

static void id_set_finish(struct id_set *s)
{
	bc_free(s->keys);
	bc_free(s->at);
}

/* The slot of id: where it is, or the empty one it would take. */
static uint32_t id_set_slot(const struct id_set *s, uint32_t id)
{
	uint32_t i = (id * 2654435761u) & s->mask;
	while (s->keys[i] && s->keys[i] != (uint64_t)id + 1u) {
		i = (i + 1u) & s->mask;
	}
	return i;
}

/* A SET cannot take a colour away: a step that must restore a primitive
 * without colour over one with colour becomes structural -- a copy of t
 * (the scene now) with the saved states written back. Only the nodes
 * batch b touched can have changed since the step was last settled.
 * Returns false when out of memory. */
static bool settle_colours(struct bc_undo *u, struct step *st,
                           const struct bc_tree *t,
                           const struct bc_edit_batch *b,
                           const struct id_set *ids)
{
	struct bc_tree *copy;
	bool needed = false;
	for (uint32_t i = 0; i < b->nsaved && !needed; i++) {
		const struct bc_edit_saved *first =
		    &st->nodes[ids->at[id_set_slot(ids, b->saved[i].id)]];
		struct bc_prim_data p;
		struct bc_op_data op;
		bc_tree_get(t, first->id, &p, &op);
		needed = op.kind == BC_OP_INVALID && !first->p.has_color &&
		         p.has_color;
	}
	if (!needed) {
		return true;
	}
	if (!(copy = bc_tree_create()) || bc_tree_copy(copy, t, NULL)) {
		bc_tree_destroy(copy);
		return false;
	}
	for (uint32_t i = 0; i < st->n; i++) {
		bc_edit_saved_restore(copy, &st->nodes[i]);
	}
	u->bytes -= st->bytes;
	bc_free(st->nodes);
	st->nodes = NULL;
	st->n = st->cap = 0;
	st->old = copy;
	st->bytes = (size_t)bc_tree_node_count(copy) * TREE_BYTES_PER_NODE;
	u->bytes += st->bytes;
	return true;
}

/* Adds to st what undoes batch b, applied to make t: b's old tree, or the
 * saved states of the nodes st does not hold yet (a node's first saved
 * state is its state before). Takes b's old tree. Returns false when out
 * of memory. */
static bool step_add(struct bc_undo *u, struct step *st,
                     struct bc_edit_batch *b, const struct bc_tree *t)
{
	struct id_set ids;
	bool ok = true;
	if (b->structural) {
		st->old = b->old;
		b->old = NULL;
		st->bytes =
		    (size_t)bc_tree_node_count(st->old) * TREE_BYTES_PER_NODE;
		u->bytes += st->bytes;
		return true;
	}
	if (!id_set_init(&ids, st->n + b->nsaved)) {
		return false;
	}
	for (uint32_t i = 0; i < st->n; i++) {
		uint32_t k = id_set_slot(&ids, st->nodes[i].id);
		ids.keys[k] = (uint64_t)st->nodes[i].id + 1u;
		ids.at[k] = i;
	}
	for (uint32_t i = 0; i < b->nsaved && ok; i++) {
		uint32_t k = id_set_slot(&ids, b->saved[i].id);
		if (ids.keys[k]) {
			continue; /* its first state is kept already */
		}
		if (st->n == st->cap) {
			uint32_t cap = st->cap ? 2u * st->cap : 8u;
			struct bc_edit_saved *more =
			    bc_realloc(st->nodes, cap * sizeof(*more));
			if (!more) {
				ok = false;
				break;
			}
			st->nodes = more;
			st->cap = cap;
		}
		ids.keys[k] = (uint64_t)b->saved[i].id + 1u;
		ids.at[k] = st->n;
		st->nodes[st->n++] = b->saved[i];
		st->bytes += sizeof(*st->nodes);
		u->bytes += sizeof(*st->nodes);
	}
	ok = ok && settle_colours(u, st, t, b, &ids);
	id_set_finish(&ids);
	return ok;
}

/* Keeps the history within its bounds, dropping the oldest steps. */
static void trim(struct bc_undo *u)
{
	while (u->nundo > 0 &&
	       (u->bytes > BC_SRV_UNDO_BYTES || u->nundo > BC_SRV_UNDO_STEPS)) {
		drop(u, u->undo, &u->nundo, 0);
	}
	while (u->nredo > 0 && u->bytes > BC_SRV_UNDO_BYTES) {
		drop(u, u->redo, &u->nredo, 0);
	}
}

/* A new step on top of stack (oldest dropped when full), or NULL. */
static struct step *push(struct bc_undo *u, struct step *stack, uint32_t *n)
{
	if (*n == BC_SRV_UNDO_STEPS) {
		drop(u, stack, n, 0);
	}
	return &stack[(*n)++];
}

static struct bc_undo *history(struct bc_session *s)
{
	if (!s->undo && (s->undo = bc_calloc(1, sizeof(*s->undo)))) {
		s->undo->loop = s->ss->loop;
	}
	return s->undo;
}

void bc__undo_record(struct bc_session *s, const struct bc_author *a,
                     struct bc_edit_batch *b, bool interacting)
{
	struct bc_undo *u = history(s);
	struct step *top;
	bool ok;
	if (!u) {
		bc_log(BC_LOG_WARN,
		       "session %s: no memory for the undo history", s->name);
		return;
	}
	while (u->nredo) {
		drop(u, u->redo, &u->nredo, u->nredo - 1);
	}
	top = u->nundo ? &u->undo[u->nundo - 1] : NULL;
	if (top && top->open && top->member == a->member_id && !top->old &&
	    !b->structural && top->n + b->nsaved <= BC_PROTO_MAX_EDIT_OPS) {
		/* The drag goes on (or ends with this edit): one step. */
		ok = step_add(u, top, b, s->tree);
	} else {
		if (top) {
			top->open = false;
		}
		top = push(u, u->undo, &u->nundo);
		top->member = a->member_id;
		snprintf(top->author, sizeof(top->author), "%s", a->name);
		ok = step_add(u, top, b, s->tree);
	}
	top->order = s->order;
	top->open = interacting;
	if (!ok) {
		bc_log(BC_LOG_WARN,
		       "session %s: no memory for the undo history; it "
		       "restarts here",
		       s->name);
		bc__undo_clear(s);
		return;
	}
	trim(u);
}

/* The step an UNDO (or REDO) applies: the newest of its stack. */
static struct step *top_of(struct bc_undo *u, bool redo)
{
	return redo ? &u->redo[u->nredo - 1] : &u->undo[u->nundo - 1];
}

/* An undo (redo) was applied: what it saved goes the other way (undone,
 * it can be redone; redone, undone again), and the step leaves its
 * stack. The session was busy or on the loop throughout: the step is
 * still the top of its stack. */
static void step_applied(struct bc_session *s, const struct bc_author *a,
                         const struct bc_change *how, struct bc_edit_batch *b,
                         void *ud)
{
	bool redo = ud != NULL;
	struct bc_undo *u = s->undo;
	struct step *st, *back;
	(void)a;
	(void)how;
	if (!u || (redo ? u->nredo : u->nundo) == 0) {
		return;
	}
	st = top_of(u, redo);
	back = redo ? push(u, u->undo, &u->nundo) : push(u, u->redo, &u->nredo);
	st = top_of(u, redo); /* push may have dropped the oldest step */
	back->order = st->order;
	back->member = st->member;
	memcpy(back->author, st->author, sizeof(back->author));
	if (!step_add(u, back, b, s->tree)) {
		bc_log(BC_LOG_WARN, "session %s: no memory to keep the %s",
		       s->name, redo ? "undo" : "redo");
		if (redo) {
			drop(u, u->undo, &u->nundo, u->nundo - 1);
		} else {
			drop(u, u->redo, &u->nredo, u->nredo - 1);
		}
	}
	if (redo) {
		drop(u, u->redo, &u->nredo, u->nredo - 1);
	} else {
		drop(u, u->undo, &u->nundo, u->nundo - 1);
	}
	trim(u);
}

/* The operations that apply step st: a REPLACE of the root by its whole
 * tree, or a SET of each saved node. Returns 0 or BC_ENOMEM. */
static int step_ops(const struct bc_session *s, const struct step *st,
                    struct bc_proto_edit_op **ops, uint32_t *nops,
                    struct bc_proto_field **fields, uint8_t **subtree)
{
	size_t len = 0;
	*ops = NULL;
	*fields = NULL;
	*subtree = NULL;
	if (st->old) {
		if (bc_scene_encode(st->old, NULL, subtree, &len) ||
		    !(*ops = bc_calloc(1, sizeof(**ops)))) {
			return BC_ENOMEM;
		}
		(*ops)->kind = BC_PROTO_EDIT_REPLACE;
		(*ops)->node = bc_tree_root(s->tree);
		(*ops)->subtree.ptr = *subtree;
		(*ops)->subtree.len = (uint32_t)len;
		*nops = 1;
		return 0;
	}
	if (!(*ops = bc_calloc(st->n ? st->n : 1, sizeof(**ops))) ||
	    !(*fields = bc_calloc((size_t)(st->n ? st->n : 1) *
	                              BC_PROTO_MAX_SET_FIELDS,
	                          sizeof(**fields)))) {
		return BC_ENOMEM;
	}
	for (uint32_t i = 0; i < st->n; i++) {
		bc_edit_state_set(
		    &st->nodes[i], st->nodes[i].op.kind != BC_OP_INVALID,
		    &(*ops)[i],
		    &(*fields)[(size_t)i * BC_PROTO_MAX_SET_FIELDS]);
	}
	*nops = st->n;
	return 0;
}

/* Applies the top step with ops; errors go to m. Returns 0, or BC_HOLD
 * while the step is applied on a task. */
static int apply_step(struct bc_member *m, bool redo, uint32_t seq,
                      struct bc_proto_edit_op *ops, uint32_t nops)
{
	struct bc_session *s = m->session;
	struct step *st = top_of(s->undo, redo);
	struct bc_errinfo ei = {0};
	struct bc_change how = {0};
	int rc;
	how.flags = redo ? BC_PROTO_FLAG_REDO : BC_PROTO_FLAG_UNDO;
	how.target_order = st->order;
	memcpy(how.target_author, st->author, sizeof(how.target_author));
	rc = bc__apply(m, ops, (uint16_t)nops, seq, &how, step_applied,
	               redo ? (void *)s : NULL, &ei);
	if (rc < 0) {
		bc__send_error(m, seq, rc, "%s refused: %s",
		               redo ? "redo" : "undo", ei.msg);
		return 0;
	}
	return bc__hold(s, m, seq);
}

/* A big structural step's tree, encoded off the loop (the session busy,
 * so its history stays as it is). */
struct encode_task {
	struct bc_task t;
	struct bc_conn_ref who;
	uint32_t seq;
	bool redo;
	uint8_t *bytes;
	size_t len;
	int rc;
};

static void encode_run(struct bc_task *t)
{
	struct encode_task *e = (struct encode_task *)t;
	e->rc = bc_scene_encode(top_of(t->s->undo, e->redo)->old, NULL,
	                        &e->bytes, &e->len);
}

static void encode_done(struct bc_task *t)
{
	struct encode_task *e = (struct encode_task *)t;
	struct bc_session *s = t->s;
	struct bc_member *m = bc__member_of(s->ss, e->who);
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_REPLACE};
	struct bc_undo *u = s->undo;
	if (s->removed || !m || m->session != s || !u ||
	    (e->redo ? u->nredo : u->nundo) == 0) {
		/* Its author left, or the session went. */
	} else if (e->rc) {
		bc__send_error(m, e->seq, e->rc, "%s refused: out of memory",
		               e->redo ? "redo" : "undo");
	} else {
		op.node = bc_tree_root(s->tree);
		op.subtree.ptr = e->bytes;
		op.subtree.len = (uint32_t)e->len;
		/* m is held by this task already: the step's own task holds
		 * it on. */
		(void)apply_step(m, e->redo, e->seq, &op, 1);
	}
	bc_free(e->bytes);
	bc_free(e);
}

int bc__undo_step(struct bc_member *m, bool redo, uint32_t seq)
{
	struct bc_session *s = m->session;
	struct bc_undo *u = s->undo;
	struct bc_proto_edit_op *ops = NULL;
	struct bc_proto_field *fields = NULL;
	struct step *st;
	uint8_t *subtree = NULL;
	uint32_t nops = 0;
	int rc;
	if (!u || (redo ? u->nredo : u->nundo) == 0) {
		bc__send_error(m, seq, BC_ESTATE, "nothing to %s",
		               redo ? "redo" : "undo");
		return 0;
	}
	st = top_of(u, redo);
	if (st->old && bc_tree_node_count(st->old) >= BC_SRV_HEAVY_NODES) {
		struct encode_task *e = bc_calloc(1, sizeof(*e));
		if (e) {
			e->who = m->peer->ref;
			e->seq = seq;
			e->redo = redo;
			e->t.run = encode_run;
			e->t.done = encode_done;
			e->t.holds_order = true;
			bc__task_start(s, &e->t);
			return bc__hold(s, m, seq);
		}
	}
	if ((rc = step_ops(s, st, &ops, &nops, &fields, &subtree)) == 0) {
		rc = apply_step(m, redo, seq, ops, nops);
	} else {
		bc__send_error(m, seq, rc, "%s refused: out of memory",
		               redo ? "redo" : "undo");
		rc = 0;
	}
	bc_free(ops);
	bc_free(fields);
	bc_free(subtree);
	return rc;
}
