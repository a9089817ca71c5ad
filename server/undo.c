/*
 * Undo and redo (loop thread; the history of a session being restored is
 * built on its load task). Each session keeps a bounded history of the
 * changes applied to its scene since it was loaded: for each, who made it
 * (the author's client name, PROTOCOL.md 7.20) and what puts the scene
 * back, in proportion to the change -- the earlier states of the nodes a
 * parameter edit changed, or the operations that take a structural edit
 * back (edit/inverse.c: a REMOVE of what was inserted, an INSERT of what
 * was removed with its ids at its place, a REPLACE by the subtree that was
 * replaced). UNDO applies a step's operations as an ordinary edit (SETs of
 * the saved states, or the kept operations), so it is journaled and
 * broadcast as EDIT_APPLIED (flag UNDO, naming the edit undone and its
 * author), and every mirror sees a plain edit. What that edit's own batch
 * yields is the REDO step, and the other way round.
 *
 * Each step belongs to its author. UNDO of scope MINE takes the sender's
 * newest applied step that no later applied step has built on: a later
 * step built on S when it changed a node S changed, or changed the shape
 * (inserted, removed, replaced) of a node S's undo needs, or inserted
 * under a node S made (the marks below). Built-on steps are skipped and
 * stay; the session-wide UNDO (its owner or presenter, and earlier
 * clients) takes the newest step whoever made it. A new edit drops its
 * author's undone steps. The edits of one member's drag make one step; a
 * SCENE_LOAD clears the history.
 *
 * The history is journaled with the edits: each record names its author,
 * its time, whether it was an edit, an undo or a redo (and of which step),
 * and carries the operations that undo a structural change
 * (bc__undo_record_encode). A restore replays the records through the
 * same rules (bc__undo_note), so the history after a restart is the one
 * before it.
 */
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/edit.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

/* What a step did to a node (marks decide "built on"). */
#define MARK_FIELDS 0x1u /* its fields changed */
#define MARK_SHAPE 0x2u  /* made, removed or replaced (its subtree too) */
#define MARK_NEEDS 0x4u  /* the step's undo puts a subtree back under it */
#define MARK_PARENT 0x8u /* the step inserted under it */

struct mark {
	uint32_t id;
	uint32_t how;
};

struct step {
	uint64_t order;   /* the edit this step undoes (or redoes) */
	uint64_t at;      /* the change that made it what it is now */
	uint64_t time_ms; /* when that edit was made, Unix ms */
	char author[BC_PROTO_MAX_NAME + 1];
	char what[BC_PROTO_MAX_HISTORY_TEXT + 1];
	uint32_t member; /* its author's member id while connected; 0 */
	bool open;       /* that member's drag still adds to it */
	struct bc_edit_saved *nodes; /* parameter step: states to restore */
	uint32_t n, cap;
	struct bc_ops_copy kept; /* structural step: what undoes it */
	struct mark *marks;
	uint32_t nmarks, mcap;
	size_t bytes;
};

struct bc_undo {
	/* Oldest first; applied steps can be undone, undone ones redone. */
	struct step applied[BC_SRV_UNDO_STEPS], undone[BC_SRV_UNDO_STEPS];
	uint32_t napplied, nundone;
	size_t bytes;
};

struct bc_undo *bc__undo_new(void)
{
	return bc_calloc(1, sizeof(struct bc_undo));
}

static void step_free(struct bc_undo *u, struct step *st)
{
	u->bytes -= st->bytes;
	bc_free(st->nodes);
	bc_free(st->marks);
	bc_ops_copy_finish(&st->kept);
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

/* Drops every step. */
static void empty(struct bc_undo *u)
{
	while (u->napplied) {
		drop(u, u->applied, &u->napplied, u->napplied - 1);
	}
	while (u->nundone) {
		drop(u, u->undone, &u->nundone, u->nundone - 1);
	}
}

void bc__undo_free(struct bc_undo *u)
{
	if (u) {
		empty(u);
		bc_free(u);
	}
}

void bc__undo_clear(struct bc_session *s)
{
	bc__undo_free(s->undo);
	s->undo = NULL;
}

void bc__undo_restored(struct bc_undo *u)
{
	/* Member ids do not outlive a restart: an anonymous member's steps
	 * belong to nobody now, and no drag goes on. */
	for (uint32_t i = 0; u && i < u->napplied; i++) {
		u->applied[i].member = 0;
		u->applied[i].open = false;
	}
	for (uint32_t i = 0; u && i < u->nundone; i++) {
		u->undone[i].member = 0;
	}
}

/* ---- ids ------------------------------------------------------------------ */

/* Node ids to a value, for merging a drag's states and for telling what
 * a later step built on. Open addressing; keys are id + 1 (0: empty). */
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

static bool mark(struct bc_undo *u, struct step *st, uint32_t id, uint32_t how)
{
	if (st->nmarks == st->mcap) {
		uint32_t cap = st->mcap ? 2u * st->mcap : 8u;
		struct mark *more = bc_realloc(st->marks, cap * sizeof(*more));
		if (!more) {
			return false;
		}
		st->marks = more;
		st->mcap = cap;
	}
	st->marks[st->nmarks++] = (struct mark){id, how};
	st->bytes += sizeof(struct mark);
	u->bytes += sizeof(struct mark);
	return true;
}

struct mark_with {
	struct bc_undo *u;
	struct step *st;
	uint32_t how;
};

static bool mark_id(void *ud, uint32_t id)
{
	struct mark_with *m = ud;
	/* An id of 0 names no node (and an applied subtree has none:
	 * EINVAL, PROTOCOL.md 7.12). */
	return id == 0 || mark(m->u, m->st, id, m->how);
}

/* Marks every node of a subtree (scene bytes) with how: their ids as the
 * scanner reads them, without a tree built for them (an INSERT of 60 000
 * spheres spent 15 ms of the loop decoding its subtree for its ids). */
static bool mark_subtree(struct bc_undo *u, struct step *st,
                         struct bc_proto_bytes sub, uint32_t how)
{
	struct mark_with m = {u, st, how};
	/* Only applied subtrees get here; one that does not scan marks
	 * nothing more. */
	return bc_proto_scene_scan_ids(sub.ptr, sub.len, mark_id, &m, NULL) !=
	       BC_ENOMEM;
}

/* Marks what ops (the change's own, or inverse: what undoes it) touch. */
static bool mark_ops(struct bc_undo *u, struct step *st,
                     const struct bc_proto_edit_op *ops, uint32_t n,
                     bool inverse)
{
	bool ok = true;
	for (uint32_t i = 0; i < n && ok; i++) {
		const struct bc_proto_edit_op *op = &ops[i];
		switch (op->kind) {
		case BC_PROTO_EDIT_SET:
		case BC_PROTO_EDIT_NAME:
			ok = mark(u, st, op->node, MARK_FIELDS);
			break;
		case BC_PROTO_EDIT_INSERT:
			ok = mark(u, st, op->node,
			          inverse ? MARK_NEEDS : MARK_PARENT) &&
			     mark_subtree(u, st, op->subtree, MARK_SHAPE);
			break;
		case BC_PROTO_EDIT_REMOVE:
			ok = mark(u, st, op->node, MARK_SHAPE);
			break;
		case BC_PROTO_EDIT_REPLACE:
			ok = mark(u, st, op->node, MARK_SHAPE) &&
			     mark_subtree(u, st, op->subtree, MARK_SHAPE);
			break;
		default:
			break;
		}
	}
	return ok;
}

/* Whether a step with marks `later` built on one with marks `was`. */
static bool builds_on(uint32_t later, uint32_t was)
{
	const uint32_t change = MARK_FIELDS | MARK_SHAPE;
	return ((later & change) && (was & change)) ||
	       ((later & MARK_SHAPE) && (was & MARK_NEEDS)) ||
	       ((later & MARK_PARENT) && (was & MARK_SHAPE));
}

/* The newest applied step made after st (its `at`) that built on st, or
 * NULL (also when out of memory: then nothing is refused for it). */
static const struct step *built_on(const struct bc_undo *u,
                                   const struct step *st)
{
	struct id_set ids;
	const struct step *hit = NULL;
	if (!id_set_init(&ids, st->nmarks)) {
		return NULL;
	}
	for (uint32_t i = 0; i < st->nmarks; i++) {
		uint32_t k = id_set_slot(&ids, st->marks[i].id);
		ids.keys[k] = (uint64_t)st->marks[i].id + 1u;
		ids.at[k] |= st->marks[i].how;
	}
	for (uint32_t j = u->napplied; j-- > 0 && !hit;) {
		const struct step *t = &u->applied[j];
		if (t == st || t->at <= st->at) {
			continue;
		}
		for (uint32_t i = 0; i < t->nmarks; i++) {
			uint32_t k = id_set_slot(&ids, t->marks[i].id);
			if (ids.keys[k] &&
			    builds_on(t->marks[i].how, ids.at[k])) {
				hit = t;
				break;
			}
		}
	}
	id_set_finish(&ids);
	return hit;
}

/* ---- steps ----------------------------------------------------------------- */

/* Adds to st what undoes a change: the operations inv (a structural
 * change, ops its own operations), or the saved states b of the nodes st
 * does not hold yet (a node's first saved state is its state before).
 * Returns false when out of memory. */
static bool step_add(struct bc_undo *u, struct step *st,
                     const struct bc_edit_batch *b,
                     const struct bc_proto_edit_op *ops, uint32_t nops,
                     const struct bc_proto_edit_op *inv, uint32_t ninv)
{
	struct id_set ids;
	bool ok = true;
	if (b->structural) {
		if (bc_ops_copy(&st->kept, inv, ninv)) {
			return false;
		}
		st->bytes += st->kept.bytes;
		u->bytes += st->kept.bytes;
		return mark_ops(u, st, ops, nops, false) &&
		       mark_ops(u, st, st->kept.ops, st->kept.n, true);
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
		ok = mark(u, st, b->saved[i].id, MARK_FIELDS);
	}
	id_set_finish(&ids);
	return ok;
}

/* Keeps the history within its bounds, dropping the oldest steps. */
static void trim(struct bc_undo *u)
{
	while (u->napplied > 0 && (u->bytes > BC_SRV_UNDO_BYTES ||
	                           u->napplied > BC_SRV_UNDO_STEPS)) {
		drop(u, u->applied, &u->napplied, 0);
	}
	while (u->nundone > 0 && u->bytes > BC_SRV_UNDO_BYTES) {
		drop(u, u->undone, &u->nundone, 0);
	}
}

/* A new step on top of stack (oldest dropped when full). */
static struct step *push(struct bc_undo *u, struct step *stack, uint32_t *n)
{
	if (*n == BC_SRV_UNDO_STEPS) {
		drop(u, stack, n, 0);
	}
	return &stack[(*n)++];
}

bool bc__undo_owns(const char *author, uint32_t member,
                   const struct bc_undo_who *who)
{
	if (author[0]) {
		return who->name[0] && strcmp(author, who->name) == 0;
	}
	return member != 0 && member == who->member;
}

static bool owns(const struct step *st, const struct bc_undo_who *who)
{
	return bc__undo_owns(st->author, st->member, who);
}

/* The name of SET field `field` of node `node` in t: its key, or a
 * primitive's parameter name ("radius"), else "paramK". */
static void field_name(char *out, size_t cap, const struct bc_tree *t,
                       uint32_t node, uint8_t field)
{
	const struct bc_proto_field_info *f = bc_proto_field_info(field);
	unsigned k = (unsigned)(field - BC_PROTO_FIELD_PARAM0);
	struct bc_prim_data p;
	const struct bc_prim_info *info;
	if (f && f->key) {
		snprintf(out, cap, "%s", f->key);
	} else if (t && bc_tree_get(t, node, &p, NULL) &&
	           p.kind != BC_PRIM_INVALID && (info = bc_prim_info(p.kind)) &&
	           k < info->nparams) {
		snprintf(out, cap, "%s", info->params[k].name);
	} else {
		snprintf(out, cap, "param%u", k);
	}
}

/* A node's name for a description: control characters as \xNN (a name
 * may hold any UTF-8 but NUL, and a history is printed on terminals),
 * cut whole characters at a time to fit out (cap bytes with the NUL). */
static void name_text(char *out, size_t cap, struct bc_proto_str name)
{
	const uint8_t *p = (const uint8_t *)name.ptr;
	size_t at = 0;
	for (uint32_t i = 0; i < name.len;) {
		uint8_t c = p[i];
		size_t n = c < 0x80 ? 1 : c < 0xe0 ? 2 : c < 0xf0 ? 3 : 4;
		bool ctrl = c < 0x20 || c == 0x7f;
		size_t need = ctrl ? 4 : n;
		if (at + need + 1 > cap || i + n > name.len) {
			break;
		}
		if (ctrl) {
			snprintf(out + at, cap - at, "\\x%02x", (unsigned)c);
		} else {
			memcpy(out + at, p + i, n);
		}
		at += need;
		i += (uint32_t)n;
	}
	out[at] = '\0';
}

/* "SET node 12 translate, radius", "REMOVE node 7", "3 operations"; t is
 * the scene after the change (NULL: parameters by number). */
static void describe(char *out, size_t cap, const struct bc_proto_edit_op *ops,
                     uint32_t n, const struct bc_tree *t)
{
	const struct bc_proto_edit_op *op = n ? &ops[0] : NULL;
	size_t at;
	if (!op) {
		snprintf(out, cap, "nothing");
		return;
	}
	if (n > 1) {
		bool sets = true;
		for (uint32_t i = 0; i < n; i++) {
			sets = sets && ops[i].kind == BC_PROTO_EDIT_SET;
		}
		snprintf(out, cap, sets ? "SET %u nodes" : "%u operations", n);
		return;
	}
	switch (op->kind) {
	case BC_PROTO_EDIT_SET:
		at = (size_t)snprintf(out, cap, "SET node %u", op->node);
		for (uint8_t k = 0; k < op->nfields && at < cap; k++) {
			char name[64];
			field_name(name, sizeof(name), t, op->node,
			           op->fields[k].field);
			at += (size_t)snprintf(out + at, cap - at, "%s%s",
			                       k ? ", " : " ", name);
		}
		break;
	case BC_PROTO_EDIT_INSERT:
		snprintf(out, cap, "INSERT under node %u", op->node);
		break;
	case BC_PROTO_EDIT_REMOVE:
		snprintf(out, cap, "REMOVE node %u", op->node);
		break;
	case BC_PROTO_EDIT_NAME:
		if (op->name.len == 0) {
			snprintf(out, cap, "NAME node %u (none)", op->node);
		} else {
			/* The name where it fits, then the closing quote. */
			at = (size_t)snprintf(out, cap, "NAME node %u \"",
			                      op->node);
			if (at + 2 < cap) {
				name_text(out + at, cap - at - 1, op->name);
				at += strlen(out + at);
				out[at] = '"';
				out[at + 1] = '\0';
			}
		}
		break;
	default:
		snprintf(out, cap, "REPLACE node %u", op->node);
		break;
	}
}

/* Index of the step of order in a stack, or n. */
static uint32_t find(const struct step *stack, uint32_t n, uint64_t order)
{
	uint32_t i = n;
	while (i-- > 0 && stack[i].order != order) {
	}
	return i < n ? i : n;
}

int bc__undo_note(struct bc_undo *u, const struct bc_undo_change *c,
                  const struct bc_edit_batch *b,
                  const struct bc_proto_edit_op *inv, uint32_t ninv)
{
	struct step *st;
	struct bc_undo_who who = {c->name, c->member};
	bool ok;
	if (c->kind != BC_UNDO_EDIT) {
		/* An undo (redo) was applied: what it saved goes the other
		 * way and the step leaves its stack. A step no longer kept
		 * (dropped by the bounds) leaves nothing to move. */
		bool redo = c->kind == BC_UNDO_REDO;
		struct step *stack = redo ? u->undone : u->applied;
		uint32_t *n = redo ? &u->nundone : &u->napplied;
		uint32_t i = find(stack, *n, c->target);
		struct step keep;
		if (i == *n) {
			return 0;
		}
		/* Out of its stack first: push may drop the oldest. */
		keep = stack[i];
		memmove(&stack[i], &stack[i + 1],
		        (*n - i - 1) * sizeof(*stack));
		(*n)--;
		memset(&stack[*n], 0, sizeof(*stack));
		st = redo ? push(u, u->applied, &u->napplied)
		          : push(u, u->undone, &u->nundone);
		st->order = keep.order;
		st->time_ms = keep.time_ms;
		st->member = keep.member;
		memcpy(st->author, keep.author, sizeof(st->author));
		memcpy(st->what, keep.what, sizeof(st->what));
		st->at = c->order;
		step_free(u, &keep);
		ok = step_add(u, st, b, c->ops, c->nops, inv, ninv);
	} else {
		/* A new edit: its author's undone steps go. */
		for (uint32_t i = u->nundone; i-- > 0;) {
			if (owns(&u->undone[i], &who)) {
				drop(u, u->undone, &u->nundone, i);
			}
		}
		struct step *from =
		    u->napplied ? &u->applied[u->napplied - 1] : NULL;
		if (from && from->open && from->member == c->member &&
		    !from->kept.ops && !b->structural &&
		    from->n + b->nsaved <= BC_PROTO_MAX_EDIT_OPS) {
			/* The drag goes on (or ends with this edit): one
			 * step. */
			st = from;
			ok = step_add(u, st, b, c->ops, c->nops, inv, ninv);
		} else {
			if (from) {
				from->open = false;
			}
			st = push(u, u->applied, &u->napplied);
			st->order = c->order;
			st->member = c->member;
			snprintf(st->author, sizeof(st->author), "%s", c->name);
			describe(st->what, sizeof(st->what), c->ops, c->nops,
			         c->tree);
			ok = step_add(u, st, b, c->ops, c->nops, inv, ninv);
		}
		st->time_ms = c->time_ms;
		st->at = c->order;
		/* A drag's step undoes the whole drag: it is named by its
		 * last edit (PROTOCOL.md 7.20). */
		st->order = c->order;
		st->open = c->interacting;
	}
	if (!ok) {
		return BC_ENOMEM;
	}
	trim(u);
	return 0;
}

/* ---- the session's requests ------------------------------------------------ */

static struct bc_undo *history(struct bc_session *s)
{
	if (!s->undo) {
		s->undo = bc__undo_new();
	}
	return s->undo;
}

void bc__undo_record(struct bc_session *s, const struct bc_undo_change *c,
                     struct bc_edit_batch *b)
{
	struct bc_undo *u = history(s);
	int rc;
	if (!u) {
		bc_log(BC_LOG_WARN,
		       "session %s: no memory for the undo history", s->name);
		return;
	}
	rc = bc__undo_note(u, c, b, b->inv.ops, b->inv.nops);
	/* The tree a structural batch replaced goes off the loop. */
	bc__tree_free_later(s->ss->loop, b->old);
	b->old = NULL;
	if (rc) {
		bc_log(BC_LOG_WARN,
		       "session %s: no memory for the undo history; it "
		       "restarts here",
		       s->name);
		bc__undo_clear(s);
	}
}

/* Who m is, for owning steps. */
static struct bc_undo_who who_of(const struct bc_member *m)
{
	return (struct bc_undo_who){m->peer->name, m->member_id};
}

/* The step a request takes: the newest of its stack (scope SESSION), or
 * the newest of m's that nothing built on (MINE). NULL, with m told why
 * (request seq), when there is none. */
static struct step *choose(struct bc_member *m, bool redo, bool mine,
                           uint32_t seq)
{
	struct bc_undo *u = m->session->undo;
	const char *verb = redo ? "redo" : "undo";
	struct bc_undo_who who = who_of(m);
	struct step *stack = u ? (redo ? u->undone : u->applied) : NULL;
	uint32_t n = u ? (redo ? u->nundone : u->napplied) : 0;
	struct step *first = NULL;
	const struct step *by = NULL;
	for (uint32_t i = n; i-- > 0;) {
		const struct step *t;
		if (mine && !owns(&stack[i], &who)) {
			continue;
		}
		if (!(t = built_on(u, &stack[i]))) {
			return &stack[i];
		}
		if (!first) {
			first = &stack[i];
			by = t;
		}
		if (!mine) {
			break; /* the session's newest, or nothing */
		}
	}
	if (!first) {
		bc__send_error(m, seq, BC_ESTATE, "nothing to %s%s", verb,
		               mine ? ": no change of yours is left" : "");
		return NULL;
	}
	bc__send_error(m, seq, BC_ESTATE,
	               "%s refused: %s edit %llu (%s) has since been built on "
	               "by edit %llu (%s, by %s); its author can %s that first",
	               verb,
	               mine ? "every change of yours is built on: your newest,"
	                    : "the session's newest,",
	               (unsigned long long)first->order, first->what,
	               (unsigned long long)by->at, by->what,
	               by->author[0] ? by->author : "an anonymous member",
	               verb);
	return NULL;
}

struct bc_undo_change bc__undo_change_of(const struct bc_session *s,
                                         const struct bc_author *a,
                                         const struct bc_change *how,
                                         const struct bc_proto_edit_op *ops,
                                         uint32_t nops)
{
	return (struct bc_undo_change){
	    .kind = how->kind ? how->kind : BC_UNDO_EDIT,
	    .interacting = (how->flags & BC_PROTO_FLAG_INTERACTING) != 0,
	    .order = s->order,
	    .target = how->target_order,
	    .time_ms = how->time_ms,
	    .name = a->name,
	    .member = a->member_id,
	    .ops = ops,
	    .nops = nops,
	    .tree = s->tree,
	};
}

void bc__undo_applied(struct bc_session *s, const struct bc_author *a,
                      const struct bc_change *how, struct bc_edit_batch *b,
                      const struct bc_proto_edit_op *ops, uint32_t nops,
                      void *ud)
{
	struct bc_undo_change c = bc__undo_change_of(s, a, how, ops, nops);
	(void)ud;
	/* An undo or redo moves a step of a history that is there (one
	 * dropped meanwhile for lack of memory stays dropped). */
	if (c.kind != BC_UNDO_EDIT && !s->undo) {
		return;
	}
	bc__undo_record(s, &c, b);
}

/* Applies step st, as an EDIT of m's (request seq) whose operations are
 * the step's kept ones, or SETs (and, for a colour to take away, a
 * one-node REPLACE) of its saved states; errors go to m. Returns 0, or
 * BC_HOLD while the step is applied on a task. */
static int apply_step(struct bc_member *m, struct step *st, bool redo,
                      uint32_t seq)
{
	struct bc_session *s = m->session;
	struct bc_edit_inverse states = {0};
	const struct bc_proto_edit_op *ops = st->kept.ops;
	uint32_t nops = st->kept.n;
	struct bc_errinfo ei = {0};
	struct bc_change how = {0};
	int rc;
	if (!ops) {
		if ((rc = bc_edit_inverse_of_states(&states, s->tree, st->nodes,
		                                    st->n))) {
			bc__send_error(m, seq, rc, "%s refused: out of memory",
			               redo ? "redo" : "undo");
			return 0;
		}
		ops = states.ops;
		nops = states.nops;
	}
	if ((rc = bc__change_waits(m, ops, nops, seq,
	                           redo ? "a redo" : "an undo"))) {
		bc_edit_inverse_finish(&states);
		return rc;
	}
	how.flags = redo ? BC_PROTO_FLAG_REDO : BC_PROTO_FLAG_UNDO;
	how.target_order = st->order;
	how.kind = redo ? BC_UNDO_REDO : BC_UNDO_UNDO;
	memcpy(how.target_author, st->author, sizeof(how.target_author));
	/* bc__apply copies the operations: the step may go meanwhile. */
	rc = bc__apply(m, ops, (uint16_t)nops, seq, &how, bc__undo_applied,
	               NULL, &ei);
	bc_edit_inverse_finish(&states);
	if (rc < 0) {
		bc__send_error(m, seq, rc, "%s refused: %s",
		               redo ? "redo" : "undo", ei.msg);
		return 0;
	}
	return bc__hold(s, m, seq);
}

/* Whether m may take back the session's newest change, whoever made it:
 * the presenter, or the session's owner (PROTOCOL.md 7.20). */
static bool may_undo_session(const struct bc_member *m)
{
	const struct bc_session *s = m->session;
	if (s->presenter_id && s->presenter_id == m->member_id) {
		return true;
	}
	return s->owner[0] && strcmp(s->owner, m->peer->name) == 0;
}

int bc__undo_step(struct bc_member *m, bool redo, uint8_t scope, uint32_t seq)
{
	bool granted = (m->peer->features & BC_PROTO_FEATURE_HISTORY) != 0;
	struct step *st;
	if (scope != BC_PROTO_UNDO_DEFAULT && !granted) {
		bc__send_error(m, seq, BC_ENOTSUP,
		               "%s with a scope needs the HISTORY feature, "
		               "which this connection did not announce",
		               redo ? "REDO" : "UNDO");
		return 0;
	}
	if (scope == BC_PROTO_UNDO_DEFAULT) {
		/* An earlier client keeps the session-wide undo; a client
		 * that knows scopes undoes its own by default. */
		scope = granted ? BC_PROTO_UNDO_MINE : BC_PROTO_UNDO_SESSION;
	} else if (scope == BC_PROTO_UNDO_SESSION && !may_undo_session(m)) {
		bc__send_error(m, seq, BC_EPERM,
		               "only the session's owner (%s) or its presenter "
		               "may %s the session's last change; use your own "
		               "%s",
		               m->session->owner[0] ? m->session->owner
		                                    : "none",
		               redo ? "redo" : "undo", redo ? "redo" : "undo");
		return 0;
	}
	if (!(st = choose(m, redo, scope == BC_PROTO_UNDO_MINE, seq))) {
		return 0;
	}
	return apply_step(m, st, redo, seq);
}

/* ---- HISTORY ---------------------------------------------------------------- */

int bc__undo_history(struct bc_member *m, uint32_t seq)
{
	struct bc_session *s = m->session;
	struct bc_undo *u = s->undo;
	struct bc_undo_who who = who_of(m);
	struct bc_proto_history_entry *e = NULL;
	struct bc_msg out = {.type = BC_MSG_HISTORY, .seq = seq};
	uint32_t n = 0, total = u ? u->napplied + u->nundone : 0;
	bool next_undo = false, next_redo = false;
	if (!(m->peer->features & BC_PROTO_FEATURE_HISTORY)) {
		bc__send_error(m, seq, BC_ENOTSUP,
		               "HISTORY_GET needs the HISTORY feature, which "
		               "this connection did not announce");
		return 0;
	}
	if (total && !(e = bc_calloc(total, sizeof(*e)))) {
		bc__send_error(m, seq, BC_ENOMEM, "history: out of memory");
		return 0;
	}
	/* Newest first: applied and undone steps by the change that made
	 * them what they are. */
	for (uint32_t ia = u ? u->napplied : 0, iu = u ? u->nundone : 0;
	     ia > 0 || iu > 0;) {
		bool take_undone =
		    iu > 0 &&
		    (ia == 0 || u->undone[iu - 1].at > u->applied[ia - 1].at);
		struct step *st =
		    take_undone ? &u->undone[--iu] : &u->applied[--ia];
		const struct step *by = built_on(u, st);
		struct bc_proto_history_entry *x = &e[n++];
		bool *next = take_undone ? &next_redo : &next_undo;
		x->order = st->order;
		x->time_ms = st->time_ms;
		x->built_on = by ? by->at : 0;
		x->state = take_undone ? BC_PROTO_HISTORY_UNDONE
		                       : BC_PROTO_HISTORY_APPLIED;
		if (owns(st, &who)) {
			x->flags |= BC_PROTO_HISTORY_YOURS;
			if (!by && !*next) {
				x->flags |= BC_PROTO_HISTORY_NEXT;
				*next = true;
			}
		}
		x->author.ptr = st->author;
		x->author.len = (uint32_t)strlen(st->author);
		x->what.ptr = st->what;
		x->what.len = (uint32_t)strlen(st->what);
	}
	out.history.order = s->order;
	out.history.nentries = (uint16_t)n;
	out.history.entries = e;
	bc__send(m, &out);
	bc_free(e);
	return 0;
}

/* ---- the journal's form ------------------------------------------------------ */

/* A history record: two 0xfe bytes (an op_count no EDIT has), then
 *   u8 kind (BC_UNDO_EDIT, _UNDO, _REDO), u8 flags (bit 0: interacting),
 *   u64 time_ms, u64 target (the step undone or redone), u32 member,
 *   str(64) author, u32 length + the change's EDIT payload,
 *   u32 length + the EDIT payload that undoes it (0: a parameter change,
 *   whose earlier states the replay reads from the tree). */
#define HIST_MAGIC 0xfeu
#define HIST_FIXED (2u + 1u + 1u + 8u + 8u + 4u + 2u + 4u + 4u)

static int edit_payload(struct bc_proto_buf *b,
                        const struct bc_proto_edit_op *ops, uint32_t n,
                        struct bc_errinfo *ei)
{
	struct bc_msg as_edit = {.type = BC_MSG_EDIT};
	as_edit.edit.nops = (uint16_t)n;
	as_edit.edit.ops = ops;
	bc_proto_buf_init(b, 0);
	return bc_proto_encode(b, &as_edit, ei);
}

int bc__undo_record_encode(struct bc_proto_buf *out,
                           const struct bc_undo_change *c,
                           const struct bc_proto_edit_op *inv, uint32_t ninv,
                           struct bc_errinfo *ei)
{
	struct bc_proto_buf fwd = {0}, back = {0};
	size_t nlen = strlen(c->name), flen, blen = 0;
	uint8_t *p;
	int rc;
	bc_proto_buf_init(out, 0);
	if ((rc = edit_payload(&fwd, c->ops, c->nops, ei)) ||
	    (ninv && (rc = edit_payload(&back, inv, ninv, ei)))) {
		goto out;
	}
	flen = fwd.len - BC_PROTO_HEADER_SIZE;
	if (ninv) {
		blen = back.len - BC_PROTO_HEADER_SIZE;
	}
	if (!(p = bc_malloc(HIST_FIXED + nlen + flen + blen))) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		goto out;
	}
	out->data = p;
	out->len = out->cap = HIST_FIXED + nlen + flen + blen;
	*p++ = HIST_MAGIC;
	*p++ = HIST_MAGIC;
	*p++ = c->kind;
	*p++ = c->interacting ? 1u : 0u;
	bc_put_le64(p, c->time_ms);
	bc_put_le64(p + 8, c->target);
	bc_put_le32(p + 16, c->member);
	bc_put_le16(p + 20, (uint16_t)nlen);
	memcpy(p + 22, c->name, nlen);
	p += 22 + nlen;
	bc_put_le32(p, (uint32_t)flen);
	memcpy(p + 4, fwd.data + BC_PROTO_HEADER_SIZE, flen);
	p += 4 + flen;
	bc_put_le32(p, (uint32_t)blen);
	if (blen) {
		memcpy(p + 4, back.data + BC_PROTO_HEADER_SIZE, blen);
	}
out:
	bc_proto_buf_finish(&fwd);
	bc_proto_buf_finish(&back);
	return rc;
}

int bc__undo_record_parse(const uint8_t *rec, size_t len,
                          struct bc_undo_record *r)
{
	size_t at;
	memset(r, 0, sizeof(*r));
	if (len < 2 || rec[0] != HIST_MAGIC || rec[1] != HIST_MAGIC) {
		return 0;
	}
	if (len < HIST_FIXED) {
		return BC_EPROTO_TRUNCATED;
	}
	r->kind = rec[2];
	r->interacting = (rec[3] & 1u) != 0;
	r->time_ms = bc_get_le64(rec + 4);
	r->target = bc_get_le64(rec + 12);
	r->member = bc_get_le32(rec + 20);
	r->name_len = bc_get_le16(rec + 24);
	if (r->kind < BC_UNDO_EDIT || r->kind > BC_UNDO_REDO ||
	    r->name_len > BC_PROTO_MAX_NAME) {
		return BC_ERANGE;
	}
	if (len < HIST_FIXED + r->name_len) {
		return BC_EPROTO_TRUNCATED;
	}
	memcpy(r->name, rec + 26, r->name_len);
	r->name[r->name_len] = '\0';
	at = 26 + r->name_len;
	r->fwd_len = bc_get_le32(rec + at);
	if (r->fwd_len > len - at - 8u) {
		return BC_EPROTO_TRUNCATED;
	}
	r->fwd = rec + at + 4;
	at += 4 + r->fwd_len;
	r->inv_len = bc_get_le32(rec + at);
	if (r->inv_len != len - at - 4u) {
		return BC_EPROTO_LENGTH;
	}
	r->inv = r->inv_len ? rec + at + 4 : NULL;
	return 1;
}

/* ---- carried over a snapshot ------------------------------------------------- */

/* The history as of a snapshot (its file history-N.bin, store.c), so that
 * a journal that starts after it loses none of it: per step, u8 stack
 * (1 applied, 2 undone), u64 order, u64 at, u64 time_ms, u32 member (0),
 * str author, str what, u32 mark count and the marks (u32 id, u8 how),
 * u32 length + the EDIT payload that undoes (redoes) it -- a parameter
 * step's saved states written as the SETs that restore them. */
#define CARRY_STEP_FIXED (1u + 8u + 8u + 8u + 4u + 2u + 2u + 4u + 4u)

/* Appends n bytes to a growing buffer; false when out of memory. */
static bool put(struct bc_proto_buf *b, const void *p, size_t n)
{
	if (b->len + n > b->cap) {
		size_t cap = b->cap ? b->cap : 256;
		uint8_t *more;
		while (cap < b->len + n) {
			cap *= 2;
		}
		if (!(more = bc_realloc(b->data, cap))) {
			return false;
		}
		b->data = more;
		b->cap = cap;
	}
	memcpy(b->data + b->len, p, n);
	b->len += n;
	return true;
}

static bool put_int(struct bc_proto_buf *b, uint64_t v, unsigned bytes)
{
	uint8_t le[8];
	for (unsigned i = 0; i < bytes; i++) {
		le[i] = (uint8_t)(v >> (8u * i));
	}
	return put(b, le, bytes);
}

static bool put_str(struct bc_proto_buf *b, const char *s)
{
	size_t n = strlen(s);
	return put_int(b, n, 2) && put(b, s, n);
}

/* One step in its carried form; a step whose states no longer name nodes
 * of t is left out (it could not be undone anyway). */
static bool carry_step(struct bc_proto_buf *out, const struct step *st,
                       uint8_t stack, const struct bc_tree *t)
{
	struct bc_edit_inverse states = {0};
	struct bc_proto_buf ops = {0};
	struct bc_errinfo ei = {0};
	const struct bc_proto_edit_op *o = st->kept.ops;
	uint32_t n = st->kept.n;
	bool ok = true;
	if (!o) {
		if (bc_edit_inverse_of_states(&states, t, st->nodes, st->n)) {
			return true;
		}
		o = states.ops;
		n = states.nops;
	}
	if (n == 0 || edit_payload(&ops, o, n, &ei)) {
		bc_edit_inverse_finish(&states);
		bc_proto_buf_finish(&ops);
		return true;
	}
	ok = put_int(out, stack, 1) && put_int(out, st->order, 8) &&
	     put_int(out, st->at, 8) && put_int(out, st->time_ms, 8) &&
	     put_int(out, 0, 4) && put_str(out, st->author) &&
	     put_str(out, st->what) && put_int(out, st->nmarks, 4);
	for (uint32_t i = 0; ok && i < st->nmarks; i++) {
		ok = put_int(out, st->marks[i].id, 4) &&
		     put_int(out, st->marks[i].how, 1);
	}
	ok = ok && put_int(out, ops.len - BC_PROTO_HEADER_SIZE, 4) &&
	     put(out, ops.data + BC_PROTO_HEADER_SIZE,
	         ops.len - BC_PROTO_HEADER_SIZE);
	bc_edit_inverse_finish(&states);
	bc_proto_buf_finish(&ops);
	return ok;
}

int bc__undo_carry(const struct bc_undo *u, const struct bc_tree *t,
                   uint8_t **out, size_t *len)
{
	struct bc_proto_buf b = {0};
	bool ok = true;
	*out = NULL;
	*len = 0;
	if (!u || u->napplied + u->nundone == 0) {
		return 0;
	}
	for (uint32_t i = 0; ok && i < u->napplied; i++) {
		ok = carry_step(&b, &u->applied[i], 1, t);
	}
	for (uint32_t i = 0; ok && i < u->nundone; i++) {
		ok = carry_step(&b, &u->undone[i], 2, t);
	}
	if (!ok) {
		bc_free(b.data);
		return BC_ENOMEM;
	}
	*out = b.data;
	*len = b.len;
	return 0;
}

/* Reads one carried step at *at into a new step of u; 0, or an error
 * for bytes that do not hold one (the file is then ignored whole). */
static int uncarry_step(struct bc_undo *u, const uint8_t *p, size_t len,
                        size_t *at)
{
	struct bc_proto_reader r;
	struct bc_msg m = {0};
	struct bc_errinfo ei = {0};
	struct step *st;
	size_t a = *at;
	uint32_t alen, wlen, nmarks, olen;
	uint8_t stack;
	int rc = 0;
	if (len - a < CARRY_STEP_FIXED) {
		return BC_EPROTO_TRUNCATED;
	}
	stack = p[a];
	if (stack != 1 && stack != 2) {
		return BC_EENUM;
	}
	if ((stack == 1 ? u->napplied : u->nundone) == BC_SRV_UNDO_STEPS) {
		return BC_ELIMIT;
	}
	st = stack == 1 ? &u->applied[u->napplied] : &u->undone[u->nundone];
	memset(st, 0, sizeof(*st));
	st->order = bc_get_le64(p + a + 1);
	st->at = bc_get_le64(p + a + 9);
	st->time_ms = bc_get_le64(p + a + 17);
	a += 29;
	alen = bc_get_le16(p + a);
	if (alen > BC_PROTO_MAX_NAME || len - a - 2 < alen + 2u) {
		return BC_EPROTO_TRUNCATED;
	}
	memcpy(st->author, p + a + 2, alen);
	a += 2 + alen;
	wlen = bc_get_le16(p + a);
	if (wlen > BC_PROTO_MAX_HISTORY_TEXT || len - a - 2 < wlen + 4u) {
		return BC_EPROTO_TRUNCATED;
	}
	memcpy(st->what, p + a + 2, wlen);
	a += 2 + wlen;
	nmarks = bc_get_le32(p + a);
	a += 4;
	if (nmarks > (len - a) / 5u) {
		return BC_EPROTO_TRUNCATED;
	}
	for (uint32_t i = 0; i < nmarks && !rc; i++) {
		rc = mark(u, st, bc_get_le32(p + a), p[a + 4]) ? 0 : BC_ENOMEM;
		a += 5;
	}
	if (rc || len - a < 4u || (olen = bc_get_le32(p + a)) > len - a - 4u) {
		step_free(u, st);
		return rc ? rc : BC_EPROTO_TRUNCATED;
	}
	bc_proto_reader_init(&r, NULL);
	if ((rc = bc_proto_decode_payload(&r, BC_MSG_EDIT, 0, 0, p + a + 4,
	                                  olen, &m, &ei)) == 0 &&
	    bc_ops_copy(&st->kept, m.edit.ops, m.edit.nops)) {
		rc = BC_ENOMEM;
	}
	bc_proto_reader_finish(&r);
	if (rc) {
		step_free(u, st);
		return rc;
	}
	st->bytes += st->kept.bytes;
	u->bytes += st->kept.bytes;
	*at = a + 4 + olen;
	if (stack == 1) {
		u->napplied++;
	} else {
		u->nundone++;
	}
	return 0;
}

int bc__undo_uncarry(struct bc_undo *u, const uint8_t *p, size_t len)
{
	size_t at = 0;
	int rc = 0;
	empty(u);
	while (at < len && !rc) {
		rc = uncarry_step(u, p, len, &at);
	}
	if (rc) {
		empty(u);
	}
	trim(u);
	return rc;
}
