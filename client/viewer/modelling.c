/*
 * Modelling from the keyboard: the add palette's choice, delete,
 * duplicate, regrouping the selection under a marked operator and moving
 * it a place among its siblings (Alt+Up, Alt+Down). Each
 * action is one EDIT built, checked against the scene mirror and sent by
 * libblobcast's modelling calls (blobcast/model.h), so every member sees
 * it at once and it undoes as one step; what the library refuses before
 * sending is said on the overlay with its reason. Nothing here waits: the
 * EDIT_APPLIED (net.c) selects what the action made, an ERROR says why
 * the daemon refused it.
 *
 * Where things go: a shape or an operator from the palette is added under
 * the operator the selection is in (the selection itself when it is one;
 * the root without a selection), at our camera's target, the centre of
 * the picture; a unary kind wraps the selection; a duplicate goes beside
 * the original, along the screen's right, and becomes the selection.
 *
 * Names: F2 opens a one-line entry in the lower panel holding the
 * selection's name; typed characters (GLFW's char callback, so any
 * keyboard layout's UTF-8) go into it, Backspace takes the last one off,
 * Enter sends one NAME (bc_model_rename; empty: no name), Escape closes
 * it unsent.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app.h"
#include "blobcast/bytes.h"
#include "blobcast/model.h"

/* What node id is: a primitive, a binary operator or a unary node. */
enum node_class { NODE_NONE = 0, NODE_PRIM, NODE_OP, NODE_UNARY };

static enum node_class classify(const struct bc_tree *t, uint32_t id,
                                struct bc_op_data *op_out)
{
	struct bc_op_data op;
	if (!t || !id || !bc_tree_get(t, id, NULL, &op)) {
		return NODE_NONE;
	}
	if (op_out) {
		*op_out = op;
	}
	if (op.kind == BC_OP_INVALID) {
		return NODE_PRIM;
	}
	return bc_op_is_unary(op.kind) ? NODE_UNARY : NODE_OP;
}

void bc_viewer_drawable(const char *name, char *out, size_t n)
{
	size_t used = 0;
	for (const unsigned char *p = (const unsigned char *)name;
	     *p && used + 1 < n; p++) {
		if (*p >= 0x20u && *p < 0x7fu) {
			out[used++] = (char)*p;
		} else if ((*p & 0xc0u) != 0x80u) {
			out[used++] = '?';
		}
	}
	if (n) {
		out[used] = '\0';
	}
}

const char *bc_viewer_name_text(const struct bc_tree *t, uint32_t id, char *out,
                                size_t n)
{
	const char *name = t ? bc_tree_name(t, id) : NULL;
	char shown[BC_TREE_NAME_MAX + 1];
	if (!n) {
		return out;
	}
	out[0] = '\0';
	if (name) {
		bc_viewer_drawable(name, shown, sizeof(shown));
		snprintf(out, n, " \"%s\"", shown);
	}
	return out;
}

const char *bc_viewer_node_text(const struct bc_tree *t, uint32_t id, char *out,
                                size_t n)
{
	struct bc_prim_data p;
	struct bc_op_data op;
	struct bc_unary u;
	char words[64], name[BC_TREE_NAME_MAX + 4];
	if (!n) {
		return out;
	}
	out[0] = '\0';
	if (!t || !id || !bc_tree_get(t, id, &p, &op)) {
		return out;
	}
	bc_viewer_name_text(t, id, name, sizeof(name));
	if (op.kind == BC_OP_INVALID) {
		const struct bc_prim_info *info = bc_prim_info(p.kind);
		snprintf(out, n, "#%u %s%s", id, info ? info->name : "?", name);
	} else if (bc_tree_get_unary(t, id, &u)) {
		snprintf(out, n, "#%u %s%s", id,
		         bc_viewer_unary_text(&u, words, sizeof(words)), name);
	} else if (bc_op_is_smooth(op.kind)) {
		snprintf(out, n, "#%u %s%s blend %.3g, %u children", id,
		         bc_op_name(op.kind), name, (double)op.blend,
		         bc_tree_child_count(t, id));
	} else {
		snprintf(out, n, "#%u %s%s, %u children", id,
		         bc_op_name(op.kind), name, bc_tree_child_count(t, id));
	}
	return out;
}

/* The operator new shapes go under: the selection when it is one, else
 * the nearest one above it; 0 (the library's choice: the root, or the
 * operator under the unary nodes at the top) without a selection. */
static uint32_t add_parent(const struct bc_tree *t, uint32_t sel)
{
	for (uint32_t id = sel; id; id = bc_tree_parent(t, id)) {
		if (classify(t, id, NULL) == NODE_OP) {
			return id;
		}
	}
	return 0;
}

/* The EDIT of an action went out as r->seq: tracked for the "render
 * pending" tag and the latency, and node `select` (0: none) becomes the
 * selection once it is applied. */
static void sent(struct bc_viewer_app *a, const struct bc_model_result *r,
                 uint32_t select, const char *what)
{
	bc_viewer_edits_track(&a->edits, r->seq, bc_viewer_now_ms());
	a->model_seq = r->seq;
	a->model_select = select;
	if (a->o.verbose) {
		printf(
		    "model %s seq=%u node=%u parent=%u first_id=%u nids=%u\n",
		    what, r->seq, r->node, r->parent, r->first_id, r->nids);
		fflush(stdout);
	}
}

/* An action the library refused (nothing was sent): its reason. */
static void refused(struct bc_viewer_app *a, const char *what,
                    const struct bc_errinfo *ei)
{
	bc_viewer_status(a, "%s: %s", what, ei->msg);
}

/* Whether an action may start: an editor, a scene, no action of ours on
 * its way (the next one needs the mirror to have the last one's ids). */
static const struct bc_tree *ready(struct bc_viewer_app *a, const char *what)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	if (!bc_viewer_may_edit(a, what)) {
		return NULL;
	}
	if (a->offline || !t) {
		bc_viewer_status(a, "%s: not connected", what);
		return NULL;
	}
	if (a->model_seq) {
		bc_viewer_status(a, "%s: the last change is still on its way",
		                 what);
		return NULL;
	}
	return t;
}

void bc_viewer_model_choose(struct bc_viewer_app *a,
                            const struct bc_viewer_pal_entry *e)
{
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	const struct bc_tree *t;
	char what[64];
	snprintf(what, sizeof(what), "%s %s",
	         e->section == BC_VIEWER_PAL_UNARY ? "wrapping in" : "adding",
	         e->name);
	if (!(t = ready(a, what))) {
		return;
	}
	if (e->section == BC_VIEWER_PAL_UNARY) {
		if (!a->selected) {
			bc_viewer_status(a,
			                 "%s: select what to wrap first (click "
			                 "a shape; Up selects its parent)",
			                 what);
			return;
		}
		if (bc_model_wrap(a->c,
		                  &(struct bc_model_wrap){.node = a->selected,
		                                          .kind = e->name},
		                  &r, &ei)) {
			refused(a, what, &ei);
			return;
		}
		/* The selection stays: Alt+wheel now turns the new node. */
		sent(a, &r, a->selected, "wrap");
		bc_viewer_status(a, "#%u wrapped in %s #%u", a->selected,
		                 e->name, r.node);
		return;
	}
	if (bc_model_add(a->c,
	                 &(struct bc_model_add){
	                     .kind = e->name,
	                     .parent = add_parent(t, a->selected),
	                     .has_at = true,
	                     .at = {a->cam.target[0], a->cam.target[1],
	                            a->cam.target[2]},
	                 },
	                 &r, &ei)) {
		refused(a, what, &ei);
		return;
	}
	sent(a, &r, r.node, "add");
	bc_viewer_status(a, "added %s #%u under #%u", e->name, r.node,
	                 r.parent);
}

void bc_viewer_model_delete(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	if (!ready(a, "deleting")) {
		return;
	}
	if (!a->selected) {
		bc_viewer_status(a, "deleting: select what to delete first");
		return;
	}
	if (bc_model_remove(a->c, a->selected, &r, &ei)) {
		refused(a, "deleting", &ei);
		return;
	}
	sent(a, &r, 0, "remove");
	bc_viewer_status(a, "deleted #%u", r.node);
}

void bc_viewer_model_duplicate(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	struct bc_model_duplicate d = {.node = a->selected, .has_offset = true};
	struct bc_view_rays vr;
	const struct bc_tree *t;
	float lo[3], hi[3], step = 1.0f;
	if (!(t = ready(a, "duplicating"))) {
		return;
	}
	if (!a->selected) {
		bc_viewer_status(a, "duplicating: select what to copy first");
		return;
	}
	/* Beside the original, to the right on screen, by its width. */
	if (bc_viewer_node_box(t, a->selected, lo, hi)) {
		float dx = hi[0] - lo[0], dy = hi[1] - lo[1],
		      dz = hi[2] - lo[2];
		step = 0.6f * sqrtf(dx * dx + dy * dy + dz * dz);
	}
	bc_view_rays_init(&vr, &a->cam, 1, 1);
	for (int i = 0; i < 3; i++) {
		d.offset[i] = vr.right[i] * step;
	}
	if (bc_model_duplicate(a->c, &d, &r, &ei)) {
		refused(a, "duplicating", &ei);
		return;
	}
	sent(a, &r, r.node, "duplicate");
	bc_viewer_status(a, "copied #%u as #%u", a->selected, r.node);
}

void bc_viewer_model_mark(struct bc_viewer_app *a)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	char words[96];
	if (!bc_viewer_may_edit(a, "regrouping")) {
		return;
	}
	if (!a->selected || a->selected == a->mark) {
		a->mark = 0;
		a->redraw = true;
		bc_viewer_status(a, "no regroup parent marked");
		return;
	}
	if (classify(t, a->selected, NULL) != NODE_OP) {
		bc_viewer_status(a,
		                 "M marks an operator as the regroup parent: "
		                 "Up selects the one above #%u",
		                 a->selected);
		return;
	}
	a->mark = a->selected;
	a->redraw = true;
	bc_viewer_status(a,
	                 "regroup parent %s: select a node, G moves it "
	                 "under it",
	                 bc_viewer_node_text(t, a->mark, words, sizeof(words)));
}

void bc_viewer_model_regroup(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	if (!ready(a, "regrouping")) {
		return;
	}
	if (!a->mark) {
		bc_viewer_status(a, "regrouping: mark the new parent first "
		                    "(select an operator, M)");
		return;
	}
	if (!a->selected) {
		bc_viewer_status(a, "regrouping: select what to move under #%u",
		                 a->mark);
		return;
	}
	if (bc_model_move(
	        a->c,
	        &(struct bc_model_move){.node = a->selected, .parent = a->mark},
	        &r, &ei)) {
		refused(a, "regrouping", &ei);
		return;
	}
	sent(a, &r, a->selected, "move");
	bc_viewer_status(a, "moved #%u under #%u", r.node, a->mark);
}

void bc_viewer_model_reorder(struct bc_viewer_app *a, bool up)
{
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	const struct bc_tree *t = ready(a, "reordering");
	struct bc_op_data op = {.kind = BC_OP_INVALID};
	uint32_t top, parent, idx, n;
	bool first_changes;
	char words[96];
	if (!t) {
		return;
	}
	if (!a->selected) {
		bc_viewer_status(a, "reordering: click a shape first");
		return;
	}
	/* What moves is the top of the unary chain around the selection. */
	top = a->selected;
	while ((parent = bc_tree_parent(t, top)) &&
	       classify(t, parent, NULL) == NODE_UNARY) {
		top = parent;
	}
	if (!parent) {
		bc_viewer_status(a, "reordering: the root has no siblings");
		return;
	}
	idx = bc_tree_child_index(t, top);
	n = bc_tree_child_count(t, parent);
	if (up ? idx == 0 : idx + 1u >= n) {
		bc_viewer_status(
		    a,
		    "reordering: #%u is already the %s child "
		    "of %s; nothing sent",
		    top, up ? "first" : "last",
		    bc_viewer_node_text(t, parent, words, sizeof(words)));
		return;
	}
	/* Positions count the gaps between the children as they are now:
	 * one place later is past the next sibling. */
	if (bc_model_move(
	        a->c,
	        &(struct bc_model_move){.node = top,
	                                .parent = parent,
	                                .has_position = true,
	                                .position = up ? idx - 1u : idx + 2u},
	        &r, &ei)) {
		refused(a, "reordering", &ei);
		return;
	}
	sent(a, &r, a->selected, "reorder");
	classify(t, parent, &op);
	/* The first child of a difference is the shape the others cut:
	 * a new first child changes the shape, which the page says too. */
	first_changes = (op.kind == BC_OP_DIFFERENCE ||
	                 op.kind == BC_OP_SMOOTH_DIFFERENCE) &&
	                (idx == 0 || (up && idx == 1u));
	bc_viewer_status(a, "moved #%u to place %u of %u under #%u%s", r.node,
	                 (up ? idx - 1u : idx + 1u) + 1u, n, parent,
	                 first_changes ? ": a difference's first child is "
	                                 "the shape the others cut"
	                               : "");
}

/* K: the next kind of the selected operator, union -> intersection ->
 * difference -> union, keeping it sharp or smooth (and a smooth one's
 * blend and range); Shift+K (smooth) turns it sharp or smooth, keeping
 * its kind. */
void bc_viewer_model_op_kind(struct bc_viewer_app *a, bool smooth)
{
	static const enum bc_op next[][2] = {
	    [BC_OP_UNION] = {BC_OP_INTERSECTION, BC_OP_SMOOTH_UNION},
	    [BC_OP_INTERSECTION] = {BC_OP_DIFFERENCE,
	                            BC_OP_SMOOTH_INTERSECTION},
	    [BC_OP_DIFFERENCE] = {BC_OP_UNION, BC_OP_SMOOTH_DIFFERENCE},
	    [BC_OP_SMOOTH_UNION] = {BC_OP_SMOOTH_INTERSECTION, BC_OP_UNION},
	    [BC_OP_SMOOTH_INTERSECTION] = {BC_OP_SMOOTH_DIFFERENCE,
	                                   BC_OP_INTERSECTION},
	    [BC_OP_SMOOTH_DIFFERENCE] = {BC_OP_SMOOTH_UNION, BC_OP_DIFFERENCE},
	};
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	struct bc_op_data op;
	const struct bc_tree *t;
	enum bc_op to;
	if (!(t = ready(a, "changing an operator"))) {
		return;
	}
	if (classify(t, a->selected, &op) != NODE_OP ||
	    (size_t)op.kind >= sizeof(next) / sizeof(next[0])) {
		bc_viewer_status(a, "K changes an operator's kind: select one "
		                    "(Up selects the one above a shape)");
		return;
	}
	to = next[op.kind][smooth ? 1 : 0];
	/* Blend and range 0: the node's own when it stays smooth, the
	 * defaults when it turns smooth (bc_model_set_operator). */
	if (bc_model_set_operator(a->c, a->selected, bc_op_name(to), 0.0f, 0.0f,
	                          &r, &ei)) {
		refused(a, "changing an operator", &ei);
		return;
	}
	sent(a, &r, a->selected, "operator");
	bc_viewer_status(a, "#%u: %s -> %s", a->selected, bc_op_name(op.kind),
	                 bc_op_name(to));
}

void bc_viewer_model_rename_open(struct bc_viewer_app *a)
{
	const struct bc_tree *t;
	const char *name;
	if (!(t = ready(a, "renaming"))) {
		return;
	}
	if (!a->selected || !bc_tree_get(t, a->selected, NULL, NULL)) {
		bc_viewer_status(a,
		                 "renaming: select what to name first (click "
		                 "a shape; Up selects its parent)");
		return;
	}
	if (!(bc_client_info(a->c)->features & BC_PROTO_FEATURE_NAMES)) {
		bc_viewer_status(a, "renaming: the server does not know node "
		                    "names (an older blobcastd): upgrade it");
		return;
	}
	name = bc_tree_name(t, a->selected);
	a->rename.open = true;
	a->rename.node = a->selected;
	snprintf(a->rename.text, sizeof(a->rename.text), "%s",
	         name ? name : "");
	a->rename.len = strlen(a->rename.text);
	a->redraw = true;
	if (a->o.verbose) {
		printf("rename open node=%u\n", a->rename.node);
		fflush(stdout);
	}
}

void bc_viewer_model_rename_char(struct bc_viewer_app *a, uint32_t cp)
{
	char u[4];
	size_t k;
	/* C0 and C1 controls have no place in a label; surrogates are not
	 * characters (bc_utf8_encode gives them no bytes). */
	if (cp < 0x20u || (cp >= 0x7fu && cp < 0xa0u) ||
	    !(k = bc_utf8_encode(cp, u))) {
		return;
	}
	if (a->rename.len + k > BC_TREE_NAME_MAX) {
		bc_viewer_status(a, "a name has at most %u bytes of UTF-8",
		                 BC_TREE_NAME_MAX);
		return;
	}
	memcpy(a->rename.text + a->rename.len, u, k);
	a->rename.len += k;
	a->rename.text[a->rename.len] = '\0';
	a->redraw = true;
}

void bc_viewer_model_rename_back(struct bc_viewer_app *a)
{
	/* Back over the continuation bytes to the character's first. */
	while (a->rename.len > 0 &&
	       ((unsigned char)a->rename.text[--a->rename.len] & 0xc0u) ==
	           0x80u) {
	}
	a->rename.text[a->rename.len] = '\0';
	a->redraw = true;
}

void bc_viewer_model_rename_send(struct bc_viewer_app *a)
{
	struct bc_errinfo ei = {0};
	struct bc_model_result r;
	uint32_t node = a->rename.node;
	a->rename.open = false;
	a->redraw = true;
	if (!ready(a, "renaming")) {
		return;
	}
	if (bc_model_rename(a->c, node, a->rename.text, &r, &ei)) {
		refused(a, "renaming", &ei);
		return;
	}
	sent(a, &r, a->selected, "rename");
	if (a->rename.len) {
		char shown[BC_TREE_NAME_MAX + 1];
		bc_viewer_drawable(a->rename.text, shown, sizeof(shown));
		bc_viewer_status(a, "named #%u \"%s\"", node, shown);
	} else {
		bc_viewer_status(a, "took the name of #%u away", node);
	}
}

void bc_viewer_model_rename_text(const struct bc_viewer_app *a, char *out,
                                 size_t n)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	char words[160], shown[BC_TREE_NAME_MAX + 1];
	bc_viewer_drawable(a->rename.text, shown, sizeof(shown));
	snprintf(out, n,
	         "Name %s (%zu of %u bytes)\n"
	         "> %s_\n"
	         "Enter: rename (empty: no name)   Backspace: erase   "
	         "Esc: cancel",
	         bc_viewer_node_text(t, a->rename.node, words, sizeof(words)),
	         a->rename.len, BC_TREE_NAME_MAX, shown);
}

void bc_viewer_model_applied(struct bc_viewer_app *a, uint32_t seq)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	if (!a->model_seq || seq != a->model_seq) {
		return;
	}
	if (a->model_select && t &&
	    bc_tree_get(t, a->model_select, NULL, NULL)) {
		a->selected = a->model_select;
		if (classify(t, a->selected, NULL) == NODE_PRIM) {
			a->sel_leaf = a->selected;
		}
	}
	a->model_seq = 0;
	a->model_select = 0;
	a->redraw = true;
}

void bc_viewer_model_refused(struct bc_viewer_app *a, uint32_t seq)
{
	if (a->model_seq && seq == a->model_seq) {
		a->model_seq = 0;
		a->model_select = 0;
	}
}
