/*
 * `blobcast load|edit|camera|present|follow|snapshot|watch|bench-latency|
 * nodes|scene|...`: the command-line client of blobcastd. Its commands
 * share one option table (blobcast/args.h): every value is checked, an
 * option a command does not take is refused as not applying and left out
 * of that command's help. It also owns their output formats and the
 * measurements of watch and bench-latency. All protocol work goes through
 * libblobcast (blobcast/client.h); image files through bc_image (OpenImageIO).
 *
 * Exit status (cli.h, docs/client.md): 0 success, 1 the server refused
 * (its ERROR text is printed), 2 usage error, 3 the network (no
 * connection, TLS, a timeout, a closed connection, not a blobcastd), 4
 * authentication; every failure also says what to do.
 */
#include "cmd_client.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/client.h"
#include "blobcast/clock.h"
#include "blobcast/image.h"
#include "blobcast/num.h"
#include "blobcast/scene.h"
#include "cli.h"
#include "cmd_inspect.h"

/* A failure that is neither the server's answer nor the network's (out of
 * memory, a file that cannot be written, too few frames): status 1. */
#define EXIT_FAIL BC_CLI_EXIT_REFUSED
#define EXIT_USAGE BC_CLI_EXIT_USAGE

/* Positional arguments a subcommand may take: edit's node id and one
 * key=value per field is the most. */
#define MAX_POSITIONAL (1 + BC_CLIENT_MAX_EDIT_ARGS)
/* bench-latency: edits per run. A million at ~10 ms each is hours: more is
 * a typing mistake. */
#define MAX_BENCH_EDITS 1000000u
/* How far bench-latency moves the primitive, in world units: visible in
 * the picture (so the frame has damage to send) yet small. */
#define BENCH_STEP 0.05f
/* watch: the client's poll slice, so that Ctrl-C is noticed promptly. */
#define WATCH_SLICE_MS 200
/* watch: edit orders whose arrival time is remembered for the latency of
 * the frame that shows them (frames lag edits by a few at most). */
#define WATCH_ORDERS 256u
/* watch: the first and the longest delay between attempts to reconnect. A
 * restarting daemon is back in well under a second; a longer outage is
 * tried every few seconds, which costs the server nothing noticeable. */
#define WATCH_BACKOFF_MIN_MS 250
#define WATCH_BACKOFF_MAX_MS 4000

/* Options; each subcommand accepts the common ones (need 0 in the table)
 * and those in its mask. */
enum {
	O_SESSION = 1u << 0,
	O_SIZE = 1u << 1,
	O_OUT = 1u << 2,
	O_DEPTH = 1u << 3,
	O_EYE = 1u << 4,
	O_TARGET = 1u << 5,
	O_UP = 1u << 6,
	O_FOV = 1u << 7,
	O_FRAMES = 1u << 8,
	O_EDITS = 1u << 9,
	O_NODE = 1u << 10,
	O_ENCODING = 1u << 11,
	O_INTERACTING = 1u << 12,
	O_DOWNSCALE = 1u << 13,
	O_IDS = 1u << 14,
	O_JSON = 1u << 15,
	O_FOR = 1u << 16,
};
#define O_CAMERA (O_EYE | O_TARGET | O_UP | O_FOV)

struct args {
	const char *cmd;
	const char *server, *token, *name, *session, *out, *depth, *ids;
	const char *ca; /* --ca: TLS trust anchors */
	bool insecure;  /* --insecure: no TLS certificate checks */
	int timeout_ms;
	uint16_t width, height;
	bool has_size;
	struct bc_camera cam;
	bool has_eye, has_target, has_up, has_fov;
	uint64_t frames;
	uint64_t for_s; /* present --for SECONDS; 0: until stopped */
	uint32_t edits, node;
	enum bc_proto_encoding encoding;
	bool interacting, json;
	uint8_t downscale;
	const char *pos[MAX_POSITIONAL];
	int npos;
};

/* A command's own wording of a shared option ("--out" is an image for
 * snapshot, a scene file for scene); NULL arg keeps the table's. */
struct opt_text {
	const char *name, *arg, *help;
};

struct cmd {
	const char *name;
	unsigned opts;
	int min_pos, max_pos;
	const char *synopsis;
	const char *summary;
	const char *help;             /* what the subcommand does */
	const struct opt_text *texts; /* ends with a NULL name; may be NULL */
	int (*run)(struct args *a);
};

/* ---- small helpers ----------------------------------------------------------
 */

/* The shared number rules (blobcast/num.h), with the protocol's bounds. */
static bool parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
	return bc_num_u64(s, lo, hi, out) == 0;
}

/* Prints a failure of the server or the connection (on c, NULL while
 * connecting) and what to do about it; returns its exit status
 * (bc_cli_exit_for). */
static int failed(const struct args *a, const struct bc_client *c,
                  const char *what, const struct bc_errinfo *ei)
{
	enum bc_cli_stage stage =
	    c ? BC_CLI_STAGE_SESSION : BC_CLI_STAGE_CONNECT;
	const char *hint = bc_cli_hint(ei->code, stage, ei->msg);
	fprintf(stderr, "blobcast %s: %s%s%s (%s)\n", a->cmd, what ? what : "",
	        what ? ": " : "", ei->msg[0] ? ei->msg : bc_strerror(ei->code),
	        bc_err_name(ei->code));
	if (hint) {
		fprintf(stderr, "blobcast %s: %s\n", a->cmd, hint);
	}
	return bc_cli_exit_for(ei->code, stage,
	                       c && bc_client_error(c, NULL) != 0);
}

/* The connection the options ask for: --server, --token (or their
 * environment variables), --name, --timeout, --ca, --insecure. */
static struct bc_client_opts connect_opts(const struct args *a)
{
	return (struct bc_client_opts){
	    .addr = a->server ? a->server : getenv("BLOBCAST_SERVER"),
	    .name = a->name ? a->name : "blobcast-cli",
	    .token = a->token ? a->token : getenv("BLOBCAST_TOKEN"),
	    .timeout_ms = a->timeout_ms,
	    .ca_file = a->ca,
	    .insecure = a->insecure};
}

static int connect_to(const struct args *a, struct bc_client **c)
{
	struct bc_errinfo ei = {0};
	struct bc_client_opts opts = connect_opts(a);
	if (bc_client_connect(c, &opts, &ei)) {
		return failed(a, NULL, NULL, &ei);
	}
	return 0;
}

/* Connects and enters the session; viewers unless the command edits. */
static int open_session(const struct args *a, enum bc_proto_role role,
                        enum bc_client_join_mode mode, struct bc_client **c)
{
	struct bc_errinfo ei = {0};
	int status = connect_to(a, c);
	if (status) {
		return status;
	}
	if (bc_client_join(*c, a->session, role, mode, &ei)) {
		char what[128];
		snprintf(what, sizeof(what), "session %s", a->session);
		return failed(a, *c, what, &ei);
	}
	return 0;
}

/* ---- load
 * --------------------------------------------------------------------- */

static int run_load(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	uint8_t *bytes = NULL;
	size_t len = 0;
	uint64_t order;
	int status = 0, rc;
	if (!t) {
		fprintf(stderr, "blobcast load: out of memory\n");
		return EXIT_FAIL;
	}
	/* The file is read before connecting: a bad file is the caller's
	 * mistake (status 2) and costs the server nothing. */
	if (bc_scene_load_json(a->pos[0], t, &cam, &ei)) {
		bc_cli_explain(stderr, "blobcast load", ei.msg);
		status = EXIT_USAGE;
		goto out;
	}
	if ((rc = bc_scene_encode(t, &cam, &bytes, &len))) {
		fprintf(stderr, "blobcast load: cannot encode %s: %s\n",
		        a->pos[0], bc_strerror(rc));
		status = EXIT_FAIL;
		goto out;
	}
	if ((status = open_session(a, BC_PROTO_ROLE_EDITOR, BC_CLIENT_JOIN_ANY,
	                           &c))) {
		goto out;
	}
	if (bc_client_load_scene(c, bytes, len, &order, &ei)) {
		status = failed(a, c, "scene not loaded", &ei);
		goto out;
	}
	printf("session %s: loaded %s (%u nodes), edit order %llu\n",
	       a->session, a->pos[0], bc_tree_node_count(t),
	       (unsigned long long)order);
out:
	bc_free(bytes);
	bc_tree_destroy(t);
	bc_client_destroy(c);
	return status;
}

/* ---- edit
 * ------------------------------------------------------------------------ */

static int run_edit(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	uint64_t id, order;
	uint32_t seq;
	int status;
	if (!parse_u64(a->pos[0], 1, UINT32_MAX, &id)) {
		fprintf(stderr,
		        "blobcast edit: \"%s\" is not a node id (1..%u)\n",
		        a->pos[0], UINT32_MAX);
		return EXIT_USAGE;
	}
	if ((status = open_session(a, BC_PROTO_ROLE_EDITOR,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (bc_client_edit_kv(c, (uint32_t)id, a->pos + 1,
	                      (size_t)(a->npos - 1), a->interacting, &seq,
	                      &ei)) {
		/* Bad key=value text is the user's mistake, not the server's;
		 * the connection failing is not. */
		if (bc_client_error(c, NULL)) {
			status = failed(a, c, NULL, &ei);
		} else {
			const char *hint =
			    bc_cli_hint(ei.code, BC_CLI_STAGE_SESSION, ei.msg);
			bc_cli_explain(stderr, "blobcast edit", ei.msg);
			if (hint) {
				fprintf(stderr, "blobcast edit: %s\n", hint);
			}
			status = EXIT_USAGE;
		}
		goto out;
	}
	if (bc_client_wait_applied(c, seq, &order, &ei)) {
		status = failed(a, c, NULL, &ei);
		goto out;
	}
	printf("node %llu: edit applied, edit order %llu\n",
	       (unsigned long long)id, (unsigned long long)order);
out:
	bc_client_destroy(c);
	return status;
}

/* ---- camera
 * -------------------------------------------------------------------------- */

/* Overrides the parts of cam that the options give. */
static void apply_camera_opts(const struct args *a, struct bc_camera *cam)
{
	if (a->has_eye) {
		memcpy(cam->eye, a->cam.eye, sizeof(cam->eye));
	}
	if (a->has_target) {
		memcpy(cam->target, a->cam.target, sizeof(cam->target));
	}
	if (a->has_up) {
		memcpy(cam->up, a->cam.up, sizeof(cam->up));
	}
	if (a->has_fov) {
		cam->fov_y_deg = a->cam.fov_y_deg;
	}
}

/* Sets cam to the session's camera (the default one when the scene has
 * none) changed by the options. Returns 0, or EXIT_USAGE after saying why
 * the result is not a camera. */
static int camera_from_opts(const struct args *a, const struct bc_client *c,
                            struct bc_camera *cam)
{
	struct bc_errinfo ei = {0};
	if (!bc_client_scene(c, cam)) {
		bc_camera_default(cam);
	}
	apply_camera_opts(a, cam);
	if (bc_camera_validate(cam, &ei)) {
		fprintf(stderr, "blobcast %s: %s\n", a->cmd, ei.msg);
		return EXIT_USAGE;
	}
	return 0;
}

/*
 * The server keeps a camera per connection (CAMERA changes only the
 * sender's view) and one per session: the scene's, which members start
 * with and which is saved with the scene. SESSION_CAMERA sets the latter
 * alone: the scene's nodes are not sent, so edits other members make at
 * the same moment stand.
 */
static int run_camera(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	uint64_t order;
	int status;
	if (!a->has_eye || !a->has_target) {
		fprintf(stderr, "blobcast camera: --eye and --target are "
		                "required (see blobcast camera --help)\n");
		return EXIT_USAGE;
	}
	if ((status = open_session(a, BC_PROTO_ROLE_EDITOR,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if ((status = camera_from_opts(a, c, &cam))) {
		goto out;
	}
	if (bc_client_session_camera(c, &cam, &order, &ei)) {
		status = failed(a, c, "camera not set", &ei);
		goto out;
	}
	printf("session %s: camera eye %g,%g,%g target %g,%g,%g up %g,%g,%g "
	       "fov %g, edit order %llu\n",
	       a->session, (double)cam.eye[0], (double)cam.eye[1],
	       (double)cam.eye[2], (double)cam.target[0], (double)cam.target[1],
	       (double)cam.target[2], (double)cam.up[0], (double)cam.up[1],
	       (double)cam.up[2], (double)cam.fov_y_deg,
	       (unsigned long long)order);
out:
	bc_client_destroy(c);
	return status;
}

/* ---- snapshot
 * ---------------------------------------------------------------------------
 */

static int run_snapshot(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	struct bc_camera cam;
	uint32_t seq;
	int status;
	unsigned planes = (a->depth ? BC_PROTO_PLANE_DEPTH : 0u) |
	                  (a->ids ? BC_PROTO_PLANE_IDS : 0u);
	if (!a->has_size || !a->out) {
		fprintf(stderr, "blobcast snapshot: --size and --out are "
		                "required (see blobcast snapshot --help)\n");
		return EXIT_USAGE;
	}
	if (a->depth && !bc_image_ext_supports(a->depth, BC_IMAGE_F32)) {
		fprintf(
		    stderr,
		    "blobcast snapshot: --depth \"%s\": depth needs a float "
		    "format: .exr, .tif or .pfm\n",
		    a->depth);
		return EXIT_USAGE;
	}
	if (a->ids && !bc_image_ext_supports(a->ids, BC_IMAGE_U32)) {
		fprintf(stderr,
		        "blobcast snapshot: --ids \"%s\": ids need a uint32 "
		        "format: .tif or .exr\n",
		        a->ids);
		return EXIT_USAGE;
	}
	if (!bc_image_ext_supports(a->out, BC_IMAGE_U8)) {
		fprintf(stderr,
		        "blobcast snapshot: \"%s\": no image format for this "
		        "extension (use .png, .tif, .exr, .jpg, ...)\n",
		        a->out);
		return EXIT_USAGE;
	}
	bc_client_image_init(&img);
	if ((status = open_session(a, BC_PROTO_ROLE_VIEWER,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (a->has_eye || a->has_target || a->has_up || a->has_fov) {
		bc_client_scene(c, &cam);
		apply_camera_opts(a, &cam);
		if (bc_camera_validate(&cam, &ei)) {
			fprintf(stderr, "blobcast snapshot: %s\n", ei.msg);
			status = EXIT_USAGE;
			goto out;
		}
		/* Before VIEW, so that the one stream frame VIEW causes is
		 * already from this camera. */
		if (bc_client_camera(c, &cam, false, &seq, &ei)) {
			status = failed(a, c, NULL, &ei);
			goto out;
		}
	}
	/* The VIEW gives the size; its stream frame is a cheap JPEG we skip.
	 * The snapshot itself is lossless. */
	if (bc_client_view(c,
	                   &(struct bc_msg_view){.width = a->width,
	                                         .height = a->height,
	                                         .encoding = BC_PROTO_ENC_JPEG,
	                                         .quality_interactive = 30,
	                                         .quality_still = 30},
	                   &seq, &ei) ||
	    bc_client_snapshot_planes(c, BC_PROTO_ENC_PNG, planes, &img, &ei)) {
		status = failed(a, c, "snapshot", &ei);
		goto out;
	}
	if (img.flags & BC_PROTO_FLAG_INCOMPLETE) {
		fprintf(
		    stderr,
		    "blobcast snapshot: the server hit its frame time budget "
		    "and sent a partial picture; nothing written (a smaller "
		    "--size renders faster)\n");
		status = EXIT_FAIL;
		goto out;
	}
	if (!img.complete || img.width != a->width || img.height != a->height) {
		fprintf(stderr,
		        "blobcast snapshot: the server sent a %ux%u picture%s "
		        "for a %ux%u request\n",
		        img.width, img.height, img.complete ? "" : " in part",
		        a->width, a->height);
		status = EXIT_FAIL;
		goto out;
	}
	if (bc_image_write_rgba8(a->out, img.width, img.height, img.rgba,
	                         &ei) ||
	    (a->depth && bc_image_write_float(a->depth, img.width, img.height,
	                                      img.depth, &ei)) ||
	    (a->ids &&
	     bc_image_write_u32(a->ids, img.width, img.height, img.ids, &ei))) {
		fprintf(stderr, "blobcast snapshot: %s\n", ei.msg);
		status = EXIT_FAIL;
		goto out;
	}
	printf("wrote %s (%ux%u, frame %u, edit order %llu, %u bytes from "
	       "the server)\n",
	       a->out, img.width, img.height, img.frame_no,
	       (unsigned long long)img.order,
	       bc_client_info(c)->last_msg_bytes);
out:
	bc_client_image_finish(&img);
	bc_client_destroy(c);
	return status;
}

/* ---- watch
 * ----------------------------------------------------------------------------------
 */

static volatile sig_atomic_t interrupted;

static void on_interrupt(int sig)
{
	(void)sig;
	interrupted = 1;
}

/* A long-running command (watch, present, follow) routes SIGINT and
 * SIGTERM to on_interrupt, to end its loop cleanly, and puts back the
 * handlers it found when it ends. */
struct stop_signals {
	struct sigaction old_int, old_term;
};

static void stop_signals_install(struct stop_signals *s)
{
	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_interrupt;
	sigemptyset(&sa.sa_mask);
	interrupted = 0;
	sigaction(SIGINT, &sa, &s->old_int);
	sigaction(SIGTERM, &sa, &s->old_term);
}

static void stop_signals_restore(const struct stop_signals *s)
{
	sigaction(SIGINT, &s->old_int, NULL);
	sigaction(SIGTERM, &s->old_term, NULL);
}

/* How long watch and follow wait for each frame when --frames asks for a
 * count, in ms; negative waits forever (--timeout -1). */
static double frame_idle_limit(const struct args *a)
{
	return a->timeout_ms < 0    ? -1.0
	       : a->timeout_ms == 0 ? (double)BC_CLIENT_DEFAULT_TIMEOUT_MS
	                            : (double)a->timeout_ms;
}

/* Reports a run of --frames N that ended because no frame came within
 * idle_limit ms; returns the exit status for it. */
static int frames_timed_out(const struct args *a, uint64_t nframes,
                            double idle_limit)
{
	fprintf(stderr,
	        "blobcast %s: timed out: %llu of %llu frames, none "
	        "for %.0f ms (--timeout)\n",
	        a->cmd, (unsigned long long)nframes,
	        (unsigned long long)a->frames, idle_limit);
	return EXIT_FAIL;
}

/* Reports the server's ERROR message m the way failed() reports our own
 * errors; returns the exit status for it. */
static int server_failed(const struct args *a, const struct bc_client *c,
                         const struct bc_msg *m)
{
	struct bc_errinfo ei = {0};
	ei.code = -(int)m->error.code;
	snprintf(ei.msg, sizeof(ei.msg), "%.*s", (int)m->error.text.len,
	         m->error.text.ptr);
	return failed(a, c, NULL, &ei);
}

/* Arrival times of edit orders, to measure frames against. */
struct order_times {
	uint64_t order[WATCH_ORDERS];
	double at[WATCH_ORDERS];
};

static void order_seen(struct order_times *o, uint64_t order, double at)
{
	uint32_t k = (uint32_t)(order % WATCH_ORDERS);
	o->order[k] = order;
	o->at[k] = at;
}

static bool order_time(const struct order_times *o, uint64_t order, double *at)
{
	uint32_t k = (uint32_t)(order % WATCH_ORDERS);
	if (order == 0 || o->order[k] != order) {
		return false;
	}
	*at = o->at[k];
	return true;
}

static const char *frame_kind(uint16_t flags)
{
	if (flags & BC_PROTO_FLAG_INCOMPLETE) {
		/* The server's time budget stopped refinement; the picture is
		 * whole at its level and finer frames follow. */
		if (flags & BC_PROTO_FLAG_SNAPSHOT) {
			return "snapshot incomplete";
		}
		return (flags & BC_PROTO_FLAG_STILL) ? "still incomplete"
		                                     : "interactive incomplete";
	}
	if (flags & BC_PROTO_FLAG_SNAPSHOT) {
		return "snapshot";
	}
	return (flags & BC_PROTO_FLAG_STILL) ? "still" : "interactive";
}

/* The session's members as the last SESSION_INFO listed them, to name
 * the authors of edits. */
struct roster {
	uint16_t n;
	uint32_t self;
	struct {
		uint32_t id;
		enum bc_proto_role role;
		char name[BC_PROTO_MAX_NAME + 1];
	} m[BC_PROTO_MAX_MEMBERS];
};

static void roster_update(struct roster *r,
                          const struct bc_msg_session_info *si)
{
	r->n = 0;
	r->self = si->member_id;
	for (uint16_t i = 0; i < si->nmembers && i < BC_PROTO_MAX_MEMBERS;
	     i++) {
		const struct bc_proto_member *pm = &si->members[i];
		r->m[i].id = pm->id;
		r->m[i].role = pm->role;
		snprintf(r->m[i].name, sizeof(r->m[i].name), "%.*s",
		         (int)pm->name.len, pm->name.ptr);
		r->n++;
	}
}

static const char *roster_name(const struct roster *r, uint32_t id)
{
	for (uint16_t i = 0; i < r->n; i++) {
		if (r->m[i].id == id) {
			return r->m[i].name;
		}
	}
	return NULL;
}

/* "members 3: alice (editor, 4), blobcast-cli (viewer, 7, this client)" */
static void print_members(const struct roster *r)
{
	printf("members %u:", r->n);
	for (uint16_t i = 0; i < r->n; i++) {
		printf(
		    "%s \"%s\" (%s, %u%s)", i ? "," : "", r->m[i].name,
		    r->m[i].role == BC_PROTO_ROLE_EDITOR ? "editor" : "viewer",
		    r->m[i].id, r->m[i].id == r->self ? ", this client" : "");
	}
	printf("\n");
}

/* `edit order=5 by="carol" member=20 ops=1`: the author's name comes from
 * the member list (an author who already left prints as ""). */
static void print_change(const struct roster *r, const char *what,
                         uint64_t order, uint32_t author, const char *tail)
{
	const char *name = roster_name(r, author);
	printf("%s order=%llu by=\"%s\" member=%u%s\n", what,
	       (unsigned long long)order, name ? name : "", author, tail);
}

/* `undo order=6 of=5 by="bob" author="alice" member=20 ops=3` (or redo):
 * edit 6, sent by bob (member 20), takes back (applies again) edit 5, whose
 * author the server names. */
static void print_undo(const struct roster *r, const struct bc_msg *m)
{
	const struct bc_msg_edit_applied *e = &m->edit_applied;
	const char *name = roster_name(r, e->author);
	printf("%s order=%llu of=%llu by=\"%s\" author=\"%.*s\" member=%u "
	       "ops=%u\n",
	       (m->flags & BC_PROTO_FLAG_REDO) ? "redo" : "undo",
	       (unsigned long long)e->order,
	       (unsigned long long)e->target_order, name ? name : "",
	       (int)e->target_author.len, e->target_author.ptr, e->author,
	       e->nops);
}

/* `presenter member=4 name="alice"` or `presenter none`, with
 * ` following` when this client follows. */
static void print_presenter(const struct roster *r, uint32_t id, bool following)
{
	const char *name = roster_name(r, id);
	if (!id) {
		printf("presenter none\n");
		return;
	}
	printf("presenter member=%u name=\"%s\"%s\n", id, name ? name : "",
	       following ? " following" : "");
}

/* The errors after which connecting again would be refused the same way:
 * watch reports them and stops instead of retrying. */
static bool watch_gives_up(int code)
{
	return code == BC_EAUTH || code == BC_EPERM ||
	       code == BC_EPROTO_VERSION || code == BC_ENOSESSION ||
	       code == BC_EINVAL || code == BC_ELIMIT;
}

/* Connects, joins a->session as a viewer and asks for frames. The join is
 * done here rather than with bc_client_join() to keep SESSION_INFO's
 * member list (the scene state that follows is read by the frame loop).
 * Returns 0 or a BC_E* code with the reason in ei; *c is set either way
 * (NULL when the connection failed). */
static int watch_open(const struct args *a, struct bc_client **c,
                      struct roster *roster, double *view_at,
                      struct bc_errinfo *ei)
{
	struct bc_client_opts opts = connect_opts(a);
	struct bc_msg m = {.type = BC_MSG_SESSION_JOIN};
	int rc;
	*c = NULL;
	if ((rc = bc_client_connect(c, &opts, ei))) {
		return rc;
	}
	m.session.role = BC_PROTO_ROLE_VIEWER;
	m.session.name.ptr = a->session;
	m.session.name.len = (uint32_t)strlen(a->session);
	if ((rc = bc_client_send(*c, &m, NULL)) ||
	    (rc = bc_client_wait(*c, BC_MSG_SESSION_INFO, 0, &m, 0, ei))) {
		if (!ei->code) {
			bc_client_error(*c, ei);
			ei->code = rc;
		}
		return rc;
	}
	roster_update(roster, &m.session_info);
	print_members(roster);
	/* FOLLOW 0 follows nobody; it asks the server to say who presents
	 * (PRESENTER), now and whenever that changes. */
	if ((rc = bc_client_follow(*c, false, ei))) {
		return rc;
	}
	print_presenter(roster, bc_client_info(*c)->presenter, false);
	*view_at = bc_clock_ms();
	return bc_client_view(*c,
	                      &(struct bc_msg_view){.width = a->width,
	                                            .height = a->height,
	                                            .encoding = a->encoding,
	                                            .downscale = a->downscale},
	                      NULL, ei);
}

/*
 * Latency of a frame, as this client can measure it without a shared
 * clock: from the moment this client learned of the newest change the
 * frame shows to the moment the frame arrived. The change is an edit
 * (EDIT_APPLIED, or SCENE_STATE for a load) when the frame's edit order is
 * new; for the first frame after joining it is our VIEW request. Frames
 * that show nothing new (a finer level or the still refining an earlier
 * frame) get "-".
 *
 * A lost connection (the daemon restarted, the network dropped) is
 * retried with a doubling delay and the session joined again; errors that
 * a retry would meet again (a refused token, a missing session) end the
 * run. With --frames N the run also ends when no frame has come for the
 * --timeout (end=timeout, status 1).
 */
static int run_watch(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	struct order_times *times = NULL;
	struct roster *roster = NULL;
	struct stop_signals sig;
	struct bc_msg m;
	struct bc_msg_stats st;
	uint64_t nframes = 0, last_order = 0, total_bytes = 0;
	uint64_t joined_at_frame = 0;
	double view_at = 0.0, last_frame_at, retry_at = 0.0;
	int backoff_ms = WATCH_BACKOFF_MIN_MS, rc, status = 0;
	/* --timeout bounds the wait for each frame when --frames asks for a
	 * count; without it watch runs until stopped. */
	double idle_limit = frame_idle_limit(a);
	const char *end = "stopped";
	bc_client_image_init(&img);
	stop_signals_install(&sig);
	if (!(times = bc_calloc(1, sizeof(*times))) ||
	    !(roster = bc_calloc(1, sizeof(*roster)))) {
		fprintf(stderr, "blobcast watch: out of memory\n");
		status = EXIT_FAIL;
		goto out;
	}
	/* The first connection must work: a wrong address or session is a
	 * mistake to report, not to retry. */
	if ((rc = watch_open(a, &c, roster, &view_at, &ei))) {
		status = failed(a, c, NULL, &ei);
		goto out;
	}
	last_frame_at = bc_clock_ms();
	while (!interrupted && (a->frames == 0 || nframes < a->frames)) {
		double at, since;
		const char *after = "-";
		if (a->frames && idle_limit >= 0.0 &&
		    bc_clock_ms() - last_frame_at > idle_limit) {
			end = "timeout";
			break;
		}
		if (!c) {
			/* Reconnecting: wait out the back-off in slices so
			 * that Ctrl-C and the timeout are noticed. */
			if (bc_clock_ms() < retry_at) {
				struct timespec ts = {0, WATCH_SLICE_MS *
				                             1000000L};
				nanosleep(&ts, NULL);
				continue;
			}
			memset(&ei, 0, sizeof(ei));
			rc = watch_open(a, &c, roster, &view_at, &ei);
			if (rc && watch_gives_up(rc)) {
				status = failed(a, c, "reconnecting", &ei);
				goto out;
			}
			if (rc) {
				bc_client_destroy(c);
				c = NULL;
				retry_at = bc_clock_ms() + backoff_ms;
				fprintf(
				    stderr,
				    "blobcast watch: reconnecting failed: %s "
				    "(%s); next try in %d ms\n",
				    ei.msg, bc_err_name(rc), backoff_ms);
				backoff_ms =
				    backoff_ms * 2 > WATCH_BACKOFF_MAX_MS
				        ? WATCH_BACKOFF_MAX_MS
				        : backoff_ms * 2;
				continue;
			}
			fprintf(stderr, "blobcast watch: rejoined session %s\n",
			        a->session);
			printf("rejoined session=%s\n", a->session);
			backoff_ms = WATCH_BACKOFF_MIN_MS;
			joined_at_frame = nframes;
			last_order = 0;
		}
		rc = bc_client_recv(c, &m, WATCH_SLICE_MS);
		if (rc == 0) {
			continue;
		}
		if (rc < 0 || (m.type == BC_MSG_ERROR &&
		               (m.flags & BC_PROTO_FLAG_FATAL))) {
			if (rc > 0) {
				ei.code = -(int)m.error.code;
				snprintf(ei.msg, sizeof(ei.msg), "server: %.*s",
				         (int)m.error.text.len,
				         m.error.text.ptr);
			} else {
				bc_client_error(c, &ei);
			}
			if (watch_gives_up(ei.code)) {
				status = failed(a, c, NULL, &ei);
				goto out;
			}
			fprintf(stderr,
			        "blobcast watch: connection lost: %s (%s); "
			        "reconnecting\n",
			        ei.msg[0] ? ei.msg : bc_strerror(ei.code),
			        bc_err_name(ei.code));
			printf("lost reason=%s\n", bc_err_name(ei.code));
			fflush(stdout);
			bc_client_destroy(c);
			c = NULL;
			retry_at = bc_clock_ms() + backoff_ms;
			continue;
		}
		at = bc_clock_ms();
		switch (m.type) {
		case BC_MSG_SESSION_INFO:
			roster_update(roster, &m.session_info);
			print_members(roster);
			fflush(stdout);
			break;
		case BC_MSG_EDIT_APPLIED: {
			const struct bc_msg_edit_applied *e = &m.edit_applied;
			order_seen(times, e->order, at);
			if (m.flags &
			    (BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO)) {
				print_undo(roster, &m);
			} else {
				char tail[32];
				snprintf(tail, sizeof(tail), " ops=%u%s",
				         e->nops,
				         (m.flags & BC_PROTO_FLAG_INTERACTING)
				             ? " interacting"
				             : "");
				print_change(roster, "edit", e->order,
				             e->author, tail);
			}
			fflush(stdout);
			break;
		}
		case BC_MSG_PRESENTER:
			print_presenter(roster, m.presenter.presenter,
			                m.presenter.following != 0);
			fflush(stdout);
			break;
		case BC_MSG_SESSION_CAMERA_SET:
			order_seen(times, m.session_camera_set.order, at);
			print_change(roster, "camera",
			             m.session_camera_set.order,
			             m.session_camera_set.author, "");
			fflush(stdout);
			break;
		case BC_MSG_SCENE_STATE:
			order_seen(times, m.scene_state.order, at);
			if (m.scene_state.author) {
				print_change(roster, "load",
				             m.scene_state.order,
				             m.scene_state.author, "");
				fflush(stdout);
			}
			break;
		case BC_MSG_ERROR:
			status = server_failed(a, c, &m);
			goto out;
		case BC_MSG_FRAME:
			nframes++;
			last_frame_at = at;
			total_bytes += bc_client_info(c)->last_msg_bytes;
			if (bc_client_image_apply(&img, &m, &ei)) {
				fprintf(stderr,
				        "blobcast watch: frame %u does not "
				        "decode: %s\n",
				        m.frame.frame_no, ei.msg);
			}
			since = -1.0;
			if (nframes == joined_at_frame + 1) {
				since = at - view_at;
				after = "view";
			} else if (m.frame.order > last_order &&
			           order_time(times, m.frame.order, &since)) {
				since = at - since;
				after = "edit";
			}
			last_order = m.frame.order;
			printf(
			    "frame %llu no=%u order=%llu bytes=%u rects=%u "
			    "image=%ux%u level=%u %s latency_ms=",
			    (unsigned long long)nframes, m.frame.frame_no,
			    (unsigned long long)m.frame.order,
			    bc_client_info(c)->last_msg_bytes, m.frame.nrects,
			    m.frame.image_width, m.frame.image_height,
			    bc_proto_flags_level(m.flags), frame_kind(m.flags));
			if (since >= 0.0) {
				printf("%.2f after=%s\n", since, after);
			} else {
				printf("- after=-\n");
			}
			fflush(stdout);
			break;
		default:
			break;
		}
	}
	if (a->frames && nframes >= a->frames) {
		end = "frames";
	}
	/* Server averages when the connection is up; a run that ends while
	 * reconnecting reports its own counts only. */
	memset(&st, 0, sizeof(st));
	if (c && bc_client_stats(c, &st, &ei)) {
		status = failed(a, c, "stats", &ei);
		goto out;
	}
	printf("stats frames=%llu bytes=%llu server_frames=%llu "
	       "server_fps=%.1f render_ms_avg=%.2f encode_ms_avg=%.2f "
	       "edit_ms_avg=%.3f end=%s\n",
	       (unsigned long long)nframes, (unsigned long long)total_bytes,
	       (unsigned long long)st.frames, (double)st.fps,
	       (double)st.render_ms_avg, (double)st.encode_ms_avg,
	       (double)st.edit_ms_avg, end);
	if (strcmp(end, "timeout") == 0) {
		status = frames_timed_out(a, nframes, idle_limit);
	}
out:
	stop_signals_restore(&sig);
	bc_free(times);
	bc_free(roster);
	bc_client_image_finish(&img);
	bc_client_destroy(c);
	return status;
}

/* ---- present, follow
 * ------------------------------------------------------------------------ */

/*
 * A one-shot presenter: it sets this connection's camera (the session's,
 * changed by the camera options), presents, and stays until Ctrl-C,
 * SIGTERM, --for SECONDS or another member taking over; then it stops
 * presenting (unless replaced), which ends every follow. Any role may
 * present, so it joins as a viewer.
 */
static int run_present(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	struct bc_msg m;
	struct stop_signals sig;
	double until = 0.0;
	const char *end = "stopped";
	uint32_t me;
	int status, rc;
	stop_signals_install(&sig);
	if ((status = open_session(a, BC_PROTO_ROLE_VIEWER,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if ((status = camera_from_opts(a, c, &cam))) {
		goto out;
	}
	if (bc_client_camera(c, &cam, false, NULL, &ei) ||
	    bc_client_present(c, true, &ei)) {
		status = failed(a, c, "present", &ei);
		goto out;
	}
	me = bc_client_info(c)->member_id;
	printf("presenting session=%s member=%u eye=%g,%g,%g "
	       "target=%g,%g,%g fov=%g\n",
	       a->session, me, (double)cam.eye[0], (double)cam.eye[1],
	       (double)cam.eye[2], (double)cam.target[0], (double)cam.target[1],
	       (double)cam.target[2], (double)cam.fov_y_deg);
	fflush(stdout);
	if (a->for_s) {
		until = bc_clock_ms() + 1000.0 * (double)a->for_s;
	}
	while (!interrupted) {
		if (until > 0.0 && bc_clock_ms() >= until) {
			end = "time";
			break;
		}
		rc = bc_client_recv(c, &m, WATCH_SLICE_MS);
		if (rc < 0) {
			bc_client_error(c, &ei);
			status = failed(a, c, NULL, &ei);
			goto out;
		}
		if (rc == 0) {
			continue;
		}
		if (m.type == BC_MSG_PRESENTER && m.presenter.presenter != me) {
			printf("replaced by member=%u\n",
			       m.presenter.presenter);
			end = "replaced";
			break;
		}
		if (m.type == BC_MSG_ERROR) {
			status = server_failed(a, c, &m);
			goto out;
		}
	}
	if (strcmp(end, "replaced") != 0 && bc_client_present(c, false, &ei)) {
		status = failed(a, c, "stop presenting", &ei);
		goto out;
	}
	printf("end=%s\n", end);
out:
	stop_signals_restore(&sig);
	bc_client_destroy(c);
	return status;
}

/*
 * Follows the session's presenter: whoever presents now or starts later
 * (a presentation that ends is waited out). Prints who presents, each
 * camera the presenter moves to and each frame, rendered at --size.
 */
static int run_follow(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	struct bc_msg m;
	struct stop_signals sig;
	uint64_t nframes = 0;
	double last_frame_at;
	double idle_limit = frame_idle_limit(a);
	const char *end = "stopped";
	int status, rc;
	bc_client_image_init(&img);
	stop_signals_install(&sig);
	if (a->out && !bc_image_ext_supports(a->out, BC_IMAGE_U8)) {
		fprintf(stderr,
		        "blobcast follow: \"%s\": no image format for this "
		        "extension (use .png, .tif, .exr, .jpg, ...)\n",
		        a->out);
		status = EXIT_USAGE;
		goto out;
	}
	if ((status = open_session(a, BC_PROTO_ROLE_VIEWER,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	/* FOLLOW 0 first: the server then says who presents (PRESENTER). */
	if (bc_client_follow(c, false, &ei)) {
		status = failed(a, c, "follow", &ei);
		goto out;
	}
	if (bc_client_view(c,
	                   &(struct bc_msg_view){.width = a->width,
	                                         .height = a->height,
	                                         .encoding = a->encoding,
	                                         .downscale = a->downscale},
	                   NULL, &ei)) {
		status = failed(a, c, "view", &ei);
		goto out;
	}
	/* Behave as if PRESENTER had just said who presents. */
	memset(&m, 0, sizeof(m));
	m.type = BC_MSG_PRESENTER;
	m.presenter.presenter = bc_client_info(c)->presenter;
	rc = 1;
	last_frame_at = bc_clock_ms();
	while (!interrupted && (a->frames == 0 || nframes < a->frames)) {
		if (rc == 0) {
			if (a->frames && idle_limit >= 0.0 &&
			    bc_clock_ms() - last_frame_at > idle_limit) {
				end = "timeout";
				break;
			}
			rc = bc_client_recv(c, &m, WATCH_SLICE_MS);
			if (rc < 0) {
				bc_client_error(c, &ei);
				status = failed(a, c, NULL, &ei);
				goto out;
			}
			continue;
		}
		rc = 0;
		switch (m.type) {
		case BC_MSG_PRESENTER: {
			struct bc_msg f = {.type = BC_MSG_FOLLOW};
			if (!m.presenter.presenter) {
				printf("presenter none: waiting\n");
			} else if (m.presenter.following) {
				printf("following member=%u\n",
				       m.presenter.presenter);
			} else {
				/* Someone presents and we do not follow
				 * yet: ask (the answer comes as PRESENTER;
				 * a presentation that ends first makes it
				 * ESTATE, ignored below). */
				printf("presenter member=%u\n",
				       m.presenter.presenter);
				f.toggle.on = 1;
				if (bc_client_send(c, &f, NULL)) {
					bc_client_error(c, &ei);
					status = failed(a, c, "follow", &ei);
					goto out;
				}
			}
			fflush(stdout);
			break;
		}
		case BC_MSG_FOLLOW_CAMERA: {
			const struct bc_msg_camera *k = &m.follow_camera.camera;
			printf("camera member=%u eye=%g,%g,%g target=%g,%g,%g "
			       "up=%g,%g,%g fov=%g%s\n",
			       m.follow_camera.presenter, (double)k->eye[0],
			       (double)k->eye[1], (double)k->eye[2],
			       (double)k->target[0], (double)k->target[1],
			       (double)k->target[2], (double)k->up[0],
			       (double)k->up[1], (double)k->up[2],
			       (double)k->fov_y_deg,
			       (m.flags & BC_PROTO_FLAG_INTERACTING)
			           ? " interacting"
			           : "");
			fflush(stdout);
			break;
		}
		case BC_MSG_FRAME:
			nframes++;
			last_frame_at = bc_clock_ms();
			if (bc_client_image_apply(&img, &m, &ei)) {
				fprintf(stderr,
				        "blobcast follow: frame %u does not "
				        "decode: %s\n",
				        m.frame.frame_no, ei.msg);
			}
			printf("frame %llu no=%u view=%ux%u image=%ux%u "
			       "level=%u %s\n",
			       (unsigned long long)nframes, m.frame.frame_no,
			       m.frame.width, m.frame.height,
			       m.frame.image_width, m.frame.image_height,
			       bc_proto_flags_level(m.flags),
			       frame_kind(m.flags));
			fflush(stdout);
			break;
		case BC_MSG_ERROR:
			/* A FOLLOW that met no presenter: the next
			 * PRESENTER says when one starts. */
			if (-(int)m.error.code == BC_ESTATE && m.seq != 0) {
				break;
			}
			status = server_failed(a, c, &m);
			goto out;
		default:
			break;
		}
	}
	if (a->frames && nframes >= a->frames) {
		end = "frames";
	}
	if (a->out && img.complete &&
	    bc_image_write_rgba8(a->out, img.width, img.height, img.rgba,
	                         &ei)) {
		fprintf(stderr, "blobcast follow: %s\n", ei.msg);
		status = EXIT_FAIL;
		goto out;
	}
	if (a->out && img.complete) {
		printf("wrote %s (%ux%u)\n", a->out, img.width, img.height);
	}
	printf("end=%s frames=%llu\n", end, (unsigned long long)nframes);
	if (strcmp(end, "timeout") == 0) {
		status = frames_timed_out(a, nframes, idle_limit);
	}
out:
	stop_signals_restore(&sig);
	bc_client_image_finish(&img);
	bc_client_destroy(c);
	return status;
}

/* ---- nodes, scene
 * ----------------------------------------------------------------------------
 */

/* Both read the scene mirror that joining as a viewer fills from the
 * session's SCENE_STATE: nothing is changed on the server, and the other
 * members see a viewer come and go. */
static int run_nodes(struct args *a)
{
	struct bc_client *c = NULL;
	const struct bc_tree *t;
	int status, rc;
	if ((status = open_session(a, BC_PROTO_ROLE_VIEWER,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (!(t = bc_client_scene(c, NULL))) {
		fprintf(stderr, "blobcast nodes: the session's scene did not "
		                "decode (see the log above)\n");
		status = EXIT_FAIL;
		goto out;
	}
	if ((rc = bc_cli_print_nodes(stdout, t, a->json))) {
		fprintf(stderr, "blobcast nodes: %s\n", bc_strerror(rc));
		status = EXIT_FAIL;
	}
out:
	bc_client_destroy(c);
	return status;
}

static int run_delete(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	char what[128];
	int status = connect_to(a, &c);
	if (status == 0 && bc_client_delete_session(c, a->session, &ei)) {
		snprintf(what, sizeof(what), "session %s", a->session);
		status = failed(a, c, what, &ei);
	}
	if (status == 0) {
		printf("deleted session %s\n", a->session);
	}
	bc_client_destroy(c);
	return status;
}

static int run_undo(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_undone u;
	bool redo = strcmp(a->cmd, "redo") == 0;
	int status;
	if ((status = open_session(a, BC_PROTO_ROLE_EDITOR,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (bc_client_undo(c, redo, &u, &ei)) {
		status = failed(a, c, NULL, &ei);
		goto out;
	}
	printf("%s edit %llu by \"%s\": edit order %llu\n",
	       redo ? "redid" : "undid", (unsigned long long)u.target_order,
	       u.target_author, (unsigned long long)u.order);
out:
	bc_client_destroy(c);
	return status;
}

/* Unix milliseconds as UTC "YYYY-MM-DDTHH:MM:SSZ", or "-" for 0. */
static void put_time(char *buf, size_t n, uint64_t ms)
{
	time_t t = (time_t)(ms / 1000u);
	struct tm tm;
	if (ms == 0 || !gmtime_r(&t, &tm) ||
	    strftime(buf, n, "%Y-%m-%dT%H:%M:%SZ", &tm) == 0) {
		snprintf(buf, n, "-");
	}
}

static int run_sessions(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_session *list = NULL;
	size_t n = 0;
	int status = connect_to(a, &c);
	if (status == 0 && bc_client_sessions(c, &list, &n, &ei)) {
		status = failed(a, c, NULL, &ei);
	}
	if (status == 0 && a->json) {
		json_t *arr = json_array();
		char *text;
		for (size_t i = 0; arr && i < n; i++) {
			const struct bc_client_session *s = &list[i];
			json_t *o = json_pack(
			    "{s:s, s:I, s:b}", "name", s->name, "members",
			    (json_int_t)s->members, "loaded", s->loaded);
			if (o && s->known) {
				json_object_set_new(
				    o, "primitives",
				    json_integer((json_int_t)s->prims));
				json_object_set_new(
				    o, "order",
				    json_integer((json_int_t)s->order));
				json_object_set_new(
				    o, "last_edit_ms",
				    json_integer((json_int_t)s->last_edit_ms));
			}
			json_array_append_new(arr, o);
		}
		if (!arr || !(text = json_dumps(arr, JSON_INDENT(2)))) {
			fprintf(stderr, "blobcast sessions: out of memory\n");
			status = EXIT_FAIL;
		} else {
			printf("%s\n", text);
			free(text);
		}
		json_decref(arr);
	} else if (status == 0) {
		printf("%-24s %7s %10s %8s  %-20s %s\n", "NAME", "MEMBERS",
		       "PRIMITIVES", "ORDER", "LAST EDIT (UTC)", "STATE");
		for (size_t i = 0; i < n; i++) {
			const struct bc_client_session *s = &list[i];
			char when[32], prims[16], order[24];
			put_time(when, sizeof(when),
			         s->known ? s->last_edit_ms : 0);
			snprintf(prims, sizeof(prims), "%s", "-");
			snprintf(order, sizeof(order), "%s", "-");
			if (s->known) {
				snprintf(prims, sizeof(prims), "%u", s->prims);
				snprintf(order, sizeof(order), "%llu",
				         (unsigned long long)s->order);
			}
			printf("%-24s %7u %10s %8s  %-20s %s\n", s->name,
			       s->members, prims, order, when,
			       s->loaded ? "loaded" : "on disk");
		}
	}
	bc_free(list);
	bc_client_destroy(c);
	return status;
}

static int run_scene(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	const struct bc_tree *t;
	struct bc_camera cam;
	char *text = NULL;
	int status;
	if ((status = open_session(a, BC_PROTO_ROLE_VIEWER,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (!(t = bc_client_scene(c, &cam))) {
		fprintf(stderr, "blobcast scene: the session's scene did not "
		                "decode (see the log above)\n");
		status = EXIT_FAIL;
		goto out;
	}
	if (a->out && strcmp(a->out, "-") != 0) {
		if (bc_scene_save_json(a->out, t, &cam, &ei)) {
			fprintf(stderr, "blobcast scene: %s\n", ei.msg);
			status = EXIT_FAIL;
			goto out;
		}
		printf("session %s: wrote %s (%u nodes, edit order %llu)\n",
		       a->session, a->out, bc_tree_node_count(t),
		       (unsigned long long)bc_client_info(c)->order);
		goto out;
	}
	if (!(text = bc_scene_to_json(t, &cam))) {
		/* The binary form carries trees the JSON writer refuses. */
		fprintf(
		    stderr,
		    "blobcast scene: the scene (%u nodes, nesting %u) cannot "
		    "be written as JSON (nesting limit %u, or out of "
		    "memory)\n",
		    bc_tree_node_count(t), bc_tree_nesting(t),
		    BC_SCENE_JSON_MAX_DEPTH);
		status = EXIT_FAIL;
		goto out;
	}
	if (fputs(text, stdout) == EOF || fflush(stdout) != 0) {
		fprintf(stderr, "blobcast scene: writing to stdout: %s\n",
		        strerror(errno));
		status = EXIT_FAIL;
	}
out:
	bc_free(text);
	bc_client_destroy(c);
	return status;
}

/* ---- bench-latency
 * ------------------------------------------------------------------------------
 */

static int cmp_double(const void *x, const void *y)
{
	double a = *(const double *)x, b = *(const double *)y;
	return (a > b) - (a < b);
}

/* Nearest-rank percentile of sorted v[0..n). */
static double percentile(const double *v, uint32_t n, double p)
{
	double rank = ceil(p / 100.0 * (double)n);
	uint32_t k = rank < 1.0 ? 0u : (uint32_t)rank - 1u;
	return v[k < n ? k : n - 1];
}

/* The first primitive in pre-order, or 0. */
static uint32_t first_prim(const struct bc_tree *t)
{
	struct bc_scene_walk w;
	struct bc_scene_node node;
	uint32_t id = 0;
	if (bc_scene_walk_init(&w, t)) {
		return 0;
	}
	while (bc_scene_walk_next(&w, &node)) {
		if (!node.is_op) {
			id = node.id;
			break;
		}
	}
	bc_scene_walk_finish(&w);
	return id;
}

/* Sends one translate edit and waits for the first frame that shows it
 * (its edit order is at least the one the server gave the edit). Returns 0
 * with the frames and bytes received meanwhile added up, or an exit
 * status. */
static int one_edit(const struct args *a, struct bc_client *c, uint32_t node,
                    const float pos[3], uint64_t *frames, uint64_t *bytes,
                    uint64_t *incomplete)
{
	struct bc_proto_field f = {.field = BC_PROTO_FIELD_TRANSLATE,
	                           .count = 3};
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	uint64_t want = 0;
	uint32_t seq;
	int timeout =
	    a->timeout_ms == 0 ? BC_CLIENT_DEFAULT_TIMEOUT_MS : a->timeout_ms;
	double deadline = bc_clock_ms() + (double)timeout;
	memcpy(f.v, pos, 3 * sizeof(float));
	if (bc_client_edit_set(c, node, &f, 1, a->interacting, &seq, &ei)) {
		return failed(a, c, NULL, &ei);
	}
	for (;;) {
		double left = deadline - bc_clock_ms();
		int rc = bc_client_recv(
		    c, &m, timeout < 0 ? -1 : (left > 0.0 ? (int)left + 1 : 0));
		if (rc < 0) {
			bc_client_error(c, &ei);
			return failed(a, c, NULL, &ei);
		}
		if (rc == 0) {
			fprintf(stderr,
			        "blobcast %s: no frame showing edit %u within "
			        "%d ms\n",
			        a->cmd, seq, timeout);
			return EXIT_FAIL;
		}
		if (m.type == BC_MSG_ERROR) {
			return server_failed(a, c, &m);
		}
		if (m.type == BC_MSG_EDIT_APPLIED &&
		    m.edit_applied.author == bc_client_info(c)->member_id &&
		    m.edit_applied.author_seq == seq) {
			want = m.edit_applied.order;
		} else if (m.type == BC_MSG_FRAME) {
			(*frames)++;
			*bytes += bc_client_info(c)->last_msg_bytes;
			if (m.flags & BC_PROTO_FLAG_INCOMPLETE) {
				(*incomplete)++;
			}
			/* EDIT_APPLIED precedes every frame that shows it. */
			if (want && m.frame.order >= want) {
				return 0;
			}
		}
	}
}

static int run_bench(struct args *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_prim_data p;
	struct bc_msg m;
	struct bc_msg_stats st;
	double *lat = NULL, sum = 0.0;
	uint64_t frames = 0, bytes = 0, incomplete = 0;
	uint32_t node = a->node, seq;
	float origin[3], pos[3];
	json_t *j = NULL;
	char *line = NULL;
	int status;
	if (a->edits == 0) {
		fprintf(stderr, "blobcast bench-latency: --edits N is required "
		                "(see blobcast bench-latency --help)\n");
		return EXIT_USAGE;
	}
	if (!(lat = bc_calloc(a->edits, sizeof(*lat)))) {
		fprintf(stderr, "blobcast bench-latency: out of memory\n");
		return EXIT_FAIL;
	}
	if ((status = open_session(a, BC_PROTO_ROLE_EDITOR,
	                           BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (!bc_client_scene(c, NULL)) {
		fprintf(stderr, "blobcast bench-latency: the session's scene "
		                "did not arrive intact\n");
		status = EXIT_FAIL;
		goto out;
	}
	if (node == 0) {
		node = first_prim(bc_client_scene(c, NULL));
	}
	if (!bc_tree_get(bc_client_scene(c, NULL), node, &p, NULL) ||
	    p.kind == BC_PRIM_INVALID) {
		fprintf(stderr,
		        "blobcast bench-latency: node %u is not a "
		        "primitive of the session's scene\n",
		        node);
		status = EXIT_USAGE;
		goto out;
	}
	memcpy(origin, p.translate, sizeof(origin));
	if (bc_client_view(c,
	                   &(struct bc_msg_view){.width = a->width,
	                                         .height = a->height,
	                                         .encoding = a->encoding,
	                                         .downscale = a->downscale},
	                   &seq, &ei) ||
	    bc_client_wait(c, BC_MSG_FRAME, 0, &m, 0, &ei)) {
		status = failed(a, c, "first frame", &ei);
		goto out;
	}
	for (uint32_t i = 0; i < a->edits; i++) {
		double t0;
		memcpy(pos, origin, sizeof(pos));
		if (i % 2 == 0) {
			pos[0] += BENCH_STEP;
		}
		t0 = bc_clock_ms();
		if ((status = one_edit(a, c, node, pos, &frames, &bytes,
		                       &incomplete))) {
			goto out;
		}
		lat[i] = bc_clock_ms() - t0;
		sum += lat[i];
	}
	if (a->edits % 2 == 1) {
		/* Put the primitive back where it was. */
		uint64_t fx = 0, bx = 0, ix = 0;
		if ((status = one_edit(a, c, node, origin, &fx, &bx, &ix))) {
			goto out;
		}
	}
	if (bc_client_stats(c, &st, &ei)) {
		status = failed(a, c, "stats", &ei);
		goto out;
	}
	qsort(lat, a->edits, sizeof(*lat), cmp_double);
	j = json_pack("{s:s, s:s, s:i, s:s, s:I, s:I, s:b, s:f, s:f, s:f, "
	              "s:f, s:f, s:I, s:f, s:f, s:f, s:f}",
	              "bench", "edit_to_frame_latency", "session", a->session,
	              "edits", (int)a->edits, "encoding",
	              bc_proto_encoding_name(a->encoding ? a->encoding
	                                                 : BC_PROTO_ENC_JPEG),
	              "width", (json_int_t)a->width, "height",
	              (json_int_t)a->height, "interacting", a->interacting,
	              "p50_ms", percentile(lat, a->edits, 50.0), "p99_ms",
	              percentile(lat, a->edits, 99.0), "mean_ms",
	              sum / (double)a->edits, "min_ms", lat[0], "max_ms",
	              lat[a->edits - 1], "frames", (json_int_t)frames,
	              "bytes_per_frame",
	              frames ? (double)bytes / (double)frames : 0.0,
	              "server_render_ms_avg", (double)st.render_ms_avg,
	              "server_encode_ms_avg", (double)st.encode_ms_avg,
	              "server_edit_ms_avg", (double)st.edit_ms_avg);
	if (j) {
		json_object_set_new(j, "node", json_integer(node));
		/* Frames cut short by the server's frame time budget. */
		json_object_set_new(j, "incomplete_frames",
		                    json_integer((json_int_t)incomplete));
	}
	if (!j ||
	    !(line = json_dumps(j, JSON_COMPACT | JSON_REAL_PRECISION(6)))) {
		fprintf(stderr, "blobcast bench-latency: out of memory\n");
		status = EXIT_FAIL;
		goto out;
	}
	printf("%s\n", line);
out:
	free(line);
	json_decref(j);
	bc_free(lat);
	bc_client_destroy(c);
	return status;
}

/* ---- dispatch
 * ------------------------------------------------------------------------------------
 */

static const struct cmd cmds[] = {
    {"load", O_SESSION, 1, 1, "--session NAME SCENE.json",
     "load a JSON scene into a session (created if missing)",
     "Loads SCENE.json (blobtree's JSON scene format, with its camera)\n"
     "into session NAME, replacing its scene; every member sees it at\n"
     "once. Creates the session when it does not exist.",
     NULL, run_load},
    {"edit", O_SESSION | O_INTERACTING, 2, MAX_POSITIONAL,
     "--session NAME ID key=value...", "set parameters of one node",
     "Sets fields of node ID and waits until the server has applied the\n"
     "edit. Primitives: translate=x,y,z rotate=x,y,z,w (unit quaternion)\n"
     "color=r,g,b and their kind's parameters (radius=0.4,\n"
     "half_extents=0.5,0.5,0.5, ...; see docs/primitives.md). Operators:\n"
     "blend=B range=R kind=NAME (union, smooth_union, ...).",
     (const struct opt_text[]){{"interacting", NULL,
                                "mark the edit as part of a drag (the "
                                "server\nanswers with fast interactive "
                                "frames)"},
                               {NULL, NULL, NULL}},
     run_edit},
    {"camera", O_SESSION | O_CAMERA, 0, 0,
     "--session NAME --eye x,y,z --target x,y,z [--up x,y,z] [--fov DEG]",
     "set the session's camera",
     "Sets the session's saved camera: the view members who join from\n"
     "now on start with, saved with the scene (and given back by\n"
     "'blobcast scene'). Members already in the session keep their own\n"
     "cameras (to take viewers along, use 'present'). Only the camera is\n"
     "sent, so edits other members make meanwhile stand. Needs the\n"
     "editor role. --up and --fov default to the session's current\n"
     "values.",
     NULL, run_camera},
    {"present", O_SESSION | O_CAMERA | O_FOR, 0, 0,
     "--session NAME [--eye x,y,z --target x,y,z ...] [--for SECONDS]",
     "present: members who follow see this client's camera",
     "Joins session NAME (as a viewer: any role may present), sets this\n"
     "client's camera to the session's changed by --eye/--target/--up/\n"
     "--fov, and presents: members who follow (viewer F key, page\n"
     "button, 'blobcast follow') see the session from this camera, each\n"
     "at its own view size. A presenter that another member replaces\n"
     "stops. Prints\n"
     "  presenting session=NAME member=ID eye=... target=... fov=...\n"
     "  replaced by member=ID             (another member presents)\n"
     "  end=stopped|time|replaced\n"
     "and stops presenting when it ends, which ends every follow.",
     NULL, run_present},
    {"follow", O_SESSION | O_SIZE | O_FRAMES | O_ENCODING | O_DOWNSCALE | O_OUT,
     0, 0, "--session NAME [--frames N] [--size WxH] [--out IMG]",
     "follow the presenter and print its camera and frames",
     "Joins session NAME as a viewer and follows whoever presents (now,\n"
     "or when someone starts; a presentation that ends is waited out):\n"
     "the server renders this client's frames from the presenter's\n"
     "camera at --size. Prints\n"
     "  presenter member=ID | presenter none: waiting\n"
     "  following member=ID\n"
     "  camera member=ID eye=x,y,z target=x,y,z up=x,y,z fov=F "
     "[interacting]\n"
     "  frame K no=N view=WxH image=WxH level=L still|interactive\n"
     "  end=frames|timeout|stopped frames=K",
     (const struct opt_text[]){{"frames", NULL,
                                "stop after N frames ({range}); give up "
                                "when no\nframe came for --timeout MS "
                                "(default 10000),\nexit status 1"},
                               {"encoding", NULL, "{choices} (default jpeg)"},
                               {"out", NULL,
                                "at the end, write the last picture to "
                                "IMG"},
                               {NULL, NULL, NULL}},
     run_follow},
    {"snapshot", O_SESSION | O_SIZE | O_OUT | O_DEPTH | O_IDS | O_CAMERA, 0, 0,
     "--session NAME --size WxH --out IMG [--depth IMG] [--ids IMG]",
     "save a lossless still of a session to an image file",
     "Asks the server for a lossless (PNG) still of session NAME at WxH\n"
     "and writes it to IMG (any format OpenImageIO writes, by extension;\n"
     ".jpg is lossy). The camera is the session's, or the one given by\n"
     "--eye/--target/--up/--fov (for this picture only). Depth and ids\n"
     "come from the same render as the colour, sent losslessly by the\n"
     "server.",
     (const struct opt_text[]){
         {"size", NULL, "picture size, each {range} (required)"},
         {"out", NULL, "write the picture to IMG (required)"},
         {NULL, NULL, NULL}},
     run_snapshot},
    {"watch", O_SESSION | O_SIZE | O_FRAMES | O_ENCODING | O_DOWNSCALE, 0, 0,
     "--session NAME [--frames N] [--size WxH]",
     "print a line per frame the session sends",
     "Joins session NAME as a viewer and prints one line per frame:\n"
     "  frame K no=SERVER_FRAME_NO order=EDIT_ORDER bytes=B rects=R\n"
     "  image=WxH level=N still|interactive latency_ms=L after=edit|view|-\n"
     "level is the frame's refinement level (0: full resolution; N: one\n"
     "pixel per 2^N block, finer frames follow). latency_ms is measured\n"
     "on this client: from the arrival of the newest change the frame\n"
     "shows (the EDIT_APPLIED or SCENE_STATE of its edit order; for the\n"
     "first frame, our VIEW request) to the arrival of the frame. It\n"
     "covers the server's render, encode and send, not the editor's\n"
     "upload; frames that show nothing new (a finer level, a still after\n"
     "interactive frames) print '-'. Other lines name the members and\n"
     "who changed the scene:\n"
     "  members 2: \"alice\" (editor, 4), \"blobcast-cli\" (viewer, 7, this "
     "client)\n"
     "  edit order=5 by=\"alice\" member=4 ops=1 [interacting]\n"
     "  undo order=6 of=5 by=\"bob\" author=\"alice\" member=9 ops=1\n"
     "  redo order=7 of=5 by=\"alice\" author=\"alice\" member=4 ops=1\n"
     "  load order=8 by=\"alice\" member=4\n"
     "  camera order=9 by=\"alice\" member=4   (the session camera)\n"
     "  presenter member=4 name=\"alice\" | presenter none\n"
     "(undo and redo: edit ORDER by member BY takes back, or applies\n"
     "again, edit OF whose author was AUTHOR).\n"
     "A lost connection prints 'lost reason=CODE' and is retried every\n"
     "0.25 s, doubling up to 4 s, then 'rejoined session=NAME'; a refused\n"
     "token or a missing session ends the run instead. At the end one\n"
     "'stats' line gives the server's averages and end=frames (N frames\n"
     "came), end=timeout or end=stopped (Ctrl-C, SIGTERM).",
     NULL, run_watch},
    {"bench-latency",
     O_SESSION | O_SIZE | O_EDITS | O_NODE | O_ENCODING | O_INTERACTING |
         O_DOWNSCALE,
     0, 0, "--session NAME --edits N [--size WxH]",
     "measure edit-to-frame latency (prints JSON)",
     "Moves one primitive back and forth by 0.05 in x, N times, each time\n"
     "waiting for the first frame whose edit order includes the edit,\n"
     "and prints one JSON line: p50_ms, p99_ms, mean_ms, min_ms, max_ms\n"
     "of edit sent -> frame received, frames and bytes_per_frame (mean\n"
     "over every frame received during the run), and the server's render,\n"
     "encode and edit averages. The primitive is put back at the end.",
     NULL, run_bench},
    {"nodes", O_SESSION | O_JSON, 0, 0, "--session NAME [--json]",
     "list a session's nodes: id, type, parent, parameters",
     "Joins session NAME as a viewer and lists its scene's nodes in\n"
     "pre-order, one line each: id, type, parent id ('-' for the root),\n"
     "then the parameters with the keys 'blobcast edit' takes (operators:\n"
     "children=N and, when smooth, blend and range; primitives: their\n"
     "kind's parameters, translate and rotate unless at rest, color when\n"
     "set). Floats are printed so that they read back exactly.",
     (const struct opt_text[]){{"json", NULL,
                                "one JSON array instead: objects with id, "
                                "type,\nparent (0 for the root), children "
                                "(operators) and\nevery parameter, "
                                "translate and rotate included"},
                               {NULL, NULL, NULL}},
     run_nodes},
    {"scene", O_SESSION | O_OUT, 0, 0, "--session NAME [--out FILE]",
     "write a session's scene as a JSON scene file",
     "Joins session NAME as a viewer and writes its scene, with the\n"
     "session's camera, as a JSON scene file (docs/scene-format.md) that\n"
     "'blobcast load' takes back unchanged: every id and float is kept.",
     (const struct opt_text[]){{"out", "FILE",
                                "write to FILE (atomically) instead of "
                                "stdout\n(\"-\": stdout)"},
                               {NULL, NULL, NULL}},
     run_scene},
    {"delete", O_SESSION, 0, 0, "--session NAME",
     "delete a session and its saved scene",
     "Deletes session NAME on the server: its members are sent back out\n"
     "of it (they stay connected), its scene and edits are no longer\n"
     "served, and a later 'load' or join of that name starts anew. The\n"
     "server keeps the files aside (docs/operations.md). Needs a token\n"
     "granting the editor role when the server has tokens.",
     NULL, run_delete},
    {"sessions", O_JSON, 0, 0, "[--json]", "list the server's sessions",
     "Lists every session of the server by name: connected members,\n"
     "primitives, last edit order, when it last changed (UTC) and whether\n"
     "it is loaded or only on disk. For a session on disk that the server\n"
     "has not loaded since it started, '-' stands for what it does not\n"
     "know without loading it. At most 1024 sessions are listed.",
     (const struct opt_text[]){{"json", NULL,
                                "one JSON array of objects: name, "
                                "members, loaded\nand, when known, "
                                "primitives, order, last_edit_ms"},
                               {NULL, NULL, NULL}},
     run_sessions},
    {"undo", O_SESSION, 0, 0, "--session NAME",
     "take back the session's newest change, whoever made it",
     "Undoes the newest change of session NAME that is not undone yet:\n"
     "a parameter edit, a structural edit, or a whole drag. It is applied\n"
     "as an edit of its own, seen by every member, and prints\n"
     "  undid edit ORDER by \"AUTHOR\": edit order NEW\n"
     "Exit status 1 with ESTATE when there is nothing to undo (the\n"
     "history starts at the last load or restart, 100 steps deep).",
     NULL, run_undo},
    {"redo", O_SESSION, 0, 0, "--session NAME",
     "apply again the change undone last",
     "Redoes the change undone last in session NAME, as 'undo' takes it\n"
     "back; a new edit in between leaves nothing to redo.",
     NULL, run_undo},
};

static const struct cmd *find_cmd(const char *name)
{
	for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
		if (strcmp(cmds[i].name, name) == 0) {
			return &cmds[i];
		}
	}
	return NULL;
}

void bc_cli_client_usage(FILE *out)
{
	for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
		fprintf(out, "  %-14s %s\n", cmds[i].name, cmds[i].summary);
	}
}

static const struct bc_opt_name encoding_names[] = {
    {"jpeg", BC_PROTO_ENC_JPEG},
    {"png", BC_PROTO_ENC_PNG},
    {"raw", BC_PROTO_ENC_RAW},
    {NULL, 0},
};

/* Where the table parses to; copied into struct args after the checks
 * that the table cannot make. */
struct parsed {
	uint32_t size[2];
	uint32_t timeout_ms, edits, node, downscale;
	float eye[3], target[3], up[3], fov;
	int encoding;
};

/* Most options of the table below. */
#define MAX_OPTS 24

/*
 * One table of every client command's options: the command-specific ones,
 * then the common ones (need 0). need[i] is the O_ bit a command's mask
 * must hold for opts[i]; options of other commands stay in the table, so
 * that giving one is refused as not applying (not as unknown), but are
 * hidden from this command's help. Returns the number of options.
 */
static int client_opts(const struct cmd *k, struct args *a, struct parsed *p,
                       struct bc_opt opts[MAX_OPTS + 1],
                       unsigned need[MAX_OPTS])
{
	const struct {
		unsigned need;
		struct bc_opt opt;
	} all[] = {
	    {O_SESSION,
	     {.name = "session",
	      .kind = BC_OPT_STRING,
	      .dst = &a->session,
	      .arg = "NAME",
	      .help = "the session (1..64 bytes; required)"}},
	    {O_SIZE,
	     {.name = "size",
	      .kind = BC_OPT_SIZE,
	      .dst = p->size,
	      .lo = 1,
	      .hi = BC_PROTO_MAX_DIM,
	      .arg = "WxH",
	      .help = "view size, each {range} (default 640x480)"}},
	    {O_FRAMES,
	     {.name = "frames",
	      .kind = BC_OPT_U64,
	      .dst = &a->frames,
	      .lo = 1,
	      .hi = 18446744073709551616.0,
	      .arg = "N",
	      .help = "stop after N frames ({range}; default: run until\n"
	              "stopped); give up when no frame came for --timeout\n"
	              "MS (default 10000; 0: never), exit status 1"}},
	    {O_FOR,
	     {.name = "for",
	      .kind = BC_OPT_U64,
	      .dst = &a->for_s,
	      .lo = 1,
	      .hi = 86400,
	      .arg = "SECONDS",
	      .help = "present for SECONDS ({range}; default: until\n"
	              "Ctrl-C or SIGTERM)"}},
	    {O_EDITS,
	     {.name = "edits",
	      .kind = BC_OPT_U32,
	      .dst = &p->edits,
	      .lo = 1,
	      .hi = MAX_BENCH_EDITS,
	      .arg = "N",
	      .help = "number of edits ({range}; required)"}},
	    {O_NODE,
	     {.name = "node",
	      .kind = BC_OPT_U32,
	      .dst = &p->node,
	      .lo = 1,
	      .hi = UINT32_MAX,
	      .arg = "ID",
	      .help = "primitive to move (default: the first one)"}},
	    {O_ENCODING,
	     {.name = "encoding",
	      .kind = BC_OPT_ENUM,
	      .dst = &p->encoding,
	      .arg = "E",
	      .names = encoding_names,
	      .help = "{choices} for still frames (default jpeg)"}},
	    {O_DOWNSCALE,
	     {.name = "downscale",
	      .kind = BC_OPT_U32,
	      .dst = &p->downscale,
	      .lo = 1,
	      .hi = BC_PROTO_MAX_DOWNSCALE,
	      .arg = "D",
	      .help = "coarsest block accepted ({range}): refinement\n"
	              "frames at 1/2^n resolution with 2^n <= D\n"
	              "(default 1)"}},
	    {O_INTERACTING,
	     {.name = "interacting",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->interacting,
	      .help = "send the edits as a drag (interactive frames)"}},
	    {O_OUT,
	     {.name = "out",
	      .kind = BC_OPT_STRING,
	      .dst = &a->out,
	      .arg = "IMG",
	      .help = "write the picture to IMG"}},
	    {O_DEPTH,
	     {.name = "depth",
	      .kind = BC_OPT_STRING,
	      .dst = &a->depth,
	      .arg = "IMG",
	      .help = "also write the ray distance per pixel as one\n"
	              "float channel (+inf where nothing is hit; .exr,\n"
	              ".tif or .pfm)"}},
	    {O_IDS,
	     {.name = "ids",
	      .kind = BC_OPT_STRING,
	      .dst = &a->ids,
	      .arg = "IMG",
	      .help = "also write the node id of the primitive seen per\n"
	              "pixel as one uint32 channel (0 where nothing is\n"
	              "hit; .tif or .exr)"}},
	    {O_EYE,
	     {.name = "eye",
	      .kind = BC_OPT_VEC3,
	      .dst = p->eye,
	      .arg = "x,y,z",
	      .help = "camera position"}},
	    {O_TARGET,
	     {.name = "target",
	      .kind = BC_OPT_VEC3,
	      .dst = p->target,
	      .arg = "x,y,z",
	      .help = "the point the camera looks at"}},
	    {O_UP,
	     {.name = "up",
	      .kind = BC_OPT_VEC3,
	      .dst = p->up,
	      .arg = "x,y,z",
	      .help = "camera up direction"}},
	    {O_FOV,
	     {.name = "fov",
	      .kind = BC_OPT_F32,
	      .dst = &p->fov,
	      .lo = 0,
	      .hi = 180,
	      .arg = "DEG",
	      .help = "vertical field of view in degrees (between 0\n"
	              "and 180)"}},
	    {O_JSON,
	     {.name = "json",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->json,
	      .help = "print JSON"}},
	    {0,
	     {.name = "server",
	      .kind = BC_OPT_STRING,
	      .dst = &a->server,
	      .arg = "ADDR",
	      .help = "HOST:PORT, [IPV6]:PORT or unix:PATH (default\n"
	              "$BLOBCAST_SERVER, else 127.0.0.1:7878);\n"
	              "tls://HOST:PORT for TLS; wss://HOST/PATH through\n"
	              "a WebSocket proxy (docs/deploy.md)"}},
	    {0,
	     {.name = "ca",
	      .kind = BC_OPT_STRING,
	      .dst = &a->ca,
	      .arg = "FILE",
	      .help = "TLS: trust the CA certificates in FILE (PEM)\n"
	              "instead of the system's"}},
	    {0,
	     {.name = "insecure",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->insecure,
	      .help = "TLS: do not check the server's certificate"}},
	    {0,
	     {.name = "token",
	      .kind = BC_OPT_STRING,
	      .dst = &a->token,
	      .arg = "TOKEN",
	      .flags = BC_OPT_EMPTY,
	      .help = "authentication token (default $BLOBCAST_TOKEN;\n"
	              "not needed over loopback or a Unix socket unless\n"
	              "the server requires one)"}},
	    {0,
	     {.name = "name",
	      .kind = BC_OPT_STRING,
	      .dst = &a->name,
	      .arg = "NAME",
	      .flags = BC_OPT_EMPTY,
	      .help = "client name shown to other members (0..64 bytes)"}},
	    {0,
	     {.name = "timeout",
	      .kind = BC_OPT_U32,
	      .dst = &p->timeout_ms,
	      .lo = 0,
	      .hi = 86400000,
	      .arg = "MS",
	      .help = "limit for connecting and for each answer\n"
	              "({range}; default 10000; 0 waits forever)"}},
	};
	int n = (int)(sizeof(all) / sizeof(all[0]));
	_Static_assert(sizeof(all) / sizeof(all[0]) <= MAX_OPTS,
	               "MAX_OPTS is too small");
	for (int i = 0; i < n; i++) {
		opts[i] = all[i].opt;
		need[i] = all[i].need;
		if (need[i] && !(k->opts & need[i])) {
			opts[i].flags |= BC_OPT_HIDDEN;
		}
		for (const struct opt_text *t = k->texts; t && t->name; t++) {
			if (strcmp(t->name, opts[i].name) == 0) {
				opts[i].help = t->help;
				if (t->arg) {
					opts[i].arg = t->arg;
				}
			}
		}
	}
	opts[n] = (struct bc_opt){.kind = BC_OPT_INVALID};
	return n;
}

/* Checks what the table cannot and copies p into a; 0 or EXIT_USAGE after
 * printing why. */
static int check_opts(const struct bc_args *pa, struct args *a,
                      const struct parsed *p)
{
	struct {
		const char *name;
		const float *v;
		float *dst;
		bool *has;
	} vecs[] = {{"eye", p->eye, a->cam.eye, &a->has_eye},
	            {"target", p->target, a->cam.target, &a->has_target},
	            {"up", p->up, a->cam.up, &a->has_up}};
	if (a->server) {
		struct bc_client_addr addr;
		struct bc_errinfo ei = {0};
		if (bc_client_addr_parse(a->server, &addr, &ei)) {
			return bc_args_error(pa, "--server: %s", ei.msg);
		}
	}
	if (a->session && strlen(a->session) > BC_PROTO_MAX_NAME) {
		return bc_args_error(pa, "--session is longer than %u bytes",
		                     BC_PROTO_MAX_NAME);
	}
	if (a->name && strlen(a->name) > BC_PROTO_MAX_NAME) {
		return bc_args_error(pa, "--name is longer than %u bytes",
		                     BC_PROTO_MAX_NAME);
	}
	for (size_t i = 0; i < sizeof(vecs) / sizeof(vecs[0]); i++) {
		if (!bc_args_given(pa, vecs[i].name)) {
			continue;
		}
		for (int j = 0; j < 3; j++) {
			if (fabsf(vecs[i].v[j]) > BC_PROTO_MAX_ABS) {
				return bc_args_error(
				    pa, "--%s is out of range (each |x| <= %g)",
				    vecs[i].name, (double)BC_PROTO_MAX_ABS);
			}
		}
		memcpy(vecs[i].dst, vecs[i].v, 3 * sizeof(float));
		*vecs[i].has = true;
	}
	if (bc_args_given(pa, "fov")) {
		/* The table's range includes its ends; a camera's does not. */
		if (p->fov <= 0.0f || p->fov >= 180.0f) {
			return bc_args_error(pa,
			                     "--fov '%g' is out of range (more "
			                     "than 0, less than 180)",
			                     (double)p->fov);
		}
		a->cam.fov_y_deg = p->fov;
		a->has_fov = true;
	}
	if (bc_args_given(pa, "timeout")) {
		a->timeout_ms = p->timeout_ms == 0 ? -1 : (int)p->timeout_ms;
	}
	a->has_size = bc_args_given(pa, "size");
	a->width = a->has_size ? (uint16_t)p->size[0] : 640;
	a->height = a->has_size ? (uint16_t)p->size[1] : 480;
	a->edits = bc_args_given(pa, "edits") ? p->edits : 0;
	a->node = bc_args_given(pa, "node") ? p->node : 0;
	a->downscale =
	    bc_args_given(pa, "downscale") ? (uint8_t)p->downscale : 0;
	a->encoding = bc_args_given(pa, "encoding")
	                  ? (enum bc_proto_encoding)p->encoding
	                  : BC_PROTO_ENC_INVALID;
	return 0;
}

int bc_cli_client(const char *subcommand, int argc, char **argv)
{
	const struct cmd *k = find_cmd(subcommand);
	struct bc_opt opts[MAX_OPTS + 1];
	unsigned need[MAX_OPTS];
	char prog[64], usage[256], about[4096];
	struct parsed p = {.size = {640, 480},
	                   .timeout_ms = 10000,
	                   .edits = 0,
	                   .downscale = 1,
	                   .encoding = BC_PROTO_ENC_JPEG};
	struct bc_args pa = {0};
	struct args a;
	int nopts, status;
	if (!k) {
		fprintf(stderr, "blobcast: '%s' is not a client command\n",
		        subcommand);
		return EXIT_USAGE;
	}
	memset(&a, 0, sizeof(a));
	a.cmd = k->name;
	bc_camera_default(&a.cam);
	nopts = client_opts(k, &a, &p, opts, need);
	snprintf(prog, sizeof(prog), "blobcast %s", k->name);
	snprintf(usage, sizeof(usage), "blobcast %s %s [options]", k->name,
	         k->synopsis);
	snprintf(about, sizeof(about), "%s\n\n%s", k->summary, k->help);
	pa.prog = prog;
	pa.usage = usage;
	pa.about = about;
	pa.footer = "exit status: 0 done, 1 the server refused, 2 usage "
	            "error, 3 network\n(cannot connect, TLS, timeout, closed, "
	            "not a blobcastd), 4 authentication\n(token, role)";
	pa.opts = opts;
	if (bc_cli_args_parse(&pa, argc, argv)) {
		return pa.status;
	}
	for (int i = 0; i < nopts; i++) {
		if (((pa.seen >> i) & 1u) && need[i] && !(k->opts & need[i])) {
			return bc_args_error(&pa, "--%s does not apply to %s",
			                     opts[i].name, k->name);
		}
	}
	if (pa.npos > k->max_pos) {
		return bc_args_error(&pa, "unexpected argument '%s'",
		                     pa.pos[k->max_pos]);
	}
	if (pa.npos < k->min_pos) {
		return bc_args_error(&pa, "missing arguments (usage: %s %s)",
		                     prog, k->synopsis);
	}
	if ((k->opts & O_SESSION) && !a.session) {
		return bc_args_error(&pa, "--session NAME is required");
	}
	if ((status = check_opts(&pa, &a, &p))) {
		return status;
	}
	for (int i = 0; i < pa.npos; i++) {
		a.pos[i] = pa.pos[i];
	}
	a.npos = pa.npos;
	return k->run(&a);
}
