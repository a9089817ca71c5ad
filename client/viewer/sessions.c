/*
 * The sessions panel (L): the daemon's sessions from its SESSIONS answer,
 * a cursor a person moves to one of them, and the panel's text. Asking
 * (SESSION_LIST, GET_STATS) and joining the chosen one are the caller's
 * (net.c, main.c); this file keeps the rows and writes the words, as the
 * browser page's sessions panel says them (docs/web.md).
 */
#include <stdio.h>
#include <string.h>

#include "blobcast/buf.h"
#include "viewer.h"

void bc_viewer_sessions_take(struct bc_viewer_sessions *s,
                             const struct bc_msg_sessions *m,
                             const char *current)
{
	uint32_t n = m->nsessions < BC_VIEWER_SESSIONS_MAX
	                 ? m->nsessions
	                 : BC_VIEWER_SESSIONS_MAX;
	s->n = n;
	s->listed_n = m->nsessions;
	s->listed = true;
	s->cur = 0;
	if (!s->delete_seq) {
		s->doomed[0] = '\0'; /* a first Delete is for one row */
	}
	for (uint32_t i = 0; i < n; i++) {
		const struct bc_proto_session_entry *e = &m->sessions[i];
		struct bc_viewer_session_row *r = &s->row[i];
		size_t len = e->name.len < BC_PROTO_MAX_NAME
		                 ? e->name.len
		                 : BC_PROTO_MAX_NAME;
		memcpy(r->name, e->name.ptr, len);
		r->name[len] = '\0';
		/* The daemon names sessions in printable ASCII; any other
		 * byte would break the panel's lines (or its font). */
		for (size_t k = 0; k < len; k++) {
			unsigned char ch = (unsigned char)r->name[k];
			if (ch < 0x20u || ch > 0x7eu) {
				r->name[k] = '?';
			}
		}
		r->members = e->members;
		r->prims = e->prims;
		r->order = e->order;
		r->last_edit_ms = e->last_edit_ms;
		r->loaded = (e->flags & BC_PROTO_SESSION_LOADED) != 0;
		r->known = (e->flags & BC_PROTO_SESSION_KNOWN) != 0;
		if (current && strcmp(r->name, current) == 0) {
			s->cur = i;
		}
	}
}

void bc_viewer_sessions_stats(struct bc_viewer_sessions *s,
                              const struct bc_msg_stats *st)
{
	if (st->has_memory) {
		s->has_memory = true;
		s->memory = st->memory;
	}
}

bool bc_viewer_sessions_name_char(struct bc_viewer_sessions *s, uint32_t cp)
{
	bool ok = (cp >= 'a' && cp <= 'z') || (cp >= 'A' && cp <= 'Z') ||
	          (cp >= '0' && cp <= '9') || cp == '-' || cp == '_' ||
	          (cp == '.' && s->name_len > 0);
	if (!ok || s->name_len >= BC_PROTO_MAX_NAME) {
		return false;
	}
	s->name[s->name_len++] = (char)cp;
	s->name[s->name_len] = '\0';
	return true;
}

void bc_viewer_sessions_name_back(struct bc_viewer_sessions *s)
{
	if (s->name_len > 0) {
		s->name[--s->name_len] = '\0';
	}
}

void bc_viewer_sessions_move(struct bc_viewer_sessions *s, int delta)
{
	int64_t n = s->n, c;
	if (!s->delete_seq) {
		s->doomed[0] = '\0';
	}
	if (n == 0) {
		return;
	}
	c = ((int64_t)s->cur + delta) % n;
	s->cur = (uint32_t)(c < 0 ? c + n : c);
}

const char *bc_viewer_sessions_chosen(const struct bc_viewer_sessions *s)
{
	return s->cur < s->n ? s->row[s->cur].name : NULL;
}

/* v with a comma between groups of three digits, as the page writes
 * counts ("1,024,000"). Returns out. */
static const char *grouped(uint64_t v, char *out, size_t n)
{
	char digits[24];
	size_t len, o = 0;
	snprintf(digits, sizeof(digits), "%llu", (unsigned long long)v);
	len = strlen(digits);
	for (size_t i = 0; i < len && o + 1 < n; i++) {
		if (i > 0 && (len - i) % 3u == 0 && o + 2 < n) {
			out[o++] = ',';
		}
		out[o++] = digits[i];
	}
	out[o < n ? o : n - 1] = '\0';
	return out;
}

/* "12 s", "3 min", "2 h", "5 d": how long ago `then` was at `now`. */
static void age(uint64_t now, uint64_t then, char *out, size_t n)
{
	uint64_t sec = now > then ? (now - then) / 1000u : 0u;
	if (sec < 60u) {
		snprintf(out, n, "%llu s", (unsigned long long)sec);
	} else if (sec < 3600u) {
		snprintf(out, n, "%llu min", (unsigned long long)(sec / 60u));
	} else if (sec < 86400u) {
		snprintf(out, n, "%llu h", (unsigned long long)(sec / 3600u));
	} else {
		snprintf(out, n, "%llu d", (unsigned long long)(sec / 86400u));
	}
}

static void row_text(const struct bc_viewer_session_row *r, bool cursor,
                     bool own, bool doomed, uint64_t now, char *out, size_t n)
{
	size_t len = 0;
	len = bc_str_appendf(out, n, len, "%c %s  %u member%s",
	                     cursor ? '>' : ' ', r->name, r->members,
	                     r->members == 1 ? "" : "s");
	if (!r->loaded || !r->known) {
		len = bc_str_appendf(out, n, len, "  on disk, not loaded yet");
	} else {
		char prims[32];
		len = bc_str_appendf(out, n, len, "  %s shape%s  order %llu",
		                     grouped(r->prims, prims, sizeof(prims)),
		                     r->prims == 1 ? "" : "s",
		                     (unsigned long long)r->order);
		if (r->last_edit_ms) {
			char ago[32];
			age(now, r->last_edit_ms, ago, sizeof(ago));
			len = bc_str_appendf(out, n, len, "  changed %s ago",
			                     ago);
		}
	}
	if (own) {
		len = bc_str_appendf(out, n, len, "  (this window)");
	}
	if (doomed) {
		bc_str_appendf(out, n, len,
		               "  - Delete again deletes it for everyone");
	}
}

const char *bc_viewer_sessions_text(const struct bc_viewer_sessions *s,
                                    const char *current, uint64_t now_ms,
                                    char *out, size_t n)
{
	size_t len = 0;
	uint32_t first;
	if (!n) {
		return out;
	}
	out[0] = '\0';
	if (s->naming) {
		bc_str_appendf(out, n, len,
		               "New session: %s_\n(letters, digits, - _ and ., "
		               "not starting with .; Enter creates and joins "
		               "it, Esc cancels)",
		               s->name);
		return out;
	}
	len = bc_str_appendf(out, n, len,
	                     "Sessions: Enter joins, N new, Delete deletes, "
	                     "F5 asks again, L or Esc closes\n");
	if (!s->listed) {
		bc_str_appendf(out, n, len, "%s",
		               s->asked ? "asking the daemon..."
		                        : "no list came (the status line "
		                          "says why); F5 asks again");
		return out;
	}
	len = bc_str_appendf(out, n, len, "%u session%s on this daemon",
	                     s->listed_n, s->listed_n == 1 ? "" : "s");
	if (s->listed_n > s->n) {
		len =
		    bc_str_appendf(out, n, len, " (the first %u shown)", s->n);
	}
	if (s->has_memory && s->memory.scene_nodes_cap) {
		uint64_t held = s->memory.scene_nodes,
		         cap = s->memory.scene_nodes_cap;
		char a[32], b[32];
		len = bc_str_appendf(
		    out, n, len, "  scene memory %s of %s nodes (%llu %%)",
		    grouped(held, a, sizeof(a)), grouped(cap, b, sizeof(b)),
		    (unsigned long long)((held * 100u + cap / 2u) / cap));
	}
	/* A window of rows around the cursor, the cursor in its middle. */
	first = s->cur >= BC_VIEWER_SESSIONS_ROWS / 2u
	            ? s->cur - BC_VIEWER_SESSIONS_ROWS / 2u
	            : 0u;
	if (s->n > BC_VIEWER_SESSIONS_ROWS &&
	    first + BC_VIEWER_SESSIONS_ROWS > s->n) {
		first = s->n - BC_VIEWER_SESSIONS_ROWS;
	} else if (s->n <= BC_VIEWER_SESSIONS_ROWS) {
		first = 0;
	}
	for (uint32_t i = first;
	     i < s->n && i < first + BC_VIEWER_SESSIONS_ROWS; i++) {
		char line[BC_PROTO_MAX_NAME + 200];
		row_text(&s->row[i], i == s->cur,
		         current && strcmp(s->row[i].name, current) == 0,
		         s->doomed[0] && strcmp(s->row[i].name, s->doomed) == 0,
		         now_ms, line, sizeof(line));
		len = bc_str_appendf(out, n, len, "\n%s", line);
	}
	return out;
}
