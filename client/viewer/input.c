/*
 * Direct manipulation, as in the browser page (docs/web.md):
 *  - a left press asks the server what is under the pointer (PICK); a
 *    primitive becomes the selection and, for an editor, the drag moves it
 *    in the view plane through the point grabbed; empty space (or a viewer's
 *    drag) orbits the camera; right or middle drag, or Shift with the left
 *    button, pans;
 *  - the wheel zooms; with Shift it scales the selected primitive's size
 *    parameter, with Ctrl the blend of the operator above it, with Alt the
 *    main parameter of the innermost unary node above it that has one
 *    (unary.c: sizes scale, signed values step);
 *  - keys: S lossless snapshot, Ctrl-S the scene as a JSON file (with
 *    Shift: binary; save.c), Ctrl-M its mesh as glTF (with Shift: OBJ;
 *    save.c, on a thread), P window screenshot, O overlay, H the
 *    keys, R the session's camera, Home zoom to fit (Shift: the
 *    selection), Escape or Q quit; Ctrl-Z undo, Ctrl-Shift-Z or Ctrl-Y
 *    redo of this window's own changes, with Alt of the session's
 *    newest (sent without waiting; the answer shows on the overlay); F
 *    follow the presenter (again: stop), Shift-F present (again: stop);
 *    I the history panel (history.c; Up/Down, PgUp/PgDn, Home/End
 *    scroll it, F5 asks again, I or Escape closes);
 *  - modelling (modelling.c does the edits): Up and Down walk the
 *    selection up the tree and back, A opens the add palette (W on its
 *    unary kinds), which then takes the keys until Enter or Escape,
 *    Delete/X deletes, D duplicates, M marks the regroup parent and G
 *    moves the selection under it; F2 opens the name entry, which takes
 *    every key (typed text through the char callback) until Enter or
 *    Escape.
 * Callbacks only record what happened; bc_viewer_drag_step() turns the
 * motion of a whole loop turn into one message. Gestures send their
 * messages with INTERACTING and end with one without it.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "app.h"

void bc_viewer_to_view(struct bc_viewer_app *a, double x, double y, float *vx,
                       float *vy)
{
	int ww = 0, wh = 0;
	glfwGetWindowSize(a->win, &ww, &wh);
	*vx = (float)(ww > 0 ? x * (double)a->view_w / (double)ww : x);
	*vy = (float)(wh > 0 ? y * (double)a->view_h / (double)wh : y);
}

static bool is_editor(const struct bc_viewer_app *a)
{
	return bc_client_info(a->c)->role == BC_PROTO_ROLE_EDITOR;
}

static void select_node(struct bc_viewer_app *a, uint32_t node)
{
	if (a->selected != node) {
		a->selected = node;
		a->redraw = true;
	}
}

void bc_viewer_drag_step(struct bc_viewer_app *a, bool final)
{
	float dx, dy, sx, sy, ex, ey;
	if (a->drag.mode == BC_VIEWER_DRAG_NONE ||
	    a->drag.mode == BC_VIEWER_DRAG_PENDING) {
		return;
	}
	if (a->mx == a->drag.last_x && a->my == a->drag.last_y && !final) {
		return;
	}
	/* Motion in view pixels: the camera's and the server's unit. */
	bc_viewer_to_view(a, a->drag.last_x, a->drag.last_y, &sx, &sy);
	bc_viewer_to_view(a, a->mx, a->my, &ex, &ey);
	dx = ex - sx;
	dy = ey - sy;
	a->drag.last_x = a->mx;
	a->drag.last_y = a->my;
	switch (a->drag.mode) {
	case BC_VIEWER_DRAG_ORBIT:
		bc_viewer_orbit(&a->cam, dx, dy);
		bc_viewer_camera_changed(a, !final);
		break;
	case BC_VIEWER_DRAG_PAN:
		bc_viewer_pan(&a->cam, dx, dy, a->view_h);
		bc_viewer_camera_changed(a, !final);
		break;
	case BC_VIEWER_DRAG_MOVE: {
		struct bc_viewer_edit e = {
		    .node = a->drag.node, .nfields = 1, .interacting = !final};
		float x0, y0;
		bc_viewer_to_view(a, a->drag.start_x, a->drag.start_y, &x0,
		                  &y0);
		/* From where it was grabbed, so rounding never accumulates. */
		bc_viewer_move_in_plane(&a->cam, a->view_h, a->drag.origin,
		                        a->drag.z, ex - x0, ey - y0,
		                        e.fields[0].v);
		e.fields[0].field = BC_PROTO_FIELD_TRANSLATE;
		e.fields[0].count = 3;
		for (int i = 0; i < 3; i++) {
			e.fields[0].v[i] =
			    fminf(fmaxf(e.fields[0].v[i], -BC_PROTO_MAX_ABS),
			          BC_PROTO_MAX_ABS);
		}
		bc_viewer_edit(a, &e);
		break;
	}
	default:
		break;
	}
}

static void finish_drag(struct bc_viewer_app *a)
{
	if (a->drag.moved) {
		bc_viewer_drag_step(a, true);
	}
	a->drag.mode = BC_VIEWER_DRAG_NONE;
}

void bc_viewer_pick_answer(struct bc_viewer_app *a, uint32_t seq, uint32_t node,
                           const float position[3])
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	struct bc_prim_data p;
	bool prim;
	if (a->drag.mode != BC_VIEWER_DRAG_PENDING || seq != a->drag.pick_seq) {
		return;
	}
	prim = node && t && bc_tree_get(t, node, &p, NULL) &&
	       p.kind != BC_PRIM_INVALID;
	if (a->o.verbose) {
		printf("pick node=%u\n", prim ? node : 0u);
		fflush(stdout);
	}
	if (prim) {
		select_node(a, node);
		a->sel_leaf = node;
	} else if (!a->drag.moved) {
		select_node(a, 0);
	}
	a->drag.mode = BC_VIEWER_DRAG_ORBIT;
	if (prim && is_editor(a) && position) {
		float px[3];
		memcpy(a->drag.origin, p.translate, sizeof(a->drag.origin));
		a->drag.node = node;
		/* The grabbed point's depth: moving the shape by the
		 * pointer's motion at that depth keeps it under the
		 * pointer. */
		a->drag.z = bc_viewer_project(&a->cam, a->view_w, a->view_h,
		                              position, px)
		                ? px[2]
		                : 1.0f;
		a->drag.mode = BC_VIEWER_DRAG_MOVE;
	}
	if (a->drag.released) {
		finish_drag(a);
	} else {
		bc_viewer_drag_step(a, false);
	}
}

static void on_button(GLFWwindow *w, int button, int action, int mods)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	if (action == GLFW_PRESS) {
		if (a->drag.mode != BC_VIEWER_DRAG_NONE) {
			return;
		}
		memset(&a->drag, 0, sizeof(a->drag));
		a->drag.button = button;
		a->drag.start_x = a->drag.last_x = a->mx;
		a->drag.start_y = a->drag.last_y = a->my;
		if (button == GLFW_MOUSE_BUTTON_RIGHT ||
		    button == GLFW_MOUSE_BUTTON_MIDDLE ||
		    (button == GLFW_MOUSE_BUTTON_LEFT &&
		     (mods & GLFW_MOD_SHIFT))) {
			a->drag.mode = BC_VIEWER_DRAG_PAN;
		} else if (button == GLFW_MOUSE_BUTTON_LEFT) {
			/* Whether this starts an orbit or moves a shape
			 * depends on what is under the pointer. */
			a->drag.mode = BC_VIEWER_DRAG_PENDING;
			a->drag.pick_seq = bc_viewer_pick(a, a->mx, a->my);
			if (!a->drag.pick_seq) {
				a->drag.mode = BC_VIEWER_DRAG_ORBIT;
			}
		}
		return;
	}
	if (action == GLFW_RELEASE && button == a->drag.button) {
		if (a->drag.mode == BC_VIEWER_DRAG_PENDING) {
			a->drag.released = true;
		} else if (a->drag.mode != BC_VIEWER_DRAG_NONE) {
			finish_drag(a);
		}
	}
}

static void on_cursor(GLFWwindow *w, double x, double y)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	a->mx = x;
	a->my = y;
	if (a->drag.mode != BC_VIEWER_DRAG_NONE &&
	    fabs(x - a->drag.start_x) + fabs(y - a->drag.start_y) >
	        BC_VIEWER_CLICK_SLOP) {
		a->drag.moved = true;
	}
}

/* Starts an Alt+wheel gesture: e edits the parameter of the innermost unary
 * node above the selection that has one. Returns false (with a note on the
 * overlay) when there is none. */
static bool start_unary(struct bc_viewer_app *a, const struct bc_tree *t,
                        struct bc_viewer_edit *e)
{
	struct bc_unary u;
	struct bc_viewer_unary_param p;
	/* A unary node selected with Up is its own target. */
	uint32_t node = bc_tree_get_unary(t, a->selected, &u) &&
	                        bc_viewer_unary_param(u.kind, &p)
	                    ? a->selected
	                    : bc_viewer_unary_target(t, a->selected, &u);
	if (!node || !bc_viewer_unary_param(u.kind, &p)) {
		bc_viewer_status(a, "no unary node with a value above #%u",
		                 a->selected);
		return false;
	}
	e->node = node;
	e->nfields = 1;
	e->fields[0].field = BC_PROTO_FIELD_PARAM0;
	e->fields[0].count = p.count;
	memcpy(e->fields[0].v, u.u, p.count * sizeof(float));
	a->wheel.unary_kind = u.kind;
	a->wheel.extent = bc_viewer_unary_extent(t, node);
	return true;
}

/* Starts or continues a Shift/Ctrl/Alt wheel gesture on the selection. */
static void wheel_edit(struct bc_viewer_app *a, enum bc_viewer_wheel what,
                       double notches)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	struct bc_prim_data p;
	struct bc_op_data op;
	float f = expf((float)notches * 0.1f);
	struct bc_viewer_edit *e = &a->wheel.edit;
	if (!bc_viewer_may_edit(a, "editing with the wheel")) {
		return;
	}
	if (!a->selected || !t || !bc_tree_get(t, a->selected, &p, &op) ||
	    (what == BC_VIEWER_WHEEL_SIZE && p.kind == BC_PRIM_INVALID)) {
		bc_viewer_status(a, "click a shape first");
		return;
	}
	if (a->wheel.what != what || a->wheel.sel != a->selected) {
		/* A new gesture starts from the scene's values; one still
		 * under way ends first. */
		if (a->wheel.what != BC_VIEWER_WHEEL_NONE) {
			struct bc_viewer_edit last = *e;
			last.interacting = false;
			a->wheel.what = BC_VIEWER_WHEEL_NONE;
			bc_viewer_edit(a, &last);
		}
		memset(e, 0, sizeof(*e));
		if (what == BC_VIEWER_WHEEL_SIZE) {
			const struct bc_prim_info *info = bc_prim_info(p.kind);
			int k = bc_viewer_size_param(p.kind);
			if (k < 0) {
				bc_viewer_status(a, "a %s has no size",
				                 info->name);
				return;
			}
			e->node = a->selected;
			e->nfields = 1;
			e->fields[0].field =
			    (uint8_t)(BC_PROTO_FIELD_PARAM0 + (unsigned)k);
			e->fields[0].count = info->params[k].count;
			memcpy(e->fields[0].v,
			       p.params + info->params[k].offset,
			       info->params[k].count * sizeof(float));
		} else if (what == BC_VIEWER_WHEEL_UNARY) {
			if (!start_unary(a, t, e)) {
				return;
			}
		} else {
			/* A smooth operator selected with Up, else the
			 * operator above the selection. */
			uint32_t parent = bc_op_is_smooth(op.kind)
			                      ? a->selected
			                      : bc_tree_parent(t, a->selected);
			if (!parent || !bc_tree_get(t, parent, NULL, &op) ||
			    !bc_op_is_smooth(op.kind)) {
				bc_viewer_status(a,
				                 "the shape's operator has no "
				                 "blend (not a smooth one)");
				return;
			}
			e->node = parent;
			e->nfields = 2;
			e->fields[0].field = BC_PROTO_FIELD_BLEND;
			e->fields[0].count = 1;
			e->fields[0].v[0] = op.blend;
			e->fields[1].field = BC_PROTO_FIELD_RANGE;
			e->fields[1].count = 1;
			e->fields[1].v[0] = op.range;
		}
		a->wheel.what = what;
		a->wheel.sel = a->selected;
	}
	if (what == BC_VIEWER_WHEEL_UNARY) {
		bc_viewer_unary_notch(a->wheel.unary_kind, e->fields[0].v,
		                      (float)notches, a->wheel.extent);
	} else {
		/* Blend and range scale together, keeping range > blend /
		 * 6. */
		for (uint32_t i = 0; i < e->nfields; i++) {
			for (uint32_t k = 0; k < e->fields[i].count; k++) {
				float v = e->fields[i].v[k] * f;
				e->fields[i].v[k] =
				    fminf(fmaxf(v, 1e-4f), 1e5f);
			}
		}
	}
	e->interacting = true;
	a->wheel.end_at = bc_viewer_now_ms() + BC_VIEWER_WHEEL_END_MS;
	bc_viewer_edit(a, e);
	a->redraw = true;
}

static void on_scroll(GLFWwindow *w, double xoff, double yoff)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	bool shift = glfwGetKey(w, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ||
	             glfwGetKey(w, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
	bool ctrl = glfwGetKey(w, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS ||
	            glfwGetKey(w, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS;
	bool alt = glfwGetKey(w, GLFW_KEY_LEFT_ALT) == GLFW_PRESS ||
	           glfwGetKey(w, GLFW_KEY_RIGHT_ALT) == GLFW_PRESS;
	(void)xoff;
	if (yoff == 0.0) {
		return;
	}
	if (shift || ctrl || alt) {
		wheel_edit(a,
		           alt    ? BC_VIEWER_WHEEL_UNARY
		           : ctrl ? BC_VIEWER_WHEEL_BLEND
		                  : BC_VIEWER_WHEEL_SIZE,
		           yoff);
		return;
	}
	/* Wheel up brings the camera closer. */
	bc_viewer_zoom(&a->cam, (float)-yoff);
	bc_viewer_camera_changed(a, true);
	a->cam_final_at = bc_viewer_now_ms() + BC_VIEWER_WHEEL_END_MS;
}

/* Home: zoom to fit the whole scene (id 0) or node id's subtree, from the
 * camera's own direction. */
static void frame_node(struct bc_viewer_app *a, uint32_t id)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	float lo[3], hi[3];
	uint32_t node = id ? id : t ? bc_tree_root(t) : 0;
	if (!node || !bc_viewer_node_box(t, node, lo, hi)) {
		bc_viewer_status(a, id ? "select a shape to frame first"
		                       : "no scene to frame yet");
		return;
	}
	bc_viewer_frame_box(&a->cam, lo, hi,
	                    a->view_h ? (float)a->view_w / (float)a->view_h
	                              : 1.0f);
	bc_viewer_camera_changed(a, false);
	if (id) {
		bc_viewer_status(a, "framed #%u", id);
	} else {
		bc_viewer_status(a, "framed the whole scene");
	}
}

/* H: what every key does, as the overlay lists it. */
static const char key_help[] =
    "Keys (H hides)\n"
    "drag: orbit, or move the shape under the pointer; right drag: pan\n"
    "wheel: zoom; Shift/Ctrl/Alt+wheel: size, blend, unary value\n"
    "click: select a shape   Up/Down: its parent / back down\n"
    "A: add (palette)   W: wrap the selection   D: duplicate\n"
    "Delete, X: delete   M: mark an operator   G: move under the mark\n"
    "Alt+Up/Down: move the selection a place among its siblings\n"
    "K: operator kind (Shift+K: sharp/smooth)   F2: name the selection\n"
    "R: the session's camera (Shift+R: make this view it)\n"
    "Home: fit the scene (Shift: selection)\n"
    "Ctrl+Z: undo yours   Ctrl+Shift+Z, Ctrl+Y: redo   +Alt: anyone's\n"
    "F: follow the presenter   Shift+F: present   L: sessions\n"
    "I: the history of changes (who, what, when, undone)\n"
    "S: snapshot   P: screenshot   O: overlay   Q, Esc: quit\n"
    "Ctrl+S: save the scene (JSON)   Ctrl+Shift+S: binary\n"
    "Ctrl+M: save its mesh (glTF)   Ctrl+Shift+M: OBJ\n"
    "Ctrl+O: load a scene file into the session";

/* Unix time in ms, for the sessions panel's ages. */
static uint64_t unix_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

bool bc_viewer_lower_panel(struct bc_viewer_app *a, char *out, size_t n)
{
	if (!n) {
		return false;
	}
	/* In the order on_key hands them the keys: the one typed into is the
	 * one shown. */
	if (a->rename.open) {
		bc_viewer_model_rename_text(a, out, n);
		return true;
	}
	if (a->load.open) {
		bc_viewer_load_text(a, out, n);
		return true;
	}
	if (a->palette.open) {
		bc_viewer_palette_text(&a->palette, out, n);
		return true;
	}
	if (a->sessions.open) {
		bc_viewer_sessions_text(&a->sessions, a->o.session, unix_ms(),
		                        out, n);
		return true;
	}
	if (a->history.open) {
		bc_viewer_history_text(&a->history, unix_ms(), out, n);
		return true;
	}
	if (a->help) {
		snprintf(out, n, "%s", key_help);
		return true;
	}
	return false;
}

/* Up: the selection's parent becomes the selection; Down: back towards
 * the primitive picked last. */
static void select_step(struct bc_viewer_app *a, bool up)
{
	const struct bc_tree *t = bc_client_scene(a->c, NULL);
	char words[96];
	uint32_t next = 0;
	if (!t || !a->selected) {
		bc_viewer_status(a, "click a shape first");
		return;
	}
	if (up) {
		next = bc_tree_parent(t, a->selected);
	} else {
		/* The node below the selection on the way to the leaf. */
		for (uint32_t id = a->sel_leaf; id && id != a->selected;
		     id = bc_tree_parent(t, id)) {
			next = id;
		}
		if (next && bc_tree_parent(t, next) != a->selected) {
			next = 0;
		}
	}
	if (!next) {
		bc_viewer_status(
		    a, up ? "#%u is the root" : "#%u: nothing picked below it",
		    a->selected);
		return;
	}
	select_node(a, next);
	bc_viewer_status(a, "selected %s",
	                 bc_viewer_node_text(t, next, words, sizeof(words)));
}

/* Keys while the palette is open; returns false for keys it leaves to
 * the rest (Ctrl combinations). */
static bool palette_key(struct bc_viewer_app *a, int key, int mods)
{
	struct bc_viewer_pal_entry e;
	if (mods & (GLFW_MOD_CONTROL | GLFW_MOD_ALT | GLFW_MOD_SUPER)) {
		return false;
	}
	a->redraw = true;
	switch (key) {
	case GLFW_KEY_UP:
		bc_viewer_palette_move(&a->palette, -1);
		break;
	case GLFW_KEY_DOWN:
		bc_viewer_palette_move(&a->palette, 1);
		break;
	case GLFW_KEY_PAGE_UP:
		bc_viewer_palette_page(&a->palette, -1);
		break;
	case GLFW_KEY_PAGE_DOWN:
		bc_viewer_palette_page(&a->palette, 1);
		break;
	case GLFW_KEY_ENTER:
	case GLFW_KEY_KP_ENTER:
		a->palette.open = false;
		if (bc_viewer_palette_entry(a->palette.cur, &e)) {
			bc_viewer_model_choose(a, &e);
		}
		break;
	case GLFW_KEY_ESCAPE:
	case GLFW_KEY_A:
	case GLFW_KEY_W:
		a->palette.open = false;
		break;
	default:
		/* GLFW's letter keys are their upper-case ASCII codes. */
		if (key >= GLFW_KEY_A && key <= GLFW_KEY_Z &&
		    !bc_viewer_palette_jump(&a->palette, (char)key)) {
			bc_viewer_status(a, "no kind starts with %c",
			                 (char)(key - GLFW_KEY_A + 'a'));
		}
		break;
	}
	return true;
}

/* Keys while a new session's name is typed: all of them (the text comes
 * through on_char). */
static void session_name_key(struct bc_viewer_app *a, int key)
{
	struct bc_viewer_sessions *s = &a->sessions;
	s->opened = false;
	switch (key) {
	case GLFW_KEY_ENTER:
	case GLFW_KEY_KP_ENTER:
		if (!s->name_len) {
			bc_viewer_status(a,
			                 "type the new session's name first");
			break;
		}
		s->naming = false;
		/* An editor's join creates a session that does not exist. */
		bc_viewer_switch_session(a, s->name);
		break;
	case GLFW_KEY_ESCAPE:
		s->naming = false;
		bc_viewer_status(a, "no new session");
		break;
	case GLFW_KEY_BACKSPACE:
		bc_viewer_sessions_name_back(s);
		break;
	default:
		break;
	}
}

/* Delete in the panel: the first press on a session asks for a second,
 * which deletes it for everyone (SESSION_DELETE; the daemon keeps its
 * files aside). The window's own session is not deleted from here. */
static void session_delete_key(struct bc_viewer_app *a)
{
	struct bc_viewer_sessions *s = &a->sessions;
	const char *chosen = bc_viewer_sessions_chosen(s);
	struct bc_msg m = {.type = BC_MSG_SESSION_DELETE};
	uint32_t seq = 0;
	if (!chosen) {
		bc_viewer_status(a, "no session listed to delete");
		return;
	}
	if (strcmp(chosen, a->o.session) == 0) {
		bc_viewer_status(a,
		                 "this window is in session %s: join another "
		                 "to delete it",
		                 chosen);
		return;
	}
	if (!bc_viewer_may_edit(a, "deleting a session") || s->delete_seq) {
		return;
	}
	if (strcmp(s->doomed, chosen) != 0) {
		snprintf(s->doomed, sizeof(s->doomed), "%s", chosen);
		bc_viewer_status(a,
		                 "Delete again deletes session %s for "
		                 "everyone (the daemon keeps its files aside)",
		                 chosen);
		return;
	}
	m.session_delete.name.ptr = s->doomed;
	m.session_delete.name.len = (uint32_t)strlen(s->doomed);
	if (bc_client_send(a->c, &m, &seq) == 0) {
		s->delete_seq = seq;
		bc_viewer_status(a, "deleting session %s...", s->doomed);
	}
}

/* Keys while the sessions panel is open; returns false for the keys it
 * leaves to the rest (Q still quits, H lists the keys, A opens the add
 * palette instead). */
static bool sessions_key(struct bc_viewer_app *a, int key, int mods)
{
	const char *chosen;
	if (a->sessions.naming) {
		session_name_key(a, key);
		a->redraw = true;
		return true;
	}
	if (mods & (GLFW_MOD_CONTROL | GLFW_MOD_ALT | GLFW_MOD_SUPER)) {
		return false;
	}
	a->redraw = true;
	switch (key) {
	case GLFW_KEY_N:
		if (bc_viewer_may_edit(a, "creating a session")) {
			a->sessions.naming = true;
			a->sessions.opened = true;
			a->sessions.name_len = 0;
			a->sessions.name[0] = '\0';
		}
		break;
	case GLFW_KEY_DELETE:
		session_delete_key(a);
		break;
	case GLFW_KEY_UP:
	case GLFW_KEY_DOWN:
		bc_viewer_sessions_move(&a->sessions,
		                        key == GLFW_KEY_UP ? -1 : 1);
		break;
	case GLFW_KEY_PAGE_UP:
	case GLFW_KEY_PAGE_DOWN:
		bc_viewer_sessions_move(&a->sessions,
		                        (key == GLFW_KEY_PAGE_UP ? -1 : 1) *
		                            (int)BC_VIEWER_SESSIONS_ROWS);
		break;
	case GLFW_KEY_F5:
		bc_viewer_sessions_ask(a);
		break;
	case GLFW_KEY_ENTER:
	case GLFW_KEY_KP_ENTER:
		if (!(chosen = bc_viewer_sessions_chosen(&a->sessions))) {
			bc_viewer_status(a, "no session listed to join");
			break;
		}
		bc_viewer_switch_session(a, chosen);
		break;
	case GLFW_KEY_ESCAPE:
	case GLFW_KEY_L:
		a->sessions.open = false;
		break;
	default:
		return false;
	}
	return true;
}

/* Keys while the history panel is open; returns false for the keys it
 * leaves to the rest (Ctrl-Z still undoes: the panel follows). */
static bool history_key(struct bc_viewer_app *a, int key, int mods)
{
	struct bc_viewer_history *h = &a->history;
	if (mods & (GLFW_MOD_CONTROL | GLFW_MOD_ALT | GLFW_MOD_SUPER)) {
		return false;
	}
	a->redraw = true;
	switch (key) {
	case GLFW_KEY_UP:
	case GLFW_KEY_DOWN:
		bc_viewer_history_scroll(h, key == GLFW_KEY_UP ? -1 : 1);
		break;
	case GLFW_KEY_PAGE_UP:
	case GLFW_KEY_PAGE_DOWN:
		bc_viewer_history_scroll(h, (key == GLFW_KEY_PAGE_UP ? -1 : 1) *
		                                (int)BC_VIEWER_HISTORY_ROWS);
		break;
	case GLFW_KEY_HOME:
	case GLFW_KEY_END:
		bc_viewer_history_scroll(h, key == GLFW_KEY_HOME
		                                ? -(int)BC_PROTO_MAX_HISTORY
		                                : (int)BC_PROTO_MAX_HISTORY);
		break;
	case GLFW_KEY_F5:
		bc_viewer_history_ask(a);
		break;
	case GLFW_KEY_ESCAPE:
	case GLFW_KEY_I:
		h->open = false;
		break;
	default:
		return false;
	}
	return true;
}

/* Keys while the name entry is open: all of them, so that nothing typed
 * into a name acts as a shortcut (the text itself comes through on_char). */
static void rename_key(struct bc_viewer_app *a, int key)
{
	switch (key) {
	case GLFW_KEY_ENTER:
	case GLFW_KEY_KP_ENTER:
		bc_viewer_model_rename_send(a);
		break;
	case GLFW_KEY_ESCAPE:
		a->rename.open = false;
		a->redraw = true;
		bc_viewer_status(a, "renaming cancelled");
		break;
	case GLFW_KEY_BACKSPACE:
		bc_viewer_model_rename_back(a);
		break;
	default:
		break;
	}
}

/* Keys while the load entry is open: all of them, as the name entry's. */
static void load_key(struct bc_viewer_app *a, int key)
{
	switch (key) {
	case GLFW_KEY_ENTER:
	case GLFW_KEY_KP_ENTER:
		bc_viewer_load_send(a);
		break;
	case GLFW_KEY_ESCAPE:
		bc_viewer_load_cancel(a);
		break;
	case GLFW_KEY_BACKSPACE:
		bc_viewer_load_back(a);
		break;
	default:
		break;
	}
}

static void on_char(GLFWwindow *w, unsigned int codepoint)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	if (a->rename.open) {
		bc_viewer_model_rename_char(a, codepoint);
	} else if (a->load.open) {
		bc_viewer_load_char(a, codepoint);
	} else if (a->sessions.open && a->sessions.naming) {
		bool opened = a->sessions.opened;
		a->sessions.opened = false;
		if (opened && (codepoint == 'n' || codepoint == 'N')) {
			return; /* the N that opened the entry */
		}
		if (!bc_viewer_sessions_name_char(&a->sessions, codepoint)) {
			bc_viewer_status(
			    a,
			    "session names use letters, digits, '-', '_' and "
			    "'.', not starting with '.', at most %u bytes",
			    BC_PROTO_MAX_NAME);
		}
		a->redraw = true;
	}
}

/* A and W: open the palette, on its shapes or its unary kinds. */
static void palette_open(struct bc_viewer_app *a, enum bc_viewer_pal_section s)
{
	if (!bc_viewer_may_edit(a, s == BC_VIEWER_PAL_UNARY ? "wrapping"
	                                                    : "adding")) {
		return;
	}
	bc_viewer_palette_open(&a->palette, s);
	a->sessions.open = false;
	a->redraw = true;
}

static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	(void)scancode;
	if (action != GLFW_PRESS && action != GLFW_REPEAT) {
		return;
	}
	if (a->rename.open) {
		rename_key(a, key);
		return;
	}
	if (a->load.open) {
		load_key(a, key);
		return;
	}
	if (a->palette.open && palette_key(a, key, mods)) {
		return;
	}
	if (a->sessions.open && sessions_key(a, key, mods)) {
		return;
	}
	if (a->history.open && history_key(a, key, mods)) {
		return;
	}
	/* Ctrl-Z undo, Ctrl-Shift-Z or Ctrl-Y redo (held: repeated): this
	 * window's own changes; with Alt too, the session's newest. */
	if ((mods & GLFW_MOD_CONTROL) &&
	    (key == GLFW_KEY_Z || key == GLFW_KEY_Y)) {
		bc_viewer_undo(a, key == GLFW_KEY_Y || (mods & GLFW_MOD_SHIFT),
		               (mods & GLFW_MOD_ALT) != 0);
		return;
	}
	if (action != GLFW_PRESS) {
		return;
	}
	/* Ctrl-S saves the scene as JSON, Ctrl-Shift-S as binary; Ctrl-M
	 * its solid as a glTF mesh, Ctrl-Shift-M as OBJ. */
	if ((mods & GLFW_MOD_CONTROL) && !(mods & GLFW_MOD_ALT) &&
	    (key == GLFW_KEY_S || key == GLFW_KEY_M)) {
		if (key == GLFW_KEY_S) {
			bc_viewer_save_scene(a, (mods & GLFW_MOD_SHIFT) != 0);
		} else {
			bc_viewer_save_mesh(a, (mods & GLFW_MOD_SHIFT) != 0);
		}
		return;
	}
	/* Ctrl-O: a scene file's path to load into the session. */
	if ((mods & GLFW_MOD_CONTROL) && key == GLFW_KEY_O) {
		bc_viewer_load_open(a);
		return;
	}
	switch (key) {
	case GLFW_KEY_ESCAPE:
	case GLFW_KEY_Q:
		glfwSetWindowShouldClose(w, GLFW_TRUE);
		break;
	case GLFW_KEY_S:
		bc_viewer_request_snapshot(a);
		break;
	case GLFW_KEY_P:
		a->screenshot_now = true;
		a->redraw = true;
		break;
	case GLFW_KEY_O:
		a->o.overlay = !a->o.overlay;
		a->redraw = true;
		break;
	case GLFW_KEY_H:
		a->help = !a->help;
		a->redraw = true;
		break;
	case GLFW_KEY_I:
		/* The session's changes, asked for each time it opens. */
		a->history.open = true;
		a->history.listed = false;
		a->history.asked = 0;
		a->sessions.open = false;
		bc_viewer_history_ask(a);
		break;
	case GLFW_KEY_L:
		/* The daemon's sessions, asked for each time it opens. */
		a->history.open = false;
		a->sessions.open = true;
		a->redraw = true;
		bc_viewer_sessions_ask(a);
		break;
	case GLFW_KEY_R:
		if (mods & GLFW_MOD_SHIFT) {
			bc_viewer_set_session_camera(a);
			break;
		}
		a->cam = a->scene_cam;
		bc_viewer_camera_changed(a, false);
		bc_viewer_status(a, "the session's camera");
		break;
	case GLFW_KEY_HOME:
		frame_node(a, (mods & GLFW_MOD_SHIFT) ? a->selected : 0);
		break;
	case GLFW_KEY_UP:
	case GLFW_KEY_DOWN:
		if (mods & GLFW_MOD_ALT) {
			bc_viewer_model_reorder(a, key == GLFW_KEY_UP);
		} else {
			select_step(a, key == GLFW_KEY_UP);
		}
		break;
	case GLFW_KEY_A:
		palette_open(a, BC_VIEWER_PAL_SHAPE);
		break;
	case GLFW_KEY_W:
		palette_open(a, BC_VIEWER_PAL_UNARY);
		break;
	case GLFW_KEY_DELETE:
	case GLFW_KEY_BACKSPACE:
	case GLFW_KEY_X:
		bc_viewer_model_delete(a);
		break;
	case GLFW_KEY_D:
		bc_viewer_model_duplicate(a);
		break;
	case GLFW_KEY_M:
		bc_viewer_model_mark(a);
		break;
	case GLFW_KEY_G:
		bc_viewer_model_regroup(a);
		break;
	case GLFW_KEY_K:
		bc_viewer_model_op_kind(a, (mods & GLFW_MOD_SHIFT) != 0);
		break;
	case GLFW_KEY_F2:
		bc_viewer_model_rename_open(a);
		break;
	case GLFW_KEY_F:
		if (mods & GLFW_MOD_SHIFT) {
			bc_viewer_present_toggle(a);
		} else {
			bc_viewer_follow_toggle(a);
		}
		break;
	default:
		break;
	}
}

static void on_resize(GLFWwindow *w, int width, int height)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	(void)width;
	(void)height;
	a->view_due = bc_viewer_now_ms() + BC_VIEWER_RESIZE_MS;
	a->redraw = true;
}

/* Moving to a screen of another density changes the content scale; the
 * framebuffer usually follows (on_resize), but the VIEW is checked either
 * way, and the overlay's text size changes with it. */
static void on_content_scale(GLFWwindow *w, float sx, float sy)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	(void)sx;
	(void)sy;
	a->view_due = bc_viewer_now_ms() + BC_VIEWER_RESIZE_MS;
	a->redraw = true;
}

static void on_refresh(GLFWwindow *w)
{
	struct bc_viewer_app *a = glfwGetWindowUserPointer(w);
	a->redraw = true;
}

void bc_viewer_input_install(struct bc_viewer_app *a)
{
	glfwSetWindowUserPointer(a->win, a);
	glfwSetMouseButtonCallback(a->win, on_button);
	glfwSetCursorPosCallback(a->win, on_cursor);
	glfwSetScrollCallback(a->win, on_scroll);
	glfwSetKeyCallback(a->win, on_key);
	glfwSetCharCallback(a->win, on_char);
	glfwSetFramebufferSizeCallback(a->win, on_resize);
	glfwSetWindowContentScaleCallback(a->win, on_content_scale);
	glfwSetWindowRefreshCallback(a->win, on_refresh);
}
