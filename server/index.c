/*
 * The index of sessions on disk (loop thread): every session's name, in
 * name order, with what SESSION_LIST says of it -- live figures for a
 * loaded session, the figures it had when it unloaded for one that was
 * loaded since the start, nothing more for the others. It is read from
 * the data directory once at start and kept current by the sessions
 * layer (created, loaded, unloaded, deleted), so that SESSION_LIST costs
 * what its answer holds, never a walk of the directory (20 000 sessions
 * took 570 ms a request).
 */
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "sessions_impl.h"

struct bc_index {
	struct bc_index_entry *e;
	uint32_t n, cap;
	bool oom;
};

/* Position of name in ix (where it is, or would be inserted); *found. */
static uint32_t find(const struct bc_index *ix, const char *name, bool *found)
{
	uint32_t lo = 0, hi = ix->n;
	*found = false;
	while (lo < hi) {
		uint32_t mid = lo + (hi - lo) / 2;
		int c = strcmp(ix->e[mid].name, name);
		if (c == 0) {
			*found = true;
			return mid;
		}
		if (c < 0) {
			lo = mid + 1;
		} else {
			hi = mid;
		}
	}
	return lo;
}

/* Room for one more entry. */
static bool grow(struct bc_index *ix)
{
	uint32_t cap;
	struct bc_index_entry *more;
	if (ix->n < ix->cap) {
		return true;
	}
	cap = ix->cap ? 2u * ix->cap : 64u;
	if (!(more = bc_realloc(ix->e, (size_t)cap * sizeof(*more)))) {
		return false;
	}
	ix->e = more;
	ix->cap = cap;
	return true;
}

struct bc_index_entry *bc__index_get(struct bc_index *ix, const char *name)
{
	bool found;
	uint32_t i = find(ix, name, &found);
	return found ? &ix->e[i] : NULL;
}

struct bc_index_entry *bc__index_add(struct bc_index *ix, const char *name)
{
	bool found;
	uint32_t i = find(ix, name, &found);
	if (found) {
		return &ix->e[i];
	}
	if (strlen(name) > BC_PROTO_MAX_NAME || !grow(ix)) {
		return NULL;
	}
	if (i < ix->n) {
		memmove(&ix->e[i + 1], &ix->e[i], (ix->n - i) * sizeof(*ix->e));
	}
	memset(&ix->e[i], 0, sizeof(ix->e[i]));
	memcpy(ix->e[i].name, name, strlen(name) + 1);
	ix->n++;
	return &ix->e[i];
}

void bc__index_remove(struct bc_index *ix, const char *name)
{
	bool found;
	uint32_t i = find(ix, name, &found);
	if (found) {
		if (i + 1 < ix->n) {
			memmove(&ix->e[i], &ix->e[i + 1],
			        (ix->n - i - 1) * sizeof(*ix->e));
		}
		ix->n--;
	}
}

uint32_t bc__index_count(const struct bc_index *ix)
{
	return ix->n;
}

struct bc_index_entry *bc__index_at(struct bc_index *ix, uint32_t i)
{
	return &ix->e[i];
}

void bc__index_note(struct bc_index *ix, const struct bc_session *s)
{
	struct bc_index_entry *e = bc__index_get(ix, s->name);
	if (!e || !s->tree) {
		return;
	}
	e->known = true;
	e->prims = bc_tree_prim_count(s->tree);
	e->order = s->order;
	e->last_edit_ms = s->last_edit_ms;
}

/* At start names come in directory order: appended, sorted once after. */
static void add_stored(void *ud, const char *name)
{
	struct bc_index *ix = ud;
	if (ix->oom || strlen(name) > BC_PROTO_MAX_NAME || !grow(ix)) {
		ix->oom = ix->oom || strlen(name) <= BC_PROTO_MAX_NAME;
		return;
	}
	memset(&ix->e[ix->n], 0, sizeof(ix->e[ix->n]));
	memcpy(ix->e[ix->n].name, name, strlen(name) + 1);
	ix->n++;
}

static int by_name(const void *a, const void *b)
{
	return strcmp(((const struct bc_index_entry *)a)->name,
	              ((const struct bc_index_entry *)b)->name);
}

int bc__index_new(struct bc_index **out, struct bc_store *store)
{
	struct bc_index *ix = bc_calloc(1, sizeof(*ix));
	*out = NULL;
	if (!ix) {
		return BC_ENOMEM;
	}
	bc_store_list(store, add_stored, ix);
	if (ix->oom) {
		bc__index_free(ix);
		return BC_ENOMEM;
	}
	if (ix->n > 1) {
		qsort(ix->e, ix->n, sizeof(*ix->e), by_name);
	}
	*out = ix;
	return 0;
}

void bc__index_free(struct bc_index *ix)
{
	if (ix) {
		bc_free(ix->e);
		bc_free(ix);
	}
}
