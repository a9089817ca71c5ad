/*
 * The viewer's picture of who is in the session: the library's roster
 * (names as the members gave them in HELLO), who presents and the author
 * of the last change, formatted as the overlay's lines.
 */
#include <stdio.h>
#include <string.h>

#include "viewer.h"

void bc_viewer_roster_update(struct bc_viewer_roster *r,
                             const struct bc_client *c)
{
	bc_client_members(c, &r->m, &r->n);
	r->self = bc_client_info(c)->member_id;
}

static const struct bc_client_member *find(const struct bc_viewer_roster *r,
                                           uint32_t id)
{
	for (size_t i = 0; i < r->n; i++) {
		if (r->m[i].id == id) {
			return &r->m[i];
		}
	}
	return NULL;
}

void bc_viewer_roster_edit(struct bc_viewer_roster *r, uint32_t author,
                           uint64_t order)
{
	const struct bc_client_member *m = find(r, author);
	r->last_author = author;
	r->last_order = order;
	if (author == r->self) {
		snprintf(r->last_name, sizeof(r->last_name), "you");
	} else if (m && m->name[0]) {
		snprintf(r->last_name, sizeof(r->last_name), "%s", m->name);
	} else {
		snprintf(r->last_name, sizeof(r->last_name), "member %u",
		         author);
	}
}

const char *bc_viewer_undo_text(const struct bc_viewer_roster *r,
                                const struct bc_msg *m, char *out, size_t n)
{
	const struct bc_msg_edit_applied *e = &m->edit_applied;
	const struct bc_client_member *who = find(r, e->author);
	char by[BC_PROTO_MAX_NAME + 16];
	if (who && who->name[0]) {
		snprintf(by, sizeof(by), "%s", who->name);
	} else {
		snprintf(by, sizeof(by), "member %u", e->author);
	}
	if (e->target_author.len) {
		snprintf(out, n, "%s %s %.*s's edit %llu", by,
		         (m->flags & BC_PROTO_FLAG_REDO) ? "redid" : "undid",
		         (int)e->target_author.len, e->target_author.ptr,
		         (unsigned long long)e->target_order);
	} else {
		snprintf(out, n, "%s %s an unnamed member's edit %llu", by,
		         (m->flags & BC_PROTO_FLAG_REDO) ? "redid" : "undid",
		         (unsigned long long)e->target_order);
	}
	return out;
}

/* Appends to out[*len..n), keeping a NUL; returns false once full. */
static bool put(char *out, size_t n, size_t *len, const char *s)
{
	size_t k = strlen(s);
	if (*len + k + 1 > n) {
		return false;
	}
	memcpy(out + *len, s, k + 1);
	*len += k;
	return true;
}

const char *bc_viewer_roster_text(const struct bc_viewer_roster *r, char *out,
                                  size_t n)
{
	char item[BC_PROTO_MAX_NAME + 48];
	size_t len = 0;
	bool ok = true;
	if (n == 0) {
		return out;
	}
	out[0] = '\0';
	snprintf(item, sizeof(item), "%zu member%s:", r->n,
	         r->n == 1 ? "" : "s");
	ok = put(out, n, &len, item);
	for (size_t i = 0; ok && i < r->n; i++) {
		const struct bc_client_member *m = &r->m[i];
		const char *role =
		    m->role == BC_PROTO_ROLE_VIEWER ? "viewer" : "editor";
		const char *pres =
		    r->presenter && m->id == r->presenter ? ", presenting" : "";
		if (m->id == r->self) {
			snprintf(item, sizeof(item), "%s you (%s%s)",
			         i ? "," : "", role, pres);
		} else if (m->name[0]) {
			snprintf(item, sizeof(item), "%s %s (%s%s)",
			         i ? "," : "", m->name, role, pres);
		} else {
			snprintf(item, sizeof(item), "%s member %u (%s%s)",
			         i ? "," : "", m->id, role, pres);
		}
		ok = put(out, n, &len, item);
	}
	if (ok && r->presenter) {
		const struct bc_client_member *p = find(r, r->presenter);
		char who[BC_PROTO_MAX_NAME + 16];
		if (p && p->name[0]) {
			snprintf(who, sizeof(who), "%s", p->name);
		} else {
			snprintf(who, sizeof(who), "member %u", r->presenter);
		}
		if (r->presenter == r->self) {
			snprintf(item, sizeof(item),
			         "\nyou present (Shift-F stops)");
		} else if (r->following) {
			snprintf(item, sizeof(item), "\nfollowing %s (F stops)",
			         who);
		} else {
			snprintf(item, sizeof(item),
			         "\n%s presents (F follows)", who);
		}
		ok = put(out, n, &len, item);
	}
	if (ok && r->last_author) {
		snprintf(item, sizeof(item), "\nlast edit: %s, order %llu",
		         r->last_name, (unsigned long long)r->last_order);
		ok = put(out, n, &len, item);
	}
	if (!ok && n > 4) {
		/* Cut: say so rather than end mid-name silently. */
		size_t at = len < n - 4 ? len : n - 4;
		memcpy(out + at, "...", 4);
	}
	return out;
}
