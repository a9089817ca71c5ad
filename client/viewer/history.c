/*
 * The history panel (I): the session's changes from the daemon's HISTORY
 * answer, newest first, and the panel's text. Asking (HISTORY_GET) is the
 * caller's (net.c); this file keeps the rows and writes the words, as
 * `blobcast history` and the page's History panel say them.
 */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "blobcast/buf.h"
#include "viewer.h"

/* s as a C string of at most cap - 1 bytes, any byte outside printable
 * ASCII as '?' (a client name or a change's text would otherwise break
 * the panel's lines, or its font). */
static void printable(char *out, size_t cap, struct bc_proto_str s)
{
	size_t len = s.len < cap - 1 ? s.len : cap - 1;
	for (size_t k = 0; k < len; k++) {
		unsigned char ch = (unsigned char)s.ptr[k];
		out[k] = ch < 0x20u || ch > 0x7eu ? '?' : (char)ch;
	}
	out[len] = '\0';
}

void bc_viewer_history_take(struct bc_viewer_history *h,
                            const struct bc_msg_history *m)
{
	uint32_t n = m->nentries < BC_PROTO_MAX_HISTORY ? m->nentries
	                                                : BC_PROTO_MAX_HISTORY;
	h->n = n;
	h->order = m->order;
	h->listed = true;
	h->top = 0;
	for (uint32_t i = 0; i < n; i++) {
		const struct bc_proto_history_entry *e = &m->entries[i];
		struct bc_viewer_change_row *r = &h->row[i];
		r->order = e->order;
		r->time_ms = e->time_ms;
		r->built_on = e->built_on;
		r->undone = e->state == BC_PROTO_HISTORY_UNDONE;
		r->yours = (e->flags & BC_PROTO_HISTORY_YOURS) != 0;
		r->next = (e->flags & BC_PROTO_HISTORY_NEXT) != 0;
		printable(r->author, sizeof(r->author), e->author);
		printable(r->what, sizeof(r->what), e->what);
	}
}

void bc_viewer_history_scroll(struct bc_viewer_history *h, int delta)
{
	int64_t last = h->n > BC_VIEWER_HISTORY_ROWS
	                   ? (int64_t)(h->n - BC_VIEWER_HISTORY_ROWS)
	                   : 0,
	        t = (int64_t)h->top + delta;
	h->top = (uint32_t)(t < 0 ? 0 : t > last ? last : t);
}

/* "14:03:22", or "2026-12-06 14:03:22" when that is not the UTC day of
 * now; "--:--:--" when unknown. */
static void when(uint64_t now_ms, uint64_t ms, char *out, size_t n)
{
	time_t t = (time_t)(ms / 1000u), now = (time_t)(now_ms / 1000u);
	struct tm tm, today;
	if (!ms || !gmtime_r(&t, &tm) || !gmtime_r(&now, &today)) {
		snprintf(out, n, "--:--:--");
		return;
	}
	if (tm.tm_year == today.tm_year && tm.tm_yday == today.tm_yday) {
		strftime(out, n, "%H:%M:%S", &tm);
	} else {
		strftime(out, n, "%Y-%m-%d %H:%M:%S", &tm);
	}
}

static void row_text(const struct bc_viewer_change_row *r, uint64_t now,
                     char *out, size_t n)
{
	char at[32];
	size_t len;
	when(now, r->time_ms, at, sizeof(at));
	len = bc_str_appendf(out, n, 0, "%6llu  %s  %s  %s%s  %s",
	                     (unsigned long long)r->order, at,
	                     r->undone ? "undone " : "applied", r->author,
	                     r->yours ? " (you)" : "", r->what);
	if (r->built_on) {
		len = bc_str_appendf(out, n, len, "  built on by %llu",
		                     (unsigned long long)r->built_on);
	}
	if (r->next) {
		bc_str_appendf(out, n, len, "  <- your %s",
		               r->undone ? "redo" : "undo");
	}
}

const char *bc_viewer_history_text(const struct bc_viewer_history *h,
                                   uint64_t now_ms, char *out, size_t n)
{
	size_t len = 0;
	if (!n) {
		return out;
	}
	out[0] = '\0';
	len = bc_str_appendf(out, n, len,
	                     "History (UTC): Up/Down, PgUp/PgDn scroll, F5 "
	                     "asks again, I or Esc closes\n");
	if (!h->listed) {
		bc_str_appendf(out, n, len, "%s",
		               h->asked ? "asking the daemon..."
		                        : "no history came (the status line "
		                          "says why); F5 asks again");
		return out;
	}
	len = bc_str_appendf(out, n, len,
	                     "%u change%s undo and redo can take, newest "
	                     "first; the session is at edit order %llu",
	                     h->n, h->n == 1 ? "" : "s",
	                     (unsigned long long)h->order);
	if (h->n > BC_VIEWER_HISTORY_ROWS) {
		uint32_t last = h->top + BC_VIEWER_HISTORY_ROWS;
		len = bc_str_appendf(out, n, len, " (%u-%u shown)", h->top + 1,
		                     last < h->n ? last : h->n);
	}
	for (uint32_t i = h->top;
	     i < h->n && i < h->top + BC_VIEWER_HISTORY_ROWS; i++) {
		char line[BC_PROTO_MAX_NAME + BC_PROTO_MAX_HISTORY_TEXT + 120];
		row_text(&h->row[i], now_ms, line, sizeof(line));
		len = bc_str_appendf(out, n, len, "\n%s", line);
	}
	return out;
}
