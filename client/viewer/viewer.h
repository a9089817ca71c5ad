/*
 * blobcast-view's parts that need neither a window nor a GL context, so that
 * tests can link them alone (library bc_viewer_core):
 *  - cam.c: the viewer's own camera (orbit, pan, zoom), projection of world
 *    points to view pixels with the server's conventions, moving a point in
 *    the view plane, a primitive's bounding box corners, which parameter is
 *    its "size";
 *  - unary.c: which unary node Alt+wheel edits and what a notch does;
 *  - meter.c: frames per second, edit -> frame latency and kB per frame;
 *  - edits.c: the edit queue (at most one INTERACTING edit in flight, the
 *    newest values replacing any not yet sent) and the matching of edits to
 *    the frames that show them;
 *  - frames.c: FRAME messages assembled into what the textures hold: a
 *    view-size composite updated rectangle by rectangle, and the latest
 *    downscaled interactive image;
 *  - shot.c: when --screenshot stops waiting for a finished picture, and
 *    the VIEW size a framebuffer asks for under the daemon's max_dim;
 *  - font.c: a 5x7 bitmap font turned into triangles;
 *  - sessions.c: the sessions panel (the daemon's sessions, one to join).
 *  - history.c: the history panel (the session's changes undo can take).
 */
#ifndef BLOBCAST_VIEWER_H
#define BLOBCAST_VIEWER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/client.h"
#include "blobcast/proto.h"

/* ---- cam.c --------------------------------------------------------------- */

/* Radians the camera turns per pixel of mouse motion: a drag across a
 * 800-pixel window turns it about 370 degrees, as in the browser page. */
#define BC_VIEWER_ORBIT_PER_PX 0.008f
/* The orbit stops this close to the poles (cosine between the view
 * direction and up): the server refuses an up parallel to the view. */
#define BC_VIEWER_ORBIT_MAX_COS 0.995f
/* Zoom keeps the eye between these distances from the target. */
#define BC_VIEWER_ZOOM_MIN 0.05f
#define BC_VIEWER_ZOOM_MAX 1.0e5f

/* Turns the eye about the target: dx pixels about the camera's up vector,
 * dy about its right vector, never past the poles. */
void bc_viewer_orbit(struct bc_camera *cam, float dx, float dy);
/* Moves eye and target together by (dx, dy) view pixels in the view plane
 * through the target, for a view height pixels tall. */
void bc_viewer_pan(struct bc_camera *cam, float dx, float dy, uint32_t height);
/* Multiplies the eye's distance to the target by exp(steps * 0.1): one
 * wheel notch is 10 %. */
void bc_viewer_zoom(struct bc_camera *cam, float steps);
/* Clamps eye and target to the protocol's coordinate range. */
void bc_viewer_cam_clamp(struct bc_camera *cam);

/* Projects world point p into a width x height view: out[0], out[1] are
 * pixel coordinates (row 0 on top, pixel centres at +0.5, as in
 * bc_view_rays_dir) and out[2] the distance along the view direction.
 * Returns false for a point at or behind the eye. */
bool bc_viewer_project(const struct bc_camera *cam, uint32_t width,
                       uint32_t height, const float p[3], float out[3]);
/* World units per view pixel at forward distance z. */
float bc_viewer_pixel_size(const struct bc_camera *cam, float z,
                           uint32_t height);
/* Moves origin by (dx, dy) view pixels parallel to the view plane at
 * forward distance z: the result projects (dx, dy) pixels away. */
void bc_viewer_move_in_plane(const struct bc_camera *cam, uint32_t height,
                             const float origin[3], float z, float dx, float dy,
                             float out[3]);

/* The world box of node id's subtree: around the ABVs a layout gives the
 * primitives below it (widened by repeats, mirrors and the operators'
 * ranges), read from the model so that a bare mirror answers too
 * (bc_tree_node_box); a unary node's is its child's. The whole scene's is
 * the root's. Returns false when t is NULL, id is unknown or the box is
 * not finite. */
bool bc_viewer_node_box(const struct bc_tree *t, uint32_t id, float lo[3],
                        float hi[3]);
/* Zoom to fit: the sphere around the box [lo, hi] seen whole by a view of
 * width / height aspect, with BC_VIEWER_FIT_MARGIN to spare, from the
 * camera's own direction (target at the box's centre, eye moved along the
 * view line; up and field of view kept). */
void bc_viewer_frame_box(struct bc_camera *cam, const float lo[3],
                         const float hi[3], float aspect);
/* Zoom to fit leaves the sphere around the box this much room. */
#define BC_VIEWER_FIT_MARGIN 1.05f

/* The eight world-space corners of primitive p's bounding box (its local
 * bound from bc_prim_bound, rotated and translated), corner i having bit 0
 * for x, bit 1 for y and bit 2 for z. */
void bc_viewer_box_corners(const struct bc_prim_data *p, float corners[8][3]);
/* The 12 edges of such a box, as corner index pairs. */
extern const uint8_t bc_viewer_box_edges[12][2];

/* Which named parameter (bc_prim_info order) is p's size: the first whose
 * values must be positive, else the first non-negative one. Returns its
 * index, or -1 when the kind has none. */
int bc_viewer_size_param(enum bc_prim kind);

/* ---- unary.c ------------------------------------------------------------- */

/* Alt+wheel on a unary node's main parameter. Sizes that must stay
 * positive or non-negative scale by e^(0.1 n) per n notches, as Shift+wheel
 * does; signed ones move by steps scaled to the shape the node wraps. */
enum bc_viewer_notch {
	BC_VIEWER_NOTCH_NONE = 0, /* no numeric parameter (mirror's axes) */
	BC_VIEWER_NOTCH_SCALE,    /* every component times e^(0.1 n) */
	BC_VIEWER_NOTCH_ADD,      /* plus n steps of a size over the extent */
	BC_VIEWER_NOTCH_COUNT
};

/* An offset notch moves the amount by this fraction of the extent (the
 * diagonal of the wrapped shape's box): a unit sphere grows 7 % a notch,
 * so three notches show plainly. */
#define BC_VIEWER_OFFSET_STEP 0.02f
/* A twist or bend notch changes the rate by this many radians over the
 * extent: the wrapped shape turns about 10 degrees more from end to end,
 * so three notches show plainly. */
#define BC_VIEWER_RATE_STEP 0.3f
/* A notch up on a non-negative size that is 0 (an onion of thickness 0)
 * starts it at this fraction of the extent: scaling 0 keeps it 0. */
#define BC_VIEWER_SEED_STEP 0.01f
/* Scaled sizes stay at or above this (above 0, which a scale could never
 * leave; scale's own floor, 1e-3, is higher). */
#define BC_VIEWER_NOTCH_MIN 1e-4f

/* Alt+wheel's parameter of a unary kind: PARAM0, count floats from u[0]
 * (elongate's half_extents, repeat's spacing: 3), named name. */
struct bc_viewer_unary_param {
	enum bc_viewer_notch rule;
	uint8_t count;
	float lo; /* SCALE: the smallest value a component may take, 0 kept */
	const char *name;
};

/* Fills *out for kind and returns true; false (out zeroed) for mirror,
 * which has no numeric parameter, and for kinds that are not unary. */
bool bc_viewer_unary_param(enum bc_op kind, struct bc_viewer_unary_param *out);
/* The unary node Alt+wheel edits for node id: its innermost unary ancestor
 * with a numeric parameter (mirrors are passed over, binary operators
 * climbed through), read into *out. Returns its id, or 0 (out zeroed)
 * when there is none. */
uint32_t bc_viewer_unary_target(const struct bc_tree *t, uint32_t id,
                                struct bc_unary *out);
/* The size additive steps scale with for unary node id: the diagonal of the
 * world box of the ABVs of the primitives below it (bc_lin), divided by the
 * factors of the scale nodes above it, which the node's parameter does not
 * see. Repeats and mirrors above widen the box; a step stays a step. Never
 * below 1e-3; 1 when the tree has no linearized form. */
float bc_viewer_unary_extent(const struct bc_tree *t, uint32_t id);
/* Applies notches (positive: wheel up) to the parameter v of a unary node
 * of kind (bc_viewer_unary_param's count floats) with extent from
 * bc_viewer_unary_extent: SCALE rules multiply each component by
 * e^(0.1 notches), kept in [lo, BC_PARAM_MAX_ABS] (a 0 stays 0, unless
 * every component is 0 and the wheel goes up: they start at
 * BC_VIEWER_SEED_STEP extent); offset adds notches BC_VIEWER_OFFSET_STEP
 * extent, twist and bend notches BC_VIEWER_RATE_STEP / extent, kept within
 * +-BC_PARAM_MAX_ABS. Mirror and other kinds: v unchanged. */
void bc_viewer_unary_notch(enum bc_op kind, float *v, float notches,
                           float extent);
/* The overlay's words for unary node u: "twist rate 1.3", "repeat spacing
 * 2,2,2", "mirror axes xz". Returns out. */
const char *bc_viewer_unary_text(const struct bc_unary *u, char *out, size_t n);

/* ---- palette.c ----------------------------------------------------------- */

/* The add palette's sections, in the order they are listed. */
enum bc_viewer_pal_section {
	BC_VIEWER_PAL_NONE = 0,
	BC_VIEWER_PAL_SHAPE,    /* primitive kinds: add */
	BC_VIEWER_PAL_OPERATOR, /* operator kinds: add, with two spheres */
	BC_VIEWER_PAL_UNARY,    /* unary kinds: wrap the selection */
	BC_VIEWER_PAL_COUNT
};

/* Entries the palette shows at once around its cursor. */
#define BC_VIEWER_PAL_ROWS 9u

struct bc_viewer_pal_entry {
	enum bc_viewer_pal_section section;
	int kind;         /* enum bc_prim for shapes, enum bc_op otherwise */
	const char *name; /* the kind's scene-file name */
};

struct bc_viewer_palette {
	bool open;
	uint32_t cur; /* the entry Enter chooses */
};

/* Entries in all: every primitive kind, every operator, every unary
 * kind. */
uint32_t bc_viewer_palette_count(void);
/* Entry i (0 .. count - 1) into *out; false (out zeroed) past the end. */
bool bc_viewer_palette_entry(uint32_t i, struct bc_viewer_pal_entry *out);
/* Opens the palette on the first entry of section s. */
void bc_viewer_palette_open(struct bc_viewer_palette *p,
                            enum bc_viewer_pal_section s);
/* Moves the cursor by delta entries, round from the last to the first. */
void bc_viewer_palette_move(struct bc_viewer_palette *p, int delta);
/* Moves to the first entry of the next (dir > 0) or previous section,
 * round. */
void bc_viewer_palette_page(struct bc_viewer_palette *p, int dir);
/* Moves to the next entry after the cursor whose name starts with letter
 * (any case), round; false (cursor kept) when none does. */
bool bc_viewer_palette_jump(struct bc_viewer_palette *p, char letter);
/* The panel: two lines of help, then BC_VIEWER_PAL_ROWS entries around
 * the cursor as "> shape    sphere" (the cursor's) or "  wrap in  twist".
 * Returns out. */
const char *bc_viewer_palette_text(const struct bc_viewer_palette *p, char *out,
                                   size_t n);

/* ---- sessions.c ---------------------------------------------------------- */

/* Sessions kept of one SESSIONS answer (the daemon lists up to 1024). */
#define BC_VIEWER_SESSIONS_MAX 256u
/* Sessions the panel shows at once around its cursor. */
#define BC_VIEWER_SESSIONS_ROWS 9u

struct bc_viewer_session_row {
	char name[BC_PROTO_MAX_NAME + 1];
	uint32_t members, prims;
	uint64_t order, last_edit_ms; /* last_edit_ms: Unix ms, 0 unknown */
	bool loaded, known;
};

/* The sessions panel (L): the daemon's sessions as its last SESSIONS
 * answer listed them (SESSION_LIST, PROTOCOL.md 7.21), and the scene
 * memory its last STATS told (7.18), for a person to pick one to join. */
struct bc_viewer_sessions {
	bool open;
	uint32_t asked; /* the SESSION_LIST on its way (its seq; 0: none) */
	bool listed;    /* an answer came since the panel opened */
	uint32_t n, listed_n; /* rows kept; sessions the answer listed */
	uint32_t cur;         /* the row Enter joins */
	struct bc_viewer_session_row row[BC_VIEWER_SESSIONS_MAX];
	bool has_memory;
	struct bc_proto_memory memory;
	/* N: the name of a new session being typed (name_len bytes); opened
	 * true until the N's own character (which follows its key) is
	 * passed over. */
	bool naming, opened;
	uint32_t name_len;
	char name[BC_PROTO_MAX_NAME + 1];
	/* Delete pressed once on this session ("": none): a second press
	 * deletes it. The SESSION_DELETE on its way (its seq; 0: none). */
	char doomed[BC_PROTO_MAX_NAME + 1];
	uint32_t delete_seq;
};

/* Keeps a SESSIONS answer: the first BC_VIEWER_SESSIONS_MAX rows, names
 * cut at BC_PROTO_MAX_NAME bytes with any byte outside printable ASCII
 * as '?', the cursor on the session named current (the window's own) or
 * on the first. */
void bc_viewer_sessions_take(struct bc_viewer_sessions *s,
                             const struct bc_msg_sessions *m,
                             const char *current);
/* Keeps STATS's memory section, when it has one. */
void bc_viewer_sessions_stats(struct bc_viewer_sessions *s,
                              const struct bc_msg_stats *st);
/* Moves the cursor by delta rows, round from the last to the first (and
 * forgets a first Delete). */
void bc_viewer_sessions_move(struct bc_viewer_sessions *s, int delta);
/* A character typed into the new session's name: the protocol's session
 * names are letters, digits, '-', '_' and '.', not starting with '.', at
 * most BC_PROTO_MAX_NAME bytes (PROTOCOL.md 7.6). Returns false (name
 * unchanged) for one that would break that. */
bool bc_viewer_sessions_name_char(struct bc_viewer_sessions *s, uint32_t cp);
/* Backspace in the name: takes its last character off. */
void bc_viewer_sessions_name_back(struct bc_viewer_sessions *s);
/* The session under the cursor, NULL when none is listed. */
const char *bc_viewer_sessions_chosen(const struct bc_viewer_sessions *s);
/* The panel: a line of keys, a line that counts the sessions (and the
 * scene memory the daemon told), then BC_VIEWER_SESSIONS_ROWS sessions
 * around the cursor, "> review  2 members  1024 shapes  order 17  changed
 * 12 s ago" (the cursor's), the window's own marked "(this window)", one
 * the daemon has not loaded "on disk, not loaded yet"; before an answer,
 * that one is awaited (asked) or that none came (the daemon refused);
 * while a new session's name is typed, that entry instead; now_ms is the
 * Unix time in ms, for the ages. Returns out. */
const char *bc_viewer_sessions_text(const struct bc_viewer_sessions *s,
                                    const char *current, uint64_t now_ms,
                                    char *out, size_t n);

/* ---- history.c ----------------------------------------------------------- */

/* Changes the history panel shows at once. */
#define BC_VIEWER_HISTORY_ROWS 9u

struct bc_viewer_change_row {
	uint64_t order, time_ms, built_on; /* time_ms: Unix ms, 0 unknown */
	bool undone, yours, next;
	char author[BC_PROTO_MAX_NAME + 1];
	char what[BC_PROTO_MAX_HISTORY_TEXT + 1];
};

/* The history panel (I): the session's changes that undo and redo can
 * still take, newest first, as the daemon's last HISTORY answer listed
 * them (HISTORY_GET, PROTOCOL.md 7.26), scrolled by a person. */
struct bc_viewer_history {
	bool open;
	uint32_t asked;  /* the HISTORY_GET on its way (its seq; 0: none) */
	double asked_at; /* when it went (the loop's ms) */
	bool listed;     /* an answer came since the panel opened */
	uint64_t order;  /* the session's order the answer was made at */
	uint32_t n;      /* changes listed */
	uint32_t top;    /* the first row shown */
	struct bc_viewer_change_row row[BC_PROTO_MAX_HISTORY];
};

/* Keeps a HISTORY answer (every entry: at most BC_PROTO_MAX_HISTORY),
 * author and text with any byte outside printable ASCII as '?'; the rows
 * shown start at the newest. */
void bc_viewer_history_take(struct bc_viewer_history *h,
                            const struct bc_msg_history *m);
/* Scrolls the rows shown by delta, held within the list. */
void bc_viewer_history_scroll(struct bc_viewer_history *h, int delta);
/* The panel: a line of keys, a line that counts the changes, then
 * BC_VIEWER_HISTORY_ROWS changes from the first shown, as `blobcast
 * history` words them: "  17  14:03:22  applied  alice (you)  SET node
 * 12 translate  built on by 19  <- your undo" (UTC; the date too when it
 * is not today's, at now_ms, Unix ms); before an answer, that one is
 * awaited, or that none came (the status line says why). Returns out. */
const char *bc_viewer_history_text(const struct bc_viewer_history *h,
                                   uint64_t now_ms, char *out, size_t n);

/* ---- meter.c ------------------------------------------------------------- */

/* Frames averaged for kB per frame. */
#define BC_VIEWER_METER_BYTES 30
/* Latencies averaged. */
#define BC_VIEWER_METER_LATENCIES 50
/* Frame times kept for the rate: one second of 240 Hz is plenty. */
#define BC_VIEWER_METER_TIMES 256

struct bc_viewer_meter {
	double frame_at[BC_VIEWER_METER_TIMES]; /* ring of arrival times, ms */
	uint32_t nframes_at, next_at;
	uint32_t bytes[BC_VIEWER_METER_BYTES];
	uint32_t nbytes, next_bytes;
	double latency[BC_VIEWER_METER_LATENCIES];
	uint32_t nlatency, next_latency;
	double last_latency; /* ms, negative before the first */
	uint64_t frames;     /* frames counted since init */
};

void bc_viewer_meter_init(struct bc_viewer_meter *m);
/* A frame of bytes (on the wire, header included) was shown at now_ms. */
void bc_viewer_meter_frame(struct bc_viewer_meter *m, uint32_t bytes,
                           double now_ms);
/* An edit took ms from being sent to being shown. */
void bc_viewer_meter_latency(struct bc_viewer_meter *m, double ms);
/* Frames shown in the second before now_ms. */
double bc_viewer_meter_fps(const struct bc_viewer_meter *m, double now_ms);
/* Average size of the last frames, in kB (1000 bytes); 0 before any. */
double bc_viewer_meter_kb(const struct bc_viewer_meter *m);
/* Average of the last latencies in ms; negative before any. */
double bc_viewer_meter_latency_avg(const struct bc_viewer_meter *m);

/* ---- edits.c ------------------------------------------------------------- */

/* Fields one viewer edit sets: a translation, a size, or blend and range. */
#define BC_VIEWER_EDIT_FIELDS 2
/* EDITs remembered between sending and EDIT_APPLIED, and applied edits
 * remembered until a frame shows them. One interacting edit is in flight
 * at a time, so only final edits queue up; a frame or an answer that never
 * comes pushes out the oldest. */
#define BC_VIEWER_EDITS_SENT 64

struct bc_viewer_edit {
	uint32_t node;
	uint8_t nfields;
	struct bc_proto_field fields[BC_VIEWER_EDIT_FIELDS];
	bool interacting;
};

struct bc_viewer_edits {
	bool has_pending;
	struct bc_viewer_edit pending; /* the newest values not yet sent */
	uint32_t inflight; /* seq of the interacting EDIT not yet applied */
	struct {
		uint32_t seq;
		double at;
	} sent[BC_VIEWER_EDITS_SENT];
	uint32_t nsent;
	struct {
		uint64_t order;
		double at;
	} shown[BC_VIEWER_EDITS_SENT];
	uint32_t nshown;
};

void bc_viewer_edits_init(struct bc_viewer_edits *q);
/* Makes e the edit to send next, replacing one not yet sent. */
void bc_viewer_edits_queue(struct bc_viewer_edits *q,
                           const struct bc_viewer_edit *e);
/* Whether the pending edit may go now: a final edit always may, an
 * interacting one when no other interacting edit is in flight. */
bool bc_viewer_edits_ready(const struct bc_viewer_edits *q);
/* The pending edit was sent as seq at now_ms. */
void bc_viewer_edits_sent(struct bc_viewer_edits *q, uint32_t seq,
                          double now_ms);
/* An EDIT built elsewhere (a modelling action: one structural edit) was
 * sent as seq at now_ms: its answer and its first frame are matched like
 * the queue's own, and the pending edit stays. */
void bc_viewer_edits_track(struct bc_viewer_edits *q, uint32_t seq,
                           double now_ms);
/* This client's EDIT seq was applied with order. Returns true when it was
 * the one in flight (a pending edit may then go). */
bool bc_viewer_edits_applied(struct bc_viewer_edits *q, uint32_t seq,
                             uint64_t order);
/* The server refused EDIT seq (an ERROR answered it). Returns true when it
 * was ours. */
bool bc_viewer_edits_refused(struct bc_viewer_edits *q, uint32_t seq);
/* A frame reflecting edits up to order was shown at now_ms: every applied
 * edit it shows is settled, its latency given to m. Returns how many. */
uint32_t bc_viewer_edits_frame(struct bc_viewer_edits *q, uint64_t order,
                               double now_ms, struct bc_viewer_meter *m);

/* ---- frames.c ------------------------------------------------------------ */

/* What a frame changed in the textures. Rectangles are those of the FRAME
 * message (valid as long as it is). */
enum bc_viewer_tex {
	BC_VIEWER_TEX_NONE = 0,
	BC_VIEWER_TEX_FULL,  /* the view-size composite */
	BC_VIEWER_TEX_SMALL, /* a coarse (level > 0) or downscaled image */
	BC_VIEWER_TEX_COUNT
};

struct bc_viewer_update {
	enum bc_viewer_tex tex;
	bool resized; /* the texture must be (re)created at its new size */
	bool whole;   /* upload all of it (otherwise rects only) */
	const struct bc_proto_rect *rects;
	uint32_t nrects;
	/* The server sent a partial still on top of interactive frames: the
	 * parts it did not resend may be stale; ask for a whole still. */
	bool want_refresh;
};

struct bc_viewer_frames {
	struct bc_client_image full;  /* full-size frames, decoded */
	struct bc_client_image small; /* coarse or downscaled frames, decoded */
	uint8_t *comp; /* width x height RGBA: what the full texture holds */
	uint32_t width, height;
	bool have_full;     /* comp holds a picture */
	bool comp_stale;    /* a smaller frame came after comp's picture */
	bool showing_small; /* the last frame was smaller than the view */
	bool last_still;    /* the last frame had the STILL flag */
	/* The part of the small image that spans the view, as a fraction of
	 * its width and height: at level n > 0 each pixel is a 2^n block from
	 * the top-left, so view / (image * 2^n) (the last block may reach past
	 * the view); 1 for a downscaled level-0 image. */
	float small_u, small_v;
	/* The last frame's refinement level, and whether the picture is still
	 * being refined (level > 0 or INCOMPLETE: more frames follow). */
	uint8_t level;
	bool refining;
};

void bc_viewer_frames_init(struct bc_viewer_frames *f);
void bc_viewer_frames_finish(struct bc_viewer_frames *f);
/*
 * Applies FRAME m (not a snapshot). A full-size frame is decoded and its
 * rectangles copied into comp; when comp is stale and the frame does not
 * cover it, the last small image is first scaled up into comp, so that
 * no pixel older than the newest interactive frame shows. A frame smaller
 * than the view (a refinement level above 0, or a downscaled level-0 frame)
 * replaces the small image. *up says what to upload. Returns 0 or the
 * error of bc_client_image_apply (the picture is then left as it was, as
 * far as possible) or BC_ENOMEM, with the reason in ei.
 */
int bc_viewer_frames_apply(struct bc_viewer_frames *f, const struct bc_msg *m,
                           struct bc_viewer_update *up, struct bc_errinfo *ei);
/* Copies the w x h rectangle at (x, y) of an RGBA image `stride` pixels
 * wide into dst, rows packed: for glTexSubImage2D, which GLES 2 cannot
 * give a row length. */
void bc_viewer_copy_rect(const uint8_t *src, uint32_t stride, uint32_t x,
                         uint32_t y, uint32_t w, uint32_t h, uint8_t *dst);
/* Scales src (sw x sh RGBA) to dst (dw x dh RGBA) bilinearly, sampling at
 * pixel centres as GL's linear filter does. */
void bc_viewer_upscale(const uint8_t *src, uint32_t sw, uint32_t sh,
                       uint8_t *dst, uint32_t dw, uint32_t dh);
/* The same for the top-left su x sv fraction of src (0 < su, sv <= 1)
 * spread over dst: a level image, whose pixels are blocks anchored at the
 * view's top-left. */
void bc_viewer_upscale_part(const uint8_t *src, uint32_t sw, uint32_t sh,
                            float su, float sv, uint8_t *dst, uint32_t dw,
                            uint32_t dh);
/* The overlay's words for a frame's flags: "refining (level N)" while it is
 * not final (a level above 0), "refining (level N, cut by budget)" for
 * INCOMPLETE, else "". Returns out. */
const char *bc_viewer_refining_text(uint16_t flags, char *out, size_t n);

/* ---- shot.c -------------------------------------------------------------- */

/* A picture that is not finished (a level above 0, or INCOMPLETE) is taken
 * as all the daemon will send once no frame has come for this long
 * (ms) while nothing we sent waits for an answer, or for this many times
 * the longest gap between its frames if that is longer: the daemon sends
 * a refinement step at least every --frame-budget ms (2000 by default),
 * which the client is not told. */
#define BC_VIEWER_SHOT_QUIET_MS 5000.0
#define BC_VIEWER_SHOT_QUIET_GAPS 3.0
/* Default of --screenshot-wait (seconds per picture): a crawling scene in
 * a big window may refine for minutes; a screenshot should not. */
#define BC_VIEWER_SHOT_WAIT_S 60u

enum bc_viewer_shot_state {
	BC_VIEWER_SHOT_WAITING = 0,
	BC_VIEWER_SHOT_FINISHED, /* level 0 without INCOMPLETE */
	BC_VIEWER_SHOT_SETTLED,  /* not finished; frames stopped coming */
	BC_VIEWER_SHOT_TIMEOUT,  /* the wait for this picture ran out */
	BC_VIEWER_SHOT_COUNT
};

/* The frames of the picture a screenshot waits for. */
struct bc_viewer_shot {
	double start;   /* when the wait began (ms) */
	double last_at; /* the last frame's arrival */
	double max_gap; /* longest wait for a frame, from start on */
	uint64_t nframes;
	uint16_t flags; /* the last frame's (LEVEL, INCOMPLETE) */
};

/* Starts waiting for a new picture at now (the VIEW or a camera turn). */
void bc_viewer_shot_start(struct bc_viewer_shot *s, double now);
/* A frame with flags arrived at now. */
void bc_viewer_shot_frame(struct bc_viewer_shot *s, uint16_t flags, double now);
/* Whether the last frame left nothing to refine. */
bool bc_viewer_shot_finished(const struct bc_viewer_shot *s);
/* How long frames must stop before an unfinished picture counts as
 * settled: BC_VIEWER_SHOT_QUIET_MS or BC_VIEWER_SHOT_QUIET_GAPS times the
 * longest gap, whichever is longer. */
double bc_viewer_shot_quiet_ms(const struct bc_viewer_shot *s);
/* Where the wait stands at now: pending_since is when the oldest request
 * of ours without an answer was sent (0: none; bc_viewer_pending_since),
 * which keeps a quiet daemon from counting as settled; wait_ms bounds the
 * wait. While WAITING, *due_ms is the time until the answer may change,
 * else -1. */
enum bc_viewer_shot_state bc_viewer_shot_check(const struct bc_viewer_shot *s,
                                               double now, double pending_since,
                                               double wait_ms, double *due_ms);
/* What the picture is, for stderr: "level 1, INCOMPLETE: no better frame
 * for 5.0 s (the daemon stopped refining it)", "level 2: still refining
 * after 60 s", "no frame within 60 s". Returns out. */
const char *bc_viewer_shot_text(const struct bc_viewer_shot *s,
                                enum bc_viewer_shot_state st, double wait_ms,
                                char *out, size_t n);
/* The VIEW for a framebuffer of fb_w x fb_h pixels when the daemon renders
 * at most max a side (WELCOME max_dim, or less): the framebuffer itself,
 * or, when a side is over max, the size with the longer side max and the
 * same aspect ratio. Returns whether it was capped. */
bool bc_viewer_view_size(uint32_t fb_w, uint32_t fb_h, uint32_t max,
                         uint32_t *w, uint32_t *h);

/* ---- roster.c ------------------------------------------------------------ */

/* Who is in the session (the library's roster, bc_client_members) and who
 * changed the scene last, for the overlay. */
struct bc_viewer_roster {
	/* The members, borrowed from the client: valid until it next
	 * receives, so bc_viewer_roster_update() follows every receive. */
	const struct bc_client_member *m;
	size_t n;
	uint32_t self; /* our member id */
	/* The last edit or load: its author (0: none yet), the author's name
	 * then (kept when the author leaves) and its order. */
	uint32_t last_author;
	char last_name[BC_PROTO_MAX_NAME + 1];
	uint64_t last_order;
	/* Presentation, from the last PRESENTER: who presents (0: nobody)
	 * and whether we follow. */
	uint32_t presenter;
	bool following;
};

/* Takes the member list and our member id from c (the last SESSION_INFO it
 * received; none before joining). */
void bc_viewer_roster_update(struct bc_viewer_roster *r,
                             const struct bc_client *c);
/* Notes an edit or load by member author with order. */
void bc_viewer_roster_edit(struct bc_viewer_roster *r, uint32_t author,
                           uint64_t order);
/* The overlay's lines: `3 members: alice (editor, presenting), bob
 * (viewer), you (editor)`, then, while someone presents, `following
 * alice (F stops)` or `alice presents (F follows)` (`you present
 * (Shift-F stops)`), then, after an edit, `last edit: alice, order 12`,
 * each on a line of its own; cut to fit n bytes with "...". A member
 * without a name shows as "member ID". Returns out. */
const char *bc_viewer_roster_text(const struct bc_viewer_roster *r, char *out,
                                  size_t n);

/* The notice for an EDIT_APPLIED flagged UNDO or REDO: `bob undid alice's
 * edit 12` (`redid` for REDO): the sender by its member name ("member ID"
 * without one), the edit taken back by its order
 * and its author's name as the server gives it ("an unnamed member's" when
 * empty). Returns out. */
const char *bc_viewer_undo_text(const struct bc_viewer_roster *r,
                                const struct bc_msg *m, char *out, size_t n);

/* ---- font.c -------------------------------------------------------------- */

#define BC_VIEWER_GLYPH_W 5
#define BC_VIEWER_GLYPH_H 7
/* Advance per character and per line, in font pixels. */
#define BC_VIEWER_GLYPH_ADVANCE 6
#define BC_VIEWER_LINE_ADVANCE 9

/* Whether font pixel (col, row) of character ch is lit; characters outside
 * printable ASCII draw as '?', lower case as upper case. */
bool bc_viewer_glyph_bit(char ch, int col, int row);
/*
 * Appends two triangles (12 floats: x, y pairs) per lit font pixel of text,
 * drawn at (x, y) (top left, window pixels) with font pixels scale window
 * pixels wide, into out, which holds cap floats. Returns the number of
 * floats the whole text needs; when that is more than cap only the first
 * cap floats are written (call again with enough room).
 */
size_t bc_viewer_text_tris(const char *text, float x, float y, float scale,
                           float *out, size_t cap);
/* Width in window pixels of the longest line of text at scale. */
float bc_viewer_text_width(const char *text, float scale);

#endif
