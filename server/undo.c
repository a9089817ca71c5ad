/*
 * Undo and redo (loop thread). Each session keeps a bounded history of the
 * changes applied to its scene since it was loaded: for each, what puts the
 * scene back, in proportion to the change -- the earlier states of the
 * nodes a parameter edit changed, or for a structural edit the operations
 * that take it back (edit/inverse.c: a REMOVE of what was inserted, an
 * INSERT of what was removed with its ids at its place, a REPLACE by the
 * subtree that was replaced; the removed and replaced subtrees kept as
 * their scene bytes, never the whole scene unless the change was to it).
 * UNDO applies the newest step's operations as an ordinary edit (SETs of
 * the saved states, or the kept operations), so it is journaled and
 * broadcast as EDIT_APPLIED (flag UNDO, naming the edit undone and its
 * author) as a record of that size, and every mirror, and a restart, sees
 * a plain edit. What that edit's own batch yields (its saved states, or
 * its inverse) is the REDO step, and the other way round.
 *
 * The history is linear and the session's, not a member's: undo takes back
 * the newest change whoever made it. A new edit clears the redo steps; the
 * edits of one member's drag (INTERACTING, up to the release) make one
 * step; a SCENE_LOAD clears the history. It lives in memory: after a
 * restart, undo starts from the restored scene.
 *
 * The inverse of a structural batch is made as the batch applies (on a
 * task for a big scene, BC_SRV_HEAVY_NODES, edits.c), and an undo is
 * applied the same way, so neither holds the loop; the tree a structural
 * batch replaced is freed off the loop too.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

struct step {
	uint64_t order; /* the edit this step undoes (or, redo, redoes) */
	char author[BC_PROTO_MAX_NAME + 1];
	uint32_t member; /* who made it: a drag's edits join its step */
	bool open;       /* that drag still adds to it */
	struct bc_edit_saved *nodes; /* parameter step: states to restore */
	uint32_t n, cap;
	/* Structural step: the operations that undo it, with the subtrees
	 * they put back (counted at their size in bytes). */
	struct bc_edit_inverse inv;
	size_t bytes;
};

struct bc_undo {
	uv_loop_t *loop; /* frees replaced trees off it */
	struct step undo[BC_SRV_UNDO_STEPS], redo[BC_SRV_UNDO_STEPS];
	uint32_t nundo, nredo;
	size_t bytes;
};

static void step_free(struct bc_undo *u, struct step *st)
{
	u->bytes -= st->bytes;
	bc_free(st->nodes);
	bc_edit_inverse_finish(&st->inv);
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

/* Adds to st what undoes batch b: b's inverse (a structural batch), or the
 * saved states of the nodes st does not hold yet (a node's first saved
 * state is its state before). Takes b's inverse, and frees b's old tree
 * off the loop. Returns false when out of memory. */
static bool step_add(struct bc_undo *u, struct step *st,
                     struct bc_edit_batch *b)
{
	struct id_set ids;
	bool ok = true;
	if (b->structural) {
		st->inv = b->inv;
		memset(&b->inv, 0, sizeof(b->inv));
		bc__tree_free_later(u->loop, b->old);
		b->old = NULL;
		st->bytes = st->inv.bytes;
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
	if (top && top->open && top->member == a->member_id && !top->inv.ops &&
	    !b->structural && top->n + b->nsaved <= BC_PROTO_MAX_EDIT_OPS) {
		/* The drag goes on (or ends with this edit): one step. */
		ok = step_add(u, top, b);
	} else {
		if (top) {
			top->open = false;
		}
		top = push(u, u->undo, &u->nundo);
		top->member = a->member_id;
		snprintf(top->author, sizeof(top->author), "%s", a->name);
		ok = step_add(u, top, b);
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
	if (!step_add(u, back, b)) {
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

/* Applies the top step, as an EDIT of m's (request seq) whose operations
 * are the step's inverse, or SETs (and, for a colour to take away, a
 * one-node REPLACE) of its saved states; errors go to m. Returns 0, or
 * BC_HOLD while the step is applied on a task. */
static int apply_step(struct bc_member *m, bool redo, uint32_t seq)
{
	struct bc_session *s = m->session;
	struct step *st = top_of(s->undo, redo);
	struct bc_edit_inverse states = {0};
	const struct bc_edit_inverse *inv = &st->inv;
	struct bc_errinfo ei = {0};
	struct bc_change how = {0};
	int rc;
	if (!st->inv.ops && (rc = bc_edit_inverse_of_states(
	                         &states, s->tree, st->nodes, st->n))) {
		bc__send_error(m, seq, rc, "%s refused: out of memory",
		               redo ? "redo" : "undo");
		return 0;
	}
	if (!st->inv.ops) {
		inv = &states;
	}
	how.flags = redo ? BC_PROTO_FLAG_REDO : BC_PROTO_FLAG_UNDO;
	how.target_order = st->order;
	memcpy(how.target_author, st->author, sizeof(how.target_author));
	/* bc__apply copies the operations: the step may go meanwhile. */
	rc = bc__apply(m, inv->ops, (uint16_t)inv->nops, seq, &how,
	               step_applied, redo ? (void *)s : NULL, &ei);
	bc_edit_inverse_finish(&states);
	if (rc < 0) {
		bc__send_error(m, seq, rc, "%s refused: %s",
		               redo ? "redo" : "undo", ei.msg);
		return 0;
	}
	return bc__hold(s, m, seq);
}

int bc__undo_step(struct bc_member *m, bool redo, uint32_t seq)
{
	struct bc_session *s = m->session;
	struct bc_undo *u = s->undo;
	if (!u || (redo ? u->nredo : u->nundo) == 0) {
		bc__send_error(m, seq, BC_ESTATE, "nothing to %s",
		               redo ? "redo" : "undo");
		return 0;
	}
	return apply_step(m, redo, seq);
}
