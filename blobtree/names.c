/*
 * Node names: a dense array of (id, name) entries reached through an id
 * map, apart from the nodes (a primitive pays nothing for names it does
 * not have). Deleting swaps the last entry into the hole, so the array
 * stays dense and a copy is two memcpys.
 */
#include "tree_impl.h"

#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/num.h"
#include "blobcast/bytes.h"

void bc__names_free(struct bc__names *nm)
{
	bc_free(nm->at.keys);
	bc_free(nm->at.vals);
	bc_free(nm->v);
	memset(nm, 0, sizeof(*nm));
}

int bc__names_reserve(struct bc__names *nm, uint32_t more)
{
	uint64_t need = (uint64_t)nm->n + more;
	int rc;
	if (more == 0) {
		return 0;
	}
	if (need > BC_TREE_MAX_NODES) {
		return BC_ELIMIT;
	}
	if (need > nm->cap) {
		uint32_t cap = nm->cap ? nm->cap : 8;
		struct bc__name *v;
		while (cap < need) {
			cap = cap > BC_TREE_MAX_NODES / 2 ? BC_TREE_MAX_NODES
			                                  : 2 * cap;
		}
		if (!(v = bc_reallocarray(nm->v, cap, sizeof(*v)))) {
			return BC_ENOMEM;
		}
		nm->v = v;
		nm->cap = cap;
	}
	if ((rc = bc__map_reserve(&nm->at, more))) {
		return rc;
	}
	return 0;
}

void bc__names_del(struct bc__names *nm, uint32_t id)
{
	uint32_t i = bc__map_find(&nm->at, id);
	if (i == BC_NONE) {
		return;
	}
	bc__map_del(&nm->at, id);
	if (i != --nm->n) {
		nm->v[i] = nm->v[nm->n];
		bc__map_put_nogrow(&nm->at, nm->v[i].id, i);
	}
}

/* Sets id's name (room reserved when id has none yet). */
static void names_put(struct bc__names *nm, uint32_t id, const char *text,
                      size_t len)
{
	uint32_t i = bc__map_find(&nm->at, id);
	if (i == BC_NONE) {
		i = nm->n++;
		bc__map_put_nogrow(&nm->at, id, i);
	}
	nm->v[i].id = id;
	nm->v[i].len = (uint8_t)len;
	memcpy(nm->v[i].text, text, len);
	nm->v[i].text[len] = '\0';
}

void bc__names_drop_subtree(struct bc_tree *t, uint32_t top)
{
	uint32_t n = top;
	if (t->names.n == 0) {
		return;
	}
	/* Pre-order through the links; the subtree may be detached. */
	for (;;) {
		bc__names_del(&t->names, t->pool[n].id);
		if (t->pool[n].is_op && t->pool[n].u.first_child != BC_NONE) {
			n = t->pool[n].u.first_child;
			continue;
		}
		while (n != top && t->pool[n].next == BC_NONE) {
			n = t->pool[n].parent;
		}
		if (n == top) {
			return;
		}
		n = t->pool[n].next;
	}
}

void bc__names_graft(struct bc_tree *t, const struct bc_tree *sub)
{
	for (uint32_t i = 0; i < sub->names.n && !t->nameless; i++) {
		const struct bc__name *e = &sub->names.v[i];
		uint32_t n = bc__id_find(sub, e->id);
		/* A node whose id sub chose itself gets a fresh one in t. */
		if (n != BC_NONE && !sub->pool[n].auto_id) {
			names_put(&t->names, e->id, e->text, e->len);
		}
	}
}

int bc__names_copy(struct bc__names *dst, const struct bc__names *src)
{
	int rc;
	bc__names_free(dst);
	if ((rc = bc__names_reserve(dst, src->n))) {
		return rc;
	}
	for (uint32_t i = 0; i < src->n; i++) {
		names_put(dst, src->v[i].id, src->v[i].text, src->v[i].len);
	}
	return 0;
}

int bc__name_check(const char *name, size_t len, struct bc_errinfo *ei)
{
	size_t bad;
	if (len > BC_TREE_NAME_MAX) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "a name of %zu bytes: at most %u", len,
		                      BC_TREE_NAME_MAX);
	}
	if ((bad = bc_utf8_check((const uint8_t *)name, len)) < len) {
		return bc_errinfo_set(ei, BC_ESTRING,
		                      "the name's byte %zu (0x%02x) breaks "
		                      "UTF-8 or is NUL",
		                      bad, (unsigned)(uint8_t)name[bad]);
	}
	return 0;
}

/* ---- public --------------------------------------------------------------- */

const char *bc_tree_name(const struct bc_tree *t, uint32_t id)
{
	uint32_t i = bc__map_find(&t->names.at, id);
	return i == BC_NONE ? NULL : t->names.v[i].text;
}

int bc_tree_set_name(struct bc_tree *t, uint32_t id, const char *name,
                     size_t len, struct bc_errinfo *ei)
{
	int rc;
	if (id == 0 || bc__id_find(t, id) == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u", id);
	}
	if ((rc = bc__name_check(name, len, ei))) {
		return rc;
	}
	if (t->nameless) {
		return 0;
	}
	if (len == 0) {
		bc__names_del(&t->names, id);
		return 0;
	}
	if (bc__map_find(&t->names.at, id) == BC_NONE &&
	    (rc = bc__names_reserve(&t->names, 1))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	names_put(&t->names, id, name, len);
	return 0;
}

uint32_t bc_tree_name_count(const struct bc_tree *t)
{
	return t->names.n;
}

uint32_t *bc_tree_name_ids(const struct bc_tree *t, uint32_t *n)
{
	uint32_t *ids;
	*n = t->names.n;
	if (*n == 0 || !(ids = bc_calloc(*n, sizeof(*ids)))) {
		return NULL;
	}
	for (uint32_t i = 0; i < *n; i++) {
		ids[i] = t->names.v[i].id;
	}
	qsort(ids, *n, sizeof(*ids), bc_cmp_u32);
	return ids;
}
