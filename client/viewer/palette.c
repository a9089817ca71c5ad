/*
 * The add palette: every kind a person can add from the keyboard, in three
 * sections -- shapes (every primitive kind, added under the operator the
 * selection is in), operators (added with two spheres to regroup into) and
 * unary nodes (wrapping the selection) -- and the keys that walk it: up
 * and down one entry, a page for the next section, a letter for the next
 * entry of that initial. What a chosen entry does is the caller's
 * (input.c); this file only keeps the cursor and writes the panel's text.
 */
#include <ctype.h>
#include <stdio.h>
#include <string.h>

#include "viewer.h"

/* Entries per section. */
#define NPRIMS ((uint32_t)BC_PRIM_COUNT - 1u)
#define NOPS ((uint32_t)BC_OP_SMOOTH_DIFFERENCE)
#define NUNARY ((uint32_t)BC_OP_COUNT - (uint32_t)BC_OP_OFFSET)

uint32_t bc_viewer_palette_count(void)
{
	return NPRIMS + NOPS + NUNARY;
}

bool bc_viewer_palette_entry(uint32_t i, struct bc_viewer_pal_entry *out)
{
	memset(out, 0, sizeof(*out));
	if (i < NPRIMS) {
		const struct bc_prim_info *info =
		    bc_prim_info((enum bc_prim)(i + 1u));
		out->section = BC_VIEWER_PAL_SHAPE;
		out->kind = (int)i + 1;
		out->name = info ? info->name : NULL;
	} else if (i < NPRIMS + NOPS) {
		out->section = BC_VIEWER_PAL_OPERATOR;
		out->kind = (int)(i - NPRIMS) + BC_OP_UNION;
		out->name = bc_op_name((enum bc_op)out->kind);
	} else if (i < bc_viewer_palette_count()) {
		const struct bc_unary_info *info = bc_unary_info(
		    (enum bc_op)(i - NPRIMS - NOPS + BC_OP_OFFSET));
		out->section = BC_VIEWER_PAL_UNARY;
		out->kind = (int)(i - NPRIMS - NOPS) + BC_OP_OFFSET;
		out->name = info ? info->name : NULL;
	}
	if (!out->name) {
		memset(out, 0, sizeof(*out));
		return false;
	}
	return true;
}

/* The first entry of section s. */
static uint32_t section_start(enum bc_viewer_pal_section s)
{
	switch (s) {
	case BC_VIEWER_PAL_OPERATOR:
		return NPRIMS;
	case BC_VIEWER_PAL_UNARY:
		return NPRIMS + NOPS;
	default:
		return 0;
	}
}

void bc_viewer_palette_open(struct bc_viewer_palette *p,
                            enum bc_viewer_pal_section s)
{
	p->open = true;
	p->cur = section_start(s);
}

void bc_viewer_palette_move(struct bc_viewer_palette *p, int delta)
{
	int64_t n = bc_viewer_palette_count();
	int64_t c = ((int64_t)p->cur + delta) % n;
	p->cur = (uint32_t)(c < 0 ? c + n : c);
}

void bc_viewer_palette_page(struct bc_viewer_palette *p, int dir)
{
	struct bc_viewer_pal_entry e;
	int s;
	bc_viewer_palette_entry(p->cur, &e);
	s = (int)e.section + (dir < 0 ? -1 : 1);
	if (s < BC_VIEWER_PAL_SHAPE) {
		s = BC_VIEWER_PAL_UNARY;
	} else if (s > BC_VIEWER_PAL_UNARY) {
		s = BC_VIEWER_PAL_SHAPE;
	}
	p->cur = section_start((enum bc_viewer_pal_section)s);
}

bool bc_viewer_palette_jump(struct bc_viewer_palette *p, char letter)
{
	uint32_t n = bc_viewer_palette_count();
	int want = tolower((unsigned char)letter);
	for (uint32_t k = 1; k <= n; k++) {
		struct bc_viewer_pal_entry e;
		uint32_t i = (p->cur + k) % n;
		if (bc_viewer_palette_entry(i, &e) &&
		    tolower((unsigned char)e.name[0]) == want) {
			p->cur = i;
			return true;
		}
	}
	return false;
}

static const char *section_name(enum bc_viewer_pal_section s)
{
	switch (s) {
	case BC_VIEWER_PAL_OPERATOR:
		return "operator";
	case BC_VIEWER_PAL_UNARY:
		return "wrap in";
	default:
		return "shape";
	}
}

const char *bc_viewer_palette_text(const struct bc_viewer_palette *p, char *out,
                                   size_t n)
{
	uint32_t count = bc_viewer_palette_count(), first;
	size_t len;
	if (!n) {
		return out;
	}
	snprintf(out, n,
	         "Add: Enter adds, Up/Down, PgUp/PgDn section, a letter "
	         "jumps, Esc closes\n"
	         "(shapes go under the selection's operator, or the root;"
	         " wrap needs a selection)");
	/* A window of rows around the cursor, the cursor in its middle. */
	first = p->cur >= BC_VIEWER_PAL_ROWS / 2u
	            ? p->cur - BC_VIEWER_PAL_ROWS / 2u
	            : 0u;
	if (first + BC_VIEWER_PAL_ROWS > count) {
		first = count - BC_VIEWER_PAL_ROWS;
	}
	for (uint32_t i = first; i < first + BC_VIEWER_PAL_ROWS; i++) {
		struct bc_viewer_pal_entry e;
		len = strlen(out);
		if (!bc_viewer_palette_entry(i, &e) || len + 1 >= n) {
			break;
		}
		snprintf(out + len, n - len, "\n%s %-8s %s",
		         i == p->cur ? ">" : " ", section_name(e.section),
		         e.name);
	}
	return out;
}
