/*
 * The state of one blobcast-view window, shared by its files: main.c
 * (options, start-up, the loop, drawing, joining another session), net.c
 * (messages from the server, sending camera, view and edits), input.c
 * (mouse and keyboard) and modelling.c (adding, deleting, duplicating,
 * wrapping, regrouping).
 * Everything runs on the main thread except the socket watcher of main.c,
 * which only polls the socket and wakes the loop, the mesher of save.c,
 * which meshes a copy of the scene of its own, and the reader of load.c,
 * which reads a scene file (both threads of worker.c).
 */
#ifndef BLOBCAST_VIEWER_APP_H
#define BLOBCAST_VIEWER_APP_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include <pthread.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "blobcast/client.h"
#include "blobcast/mesh.h"
#include "viewer.h"
#include "viewer_gl.h"

/* Mouse motion, in window pixels, before a press counts as a drag rather
 * than a click. */
#define BC_VIEWER_CLICK_SLOP 3.0
/* Interacting CAMERA messages are sent at most this often (ms): a 60 Hz
 * display never shows more. */
#define BC_VIEWER_CAMERA_EVERY_MS 15.0
/* A wheel gesture ends this long (ms) after its last notch; its final,
 * non-interacting message goes then. */
#define BC_VIEWER_WHEEL_END_MS 250.0
/* Resizing sends many sizes in a row; the VIEW goes this long (ms) after
 * the last. */
#define BC_VIEWER_RESIZE_MS 120.0
/* Status messages stay on the overlay this long (ms). */
#define BC_VIEWER_STATUS_MS 6000.0
/* The window title and overlay numbers refresh this often (ms). */
#define BC_VIEWER_STATS_EVERY_MS 500.0
/* Messages handled per loop turn before input and drawing get their turn:
 * a burst of frames must not freeze the window. */
#define BC_VIEWER_MSGS_PER_TURN 64
/* One attempt waits at most this long (ms) for the daemon's answers; the
 * window does not redraw meanwhile, so keep it short. */
#define BC_VIEWER_RETRY_TIMEOUT_MS 2000
/* Exit status of --screenshot when the picture written is not finished
 * (a level above 0 or INCOMPLETE: the daemon stopped refining it, or the
 * --screenshot-wait ran out); 1 and 2 are failures and bad options. */
#define BC_VIEWER_EXIT_UNFINISHED 5
/* Bytes of the text of the panel along the bottom (the add palette or the
 * keys). */
#define BC_VIEWER_PANEL_TEXT 2048
/* Floats of the triangles of one panel's text: a lit font pixel takes 12
 * (two triangles), a character about 15 lit pixels, so 256 Ki floats draw
 * some 1400 characters, more than the key list (about 600) or the
 * overlay's lines hold. */
#define BC_VIEWER_TEXT_FLOATS (256u * 1024u)

struct bc_viewer_opts {
	const char *server, *session, *name, *token;
	const char *ca; /* --ca: TLS trust anchors; NULL: the system's */
	bool insecure;  /* --insecure: no TLS certificate checks */
	enum bc_proto_role role;
	uint32_t width, height; /* window size asked for */
	/* Frames: JPEG, PNG or H.264 (a video stream decoded here). */
	enum bc_proto_encoding encoding;
	bool exact_still; /* --exact-still: the still in PNG */
	uint8_t quality, downscale;
	bool gles, overlay, verbose;
	const char *screenshot; /* write the window here ... */
	uint32_t frames;        /* ... once this many frames were shown */
	float turn_deg;         /* camera turn between those frames */
	const char *dump_frame; /* with --screenshot: the picture received */
	uint32_t shot_wait_s;   /* --screenshot-wait: seconds per picture */
	const char *snapshot_dir;
	/* --snapshot-size: S asks for a picture of this size in tiles
	 * (PROTOCOL.md 7.17), up to 8192 x 8192; 0: the window's size. */
	uint32_t snap_width, snap_height;
};

enum bc_viewer_drag {
	BC_VIEWER_DRAG_NONE = 0,
	BC_VIEWER_DRAG_PENDING, /* pressed; waiting for the PICK answer */
	BC_VIEWER_DRAG_ORBIT,
	BC_VIEWER_DRAG_PAN,
	BC_VIEWER_DRAG_MOVE, /* moving a primitive in the view plane */
	BC_VIEWER_DRAG_COUNT
};

enum bc_viewer_wheel {
	BC_VIEWER_WHEEL_NONE = 0,
	BC_VIEWER_WHEEL_SIZE,  /* Shift: the primitive's size parameter */
	BC_VIEWER_WHEEL_BLEND, /* Ctrl: the parent operator's blend */
	BC_VIEWER_WHEEL_UNARY, /* Alt: the unary node above's parameter */
	BC_VIEWER_WHEEL_COUNT
};

/* A thread of the window's own for one long piece of work (worker.c):
 * the mesher's, the reader's. */
#define BC_VIEWER_WORKER_SAY_MS 250.0 /* progress shown at most this often */
struct bc_viewer_worker {
	pthread_t thread;
	bool busy;            /* started and not joined yet */
	atomic_bool done;     /* run has returned */
	double started, said; /* when it started; progress last shown */
	void (*run)(void *arg);
	void *arg;
};
/* Starts run(arg) on a thread of its own: 0, or -1 (no thread). */
int bc_viewer_worker_start(struct bc_viewer_worker *w, void (*run)(void *arg),
                           void *arg);
/* True when the work has ended and its thread was joined now. */
bool bc_viewer_worker_reap(struct bc_viewer_worker *w);
/* Joins a started thread, waiting for its work (the window is closing). */
void bc_viewer_worker_join(struct bc_viewer_worker *w);
/* Whether progress is due again at now (then marked said). */
bool bc_viewer_worker_say_due(struct bc_viewer_worker *w, double now);
/* Milliseconds from now until progress is due again. */
double bc_viewer_worker_next(const struct bc_viewer_worker *w, double now);

/* Ctrl+M and Ctrl+Shift+M (save.c): the session's solid as a mesh file,
 * made on a thread of its own from a copy of the mirror, so that the
 * window goes on drawing; one at a time. */
struct bc_viewer_mesher {
	struct bc_viewer_worker w;
	atomic_uint permille; /* how far it is */
	/* The thread's alone until done: its copy of the scene (bare), the
	 * file, and what became of it. */
	struct bc_tree *tree;
	enum bc_mesh_format format;
	char path[4096];
	int rc;
	struct bc_errinfo ei;
	uint32_t nverts, ntris;
};

/* Ctrl+O's reading of a scene file (load.c): a big JSON scene takes
 * seconds to read and check (a million spheres: about 5 s), so a thread of
 * its own does it while the window goes on; the loop sends what it read.
 * One at a time. */
struct bc_viewer_reader {
	struct bc_viewer_worker w;
	bool ready;     /* joined, read: sent in the loop's next turn */
	bool cancelled; /* Escape: what it reads is dropped, not sent */
	/* The thread's alone until done: the file, and what it read. */
	char path[1024];
	uint8_t *bytes; /* the scene's encoding, as SCENE_LOAD sends it */
	size_t len;
	uint32_t nodes;
	bool has_camera;
	int rc;
	struct bc_errinfo ei;
};

struct bc_viewer_app {
	struct bc_viewer_opts o;
	GLFWwindow *win;
	struct bc_viewer_gl gl;
	bool gl_ready;
	struct bc_client *c;
	struct bc_viewer_frames frames;
	struct bc_viewer_meter meter;
	struct bc_viewer_edits edits;
	struct bc_viewer_roster roster;

	/* Our camera; the scene's, for R. */
	struct bc_camera cam, scene_cam;
	bool cam_dirty, cam_interacting;
	double cam_sent_at, cam_final_at; /* final_at: end of a wheel zoom */
	/* The last CAMERA sent that no frame reflects yet (0: none), and the
	 * VIEW sent that no frame answered yet (0: none): "render pending". */
	uint32_t cam_seq, view_seq;
	double cam_seq_at, view_sent_at;

	/* The VIEW sent (0 before), and a resize waiting to be sent. */
	uint32_t view_w, view_h;
	double view_due;
	/* The view was capped by the daemon's max_dim (said once). */
	bool view_capped_said;

	/* Mouse. */
	double mx, my; /* cursor, window pixels */
	struct {
		enum bc_viewer_drag mode;
		int button;
		double start_x, start_y, last_x, last_y;
		bool moved, released;
		uint32_t pick_seq;
		uint32_t node;
		float origin[3], z;
	} drag;
	struct {
		enum bc_viewer_wheel what;
		uint32_t sel; /* the selection the gesture began on */
		struct bc_viewer_edit edit;
		double end_at;
		/* Alt: the unary node's kind and the size its steps scale
		 * with (bc_viewer_unary_notch). */
		enum bc_op unary_kind;
		float extent;
	} wheel;
	/* The selection: a primitive picked, or a node above it (Up). Down
	 * walks back towards sel_leaf, the primitive picked last. */
	uint32_t selected, sel_leaf;
	/* M: the operator G moves the selection under (0: none). */
	uint32_t mark;
	/* The add palette (A, W). */
	struct bc_viewer_palette palette;
	/* The modelling EDIT on its way (0: none), and the node that becomes
	 * the selection once it is applied (0: none). */
	uint32_t model_seq, model_select;
	/* F2: the name being typed for node `node`; while open, the entry
	 * takes every key until Enter or Escape. text holds len bytes of
	 * UTF-8, NUL-terminated. */
	struct {
		bool open;
		uint32_t node;
		size_t len;
		char text[BC_TREE_NAME_MAX + 1];
	} rename;

	/* Ctrl+O (load.c): the path of a scene file to load, being typed;
	 * while open, the entry takes every key until Enter or Escape. path
	 * holds len bytes of UTF-8, NUL-terminated. */
	struct {
		bool open;
		size_t len;
		char path[1024];
		/* The file being read (Enter), on a thread of its own. */
		struct bc_viewer_reader reader;
	} load;

	/* Frames. */
	uint64_t nframes; /* shown, snapshots excluded */
	/* FRAME_ACK (when the server granted ACKS): the newest frame_no
	 * received, and the newest acknowledged once drawn. */
	uint32_t frame_got, frame_acked;
	/* An H.264 frame did not decode and the VIEW went again: frames that
	 * fail until its KEY frame are expected, not reported. */
	bool awaiting_key;
	/* Finished pictures among them: frames that left nothing to refine
	 * (level 0 without INCOMPLETE). --frames counts these. */
	uint64_t npictures;
	uint64_t settle_order; /* newest order shown since the last draw */
	bool settle;
	struct {
		uint32_t frame_no, width, height, image_width, image_height;
		uint32_t nrects;
		uint64_t order;
		uint16_t flags;
		enum bc_proto_encoding encoding;
	} last;
	bool redraw;
	bool turn_pending; /* --frames: a camera turn asked for a frame */
	/* --screenshot: the frames of the picture waited for; whether a
	 * picture was counted and the next turn not made yet; whether the
	 * last one counted was settled unfinished (exit status
	 * BC_VIEWER_EXIT_UNFINISHED). */
	struct bc_viewer_shot shot;
	bool shot_ready, shot_unfinished;

	/* The last UNDO or REDO sent (Ctrl-Z, Ctrl-Shift-Z, Ctrl-Y) that the
	 * server has not answered yet (0: none), and which of the two. */
	uint32_t undo_seq;
	/* Shift+R: the SESSION_CAMERA on its way (its seq; 0: none). */
	uint32_t session_cam_seq;
	bool undo_redo;

	/* F: follow whoever presents (kept across reconnects; moving our
	 * camera turns it off). */
	bool follow_wanted;

	/* S (lossless snapshot) and P (window screenshot). */
	uint32_t snapshot_seq;
	/* S with --snapshot-size: the picture whose tiles are arriving. */
	struct bc_client_big *big;
	struct bc_client_image big_img;
	bool screenshot_now;
	unsigned shots;
	/* Ctrl+M: the mesh being made. */
	struct bc_viewer_mesher mesher;

	/* H: the keys listed along the bottom of the overlay. */
	bool help;
	/* L: the daemon's sessions, one to join; and the name of the session
	 * joined from it, which o.session then points to. */
	struct bc_viewer_sessions sessions;
	char session_name[BC_PROTO_MAX_NAME + 1];
	/* I: the session's changes that undo and redo can take. */
	struct bc_viewer_history history;

	char status[200];
	double status_at, stats_at;
	float *text;

	/* The socket watcher. */
	int wake[2];
	pthread_t watcher;
	bool watching;
	atomic_int fired; /* it woke the loop and waits to be re-armed */

	/* Joined as a viewer because the token grants viewing only (no
	 * --role given): the overlay says why edits are off. */
	bool view_only_token;

	bool offline; /* the connection failed; the status says why */
	bool gave_up; /* ... for a reason a retry would meet again */
	/* When to try again, and the failed attempts since the connection
	 * was lost: the library's delays (BC_CLIENT_BACKOFF_FIRST_MS doubling
	 * up to BC_CLIENT_BACKOFF_LONGEST_MS). */
	struct bc_client_backoff retry;
	bool quit;
	int exit_code;
};

/* Milliseconds on base's monotonic clock (bc_clock_ms), the viewer's one
 * time base for deadlines and rates. */
double bc_viewer_now_ms(void);
/* Shows a sentence on the overlay (and on stderr when verbose). */
void bc_viewer_status(struct bc_viewer_app *a, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Whether this window may edit (it joined as an editor). When not, says
 * on the overlay that `what` (a sentence's subject: "undo", "adding a
 * shape") is off in a view-only window, and why. */
bool bc_viewer_may_edit(struct bc_viewer_app *a, const char *what);
/* The overlay's words for a view-only window, "" for an editor. */
const char *bc_viewer_view_only_text(const struct bc_viewer_app *a);

/* modelling.c: each action is one EDIT (blobcast/model.h), refused on the
 * overlay with the library's reason before anything is sent when it cannot
 * be done, and never sent by a view-only window. */
/* Enter in the palette: a shape or operator is added under the selection's
 * operator at the camera's target and selected; a unary kind wraps the
 * selection. */
void bc_viewer_model_choose(struct bc_viewer_app *a,
                            const struct bc_viewer_pal_entry *e);
/* Delete, X, Backspace: removes the selection with its subtree. */
void bc_viewer_model_delete(struct bc_viewer_app *a);
/* D: a copy of the selection beside it, selected once applied. */
void bc_viewer_model_duplicate(struct bc_viewer_app *a);
/* M: marks the selected operator as the regroup parent (again, or with
 * nothing selected: unmarks). */
void bc_viewer_model_mark(struct bc_viewer_app *a);
/* G: moves the selection under the marked operator. */
void bc_viewer_model_regroup(struct bc_viewer_app *a);
/* Alt+Up, Alt+Down: the selection (with the unary nodes wrapping it) one
 * place earlier (up) or later among its siblings, one MOVE under the same
 * operator, as the page's; at either end nothing is sent and the status
 * line says so. */
void bc_viewer_model_reorder(struct bc_viewer_app *a, bool up);
/* K (Shift: sharp <-> smooth): the selected operator's next kind. */
void bc_viewer_model_op_kind(struct bc_viewer_app *a, bool smooth);
/* F2: opens the name entry on the selection, holding its name. */
void bc_viewer_model_rename_open(struct bc_viewer_app *a);
/* A character typed into the open entry (a Unicode code point); control
 * characters and what would pass BC_TREE_NAME_MAX bytes are refused. */
void bc_viewer_model_rename_char(struct bc_viewer_app *a, uint32_t cp);
/* Backspace in the entry: takes its last character off. */
void bc_viewer_model_rename_back(struct bc_viewer_app *a);
/* Enter in the entry: names the node (one NAME; empty: no name). */
void bc_viewer_model_rename_send(struct bc_viewer_app *a);
/* The lower panel's text while the entry is open. */
void bc_viewer_model_rename_text(const struct bc_viewer_app *a, char *out,
                                 size_t n);
/* Node id's name for the overlay, in double quotes after a space
 * (' "wheel"'), every character the overlay's font lacks as '?'; "" when
 * it has none. Returns out. */
const char *bc_viewer_name_text(const struct bc_tree *t, uint32_t id, char *out,
                                size_t n);
/* Our EDIT seq was applied, or refused (ERROR): the action is over. */
void bc_viewer_model_applied(struct bc_viewer_app *a, uint32_t seq);
void bc_viewer_model_refused(struct bc_viewer_app *a, uint32_t seq);
/* The overlay's words for node id: "#4 sphere", "#1 smooth_union blend
 * 0.3, 3 children", "#5 twist rate 0.5". Returns out. */
const char *bc_viewer_node_text(const struct bc_tree *t, uint32_t id, char *out,
                                size_t n);

/* main.c: joins session `name` over a new connection (the window's
 * address, token and role) and, once joined, leaves the one it is in
 * for it, starting afresh as a reconnect does; when the join fails the
 * window stays where it is and the overlay says why. */
void bc_viewer_switch_session(struct bc_viewer_app *a, const char *name);

/* net.c */
/* L and F5: asks the daemon for its sessions (SESSION_LIST) and, when it
 * granted MEMORY, its scene memory (GET_STATS); the answers fill
 * a->sessions as they come (bc_viewer_pump). */
void bc_viewer_sessions_ask(struct bc_viewer_app *a);
/* Handles messages already received or readable, at most
 * BC_VIEWER_MSGS_PER_TURN. Returns 1 when more may be waiting, 0 when
 * drained, or the connection's negative error (the reason is shown). */
int bc_viewer_pump(struct bc_viewer_app *a);
/* Sends what is due: a VIEW after a resize, the camera, queued edits, the
 * end of a wheel gesture. Returns the ms until something else falls due
 * (negative: nothing scheduled). */
double bc_viewer_send_due(struct bc_viewer_app *a, double now);
/* Sends VIEW for the framebuffer's current size (bc_viewer_view_size
 * under the daemon's max_dim and the GL texture limit). */
int bc_viewer_send_view(struct bc_viewer_app *a);
/* The HELLO encodings for the options: the image ones, with H.264 when
 * --encoding h264 or --exact-still needs it. */
uint8_t bc_viewer_encodings(const struct bc_viewer_opts *o);
/* After the window was drawn: acknowledges the frames received so far
 * (FRAME_ACK) when the server granted ACKS. */
void bc_viewer_frame_drawn(struct bc_viewer_app *a);
/* Whether the framebuffer now asks for another VIEW than the last one
 * sent (a resize or a content-scale change). */
bool bc_viewer_view_changed(struct bc_viewer_app *a);
/* Marks the camera changed; interacting false sends it at once. */
void bc_viewer_camera_changed(struct bc_viewer_app *a, bool interacting);
/* Queues an edit and sends it when the queue allows. */
void bc_viewer_edit(struct bc_viewer_app *a, const struct bc_viewer_edit *e);
/* Sends PICK for window pixel (x, y); returns its seq or 0. */
uint32_t bc_viewer_pick(struct bc_viewer_app *a, double x, double y);
/* Sends UNDO (redo false) or REDO without waiting for the answer: the
 * EDIT_APPLIED every member gets, or an ERROR whose words the status line
 * shows ("nothing to undo: no change of yours is left"). Of this
 * window's own changes (its client name's, PROTOCOL.md 7.20), or with any
 * the session's newest, whoever made it (scope SESSION: the session's
 * owner or the presenter). A daemon without per-person undo (no
 * HISTORY) takes the session's newest either way, and any is not sent. */
void bc_viewer_undo(struct bc_viewer_app *a, bool redo, bool any);
/* Shift+R: this window's camera becomes the session's (SESSION_CAMERA,
 * editors; not waiting: SESSION_CAMERA_SET tells every member, and the
 * status line says who set it). */
void bc_viewer_set_session_camera(struct bc_viewer_app *a);
/* F: follow the presenter, or stop following (FOLLOW, not waiting). */
void bc_viewer_follow_toggle(struct bc_viewer_app *a);
/* Shift-F: present, or stop presenting (PRESENT, not waiting). */
void bc_viewer_present_toggle(struct bc_viewer_app *a);
/* Sends SNAPSHOT (PNG) unless one is on its way. */
void bc_viewer_request_snapshot(struct bc_viewer_app *a);
/* Ends a picture in tiles that is on its way (S with --snapshot-size),
 * saying why on the status line. */
void bc_viewer_picture_drop(struct bc_viewer_app *a, const char *why);
/* When the oldest request of ours that no frame answers yet was sent (ms),
 * 0 when none: a VIEW before its first frame, a CAMERA newer than the last
 * frame's camera_seq, an EDIT not applied or applied but not shown. */
double bc_viewer_pending_since(const struct bc_viewer_app *a);

/* save.c: Ctrl+S (JSON) and Ctrl+Shift+S (binary) save the mirror's scene
 * in the snapshot directory, saying where on the status line. */
void bc_viewer_save_scene(struct bc_viewer_app *a, bool binary);
/* Starts meshing the session's solid (the scene as the mirror holds it,
 * `blobcast mesh`'s defaults) into blobcast-SESSION-ORDER.glb, or .obj,
 * in the snapshot directory, on a thread; the status line follows it. */
void bc_viewer_save_mesh(struct bc_viewer_app *a, bool obj);
/* The mesher's turn of the loop: when it has finished, joins it and says
 * what it wrote; while it runs, shows how far it is. Returns the ms until
 * it wants the next turn, -1 when none runs. */
double bc_viewer_mesh_poll(struct bc_viewer_app *a, double now);
/* Waits for a mesh being made (the window is closing). */
void bc_viewer_mesh_wait(struct bc_viewer_app *a);
/* Writes text into out as the overlay can draw it: printable ASCII as it
 * is, every other character (a whole UTF-8 sequence) as one '?'
 * (modelling.c). */
void bc_viewer_drawable(const char *text, char *out, size_t n);
/* Ctrl+O (load.c): opens the entry for a scene file's path (editors). */
void bc_viewer_load_open(struct bc_viewer_app *a);
/* A character typed into it (a Unicode code point, kept as UTF-8). */
void bc_viewer_load_char(struct bc_viewer_app *a, uint32_t cp);
/* Backspace: its last character off. */
void bc_viewer_load_back(struct bc_viewer_app *a);
/* Enter: starts reading the file (JSON or binary, as `blobcast load`) on
 * the reader's thread; bc_viewer_load_poll sends it. */
void bc_viewer_load_send(struct bc_viewer_app *a);
/* Escape: closes the entry; a file being read is dropped when read. */
void bc_viewer_load_cancel(struct bc_viewer_app *a);
/* The reader's turn of the loop: progress on the status line; once the
 * file is read, loads it into the session, waiting for the daemon's
 * answer (a file that did not read keeps the entry open, saying why).
 * Returns the milliseconds until it wants its next turn, or -1. */
double bc_viewer_load_poll(struct bc_viewer_app *a, double now);
/* Waits for a file being read (the window is closing). */
void bc_viewer_load_wait(struct bc_viewer_app *a);
/* The entry's text for the lower panel. */
void bc_viewer_load_text(const struct bc_viewer_app *a, char *out, size_t n);
/* The session's scene was replaced (anyone's load, or this window's,
 * whose SCENE_STATE the library's wait took in): the camera follows a
 * scene that carries one, the selection forgets nodes that went, and the
 * member line names author (0: none) at order (net.c). */
void bc_viewer_scene_loaded(struct bc_viewer_app *a, bool has_camera,
                            uint32_t author, uint64_t order);

/* Sends HISTORY_GET for the history panel (not waiting: the answer fills
 * it), or says on the status line why not (no connection, a daemon
 * without per-person undo and history). */
void bc_viewer_history_ask(struct bc_viewer_app *a);
/* The history panel's turn of the loop: while it is open, asks again
 * when the session's order moved since its answer, at most once a
 * second. Returns the ms until it wants the next turn, -1 when none. */
double bc_viewer_history_poll(struct bc_viewer_app *a, double now);

/* input.c */
void bc_viewer_input_install(struct bc_viewer_app *a);
/* Applies mouse motion since the last turn (at most one camera or edit
 * message per turn however many events arrived). */
void bc_viewer_drag_step(struct bc_viewer_app *a, bool final);
/* The PICK answer for a pending press arrived (node 0: nothing hit). */
void bc_viewer_pick_answer(struct bc_viewer_app *a, uint32_t seq, uint32_t node,
                           const float position[3]);
/* The text of the panel along the bottom of the window: the add palette
 * while it is open, else the keys (H).
 * Returns false when there is none to show. */
bool bc_viewer_lower_panel(struct bc_viewer_app *a, char *out, size_t n);
/* Window pixels to view pixels. */
void bc_viewer_to_view(struct bc_viewer_app *a, double x, double y, float *vx,
                       float *vy);

#endif
