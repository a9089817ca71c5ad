/*
 * The `blobcast` subcommands that talk to a blobcastd through libblobcast:
 * load, edit, camera, present, follow, snapshot, watch, bench-latency,
 * nodes, scene, delete, sessions, undo, redo, history and the modelling
 * verbs add, remove, move, wrap, duplicate and rename. main.c calls the first
 * two functions; the rest is shared by the commands' files (cmd_client.c
 * parses the options, client_common.c holds the helpers).
 */
#ifndef BLOBCAST_CLI_CMD_CLIENT_H
#define BLOBCAST_CLI_CMD_CLIENT_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "blobcast/client.h"
#include "cli.h"

/* Runs one client subcommand. argv[0] is the subcommand's name (the same
 * string as subcommand); argv[1..argc) are its arguments, where
 * `--server ADDR` may appear anywhere (main passes a global --server that
 * way; a later one wins). Output goes to stdout, messages to stderr.
 * Returns the process exit status: 0 on success (and for --help), 1 when
 * the server or the connection fails (the server's ERROR text is printed),
 * 2 for a usage error (worded like every command's, blobcast/args.h). */
int bc_cli_client(const char *subcommand, int argc, char **argv);

/* Prints one help line per client subcommand, for the overview. */
void bc_cli_client_usage(FILE *out);

/* ---- shared by the client commands' files -------------------------------- */

/* A failure that is neither the server's answer nor the network's (out of
 * memory, a file that cannot be written, too few frames): status 1. */
#define BC_CLI_EXIT_FAIL BC_CLI_EXIT_REFUSED

/* Positional arguments a subcommand may take: edit's node id and one
 * key=value per field is the most. */
#define BC_CLI_MAX_POSITIONAL (1 + BC_CLIENT_MAX_EDIT_ARGS)
/* watch, present and follow: the client's poll slice, so that Ctrl-C is
 * noticed promptly. */
#define BC_CLI_SLICE_MS 200

/* Options; each subcommand accepts the common ones (need 0 in the table)
 * and those in its mask. */
enum {
	BC_CLI_O_SESSION = 1u << 0,
	BC_CLI_O_SIZE = 1u << 1,
	BC_CLI_O_OUT = 1u << 2,
	BC_CLI_O_DEPTH = 1u << 3,
	BC_CLI_O_EYE = 1u << 4,
	BC_CLI_O_TARGET = 1u << 5,
	BC_CLI_O_UP = 1u << 6,
	BC_CLI_O_FOV = 1u << 7,
	BC_CLI_O_FRAMES = 1u << 8,
	BC_CLI_O_EDITS = 1u << 9,
	BC_CLI_O_NODE = 1u << 10,
	BC_CLI_O_ENCODING = 1u << 11,
	BC_CLI_O_INTERACTING = 1u << 12,
	BC_CLI_O_DOWNSCALE = 1u << 13,
	BC_CLI_O_IDS = 1u << 14,
	BC_CLI_O_JSON = 1u << 15,
	BC_CLI_O_FOR = 1u << 16,
	BC_CLI_O_TILE = 1u << 17,
	BC_CLI_O_PARENT = 1u << 18,
	BC_CLI_O_POSITION = 1u << 19,
	BC_CLI_O_AT = 1u << 20,
	BC_CLI_O_CHILD = 1u << 21,
	BC_CLI_O_OFFSET = 1u << 22,
	BC_CLI_O_ANY = 1u << 23,
	BC_CLI_O_RECORD = 1u << 24,
	BC_CLI_O_BINARY = 1u << 25,
};
#define BC_CLI_O_CAMERA                                                        \
	(BC_CLI_O_EYE | BC_CLI_O_TARGET | BC_CLI_O_UP | BC_CLI_O_FOV)

/* One call of a client command: its options, checked (cmd_client.c), and
 * its positional arguments. */
struct bc_cli_call {
	const char *cmd;
	const char *server, *token, *name, *session, *out, *depth, *ids;
	const char *ca;     /* --ca: TLS trust anchors */
	const char *record; /* watch --record: the H.264 file, or NULL */
	bool insecure;      /* --insecure: no TLS certificate checks */
	int timeout_ms;
	uint16_t width, height;
	bool has_size;
	struct bc_camera cam;
	bool has_eye, has_target, has_up, has_fov;
	uint64_t frames;
	uint64_t for_s; /* present --for SECONDS; 0: until stopped */
	uint32_t edits, node;
	uint32_t tile; /* snapshot --tile: tile edge, 0: as the size needs */
	enum bc_proto_encoding encoding;
	bool interacting, json;
	bool binary; /* scene --binary: a binary scene file */
	bool any; /* undo, redo --any: the session's change, whoever made it */
	uint8_t downscale;
	/* The modelling verbs (cmd_model.c): --parent (0: not given), and
	 * --position, --at, --child, --offset as typed (NULL: not given). */
	uint32_t parent;
	const char *position, *at, *child, *offset;
	const char *pos[BC_CLI_MAX_POSITIONAL];
	int npos;
};

/* A command's own wording of a shared option ("--out" is an image for
 * snapshot, a scene file for scene); NULL arg keeps the table's. */
struct bc_cli_opt_text {
	const char *name, *arg, *help;
};

/* A client command: its name, the options it takes (a mask of BC_CLI_O_*),
 * how many positional arguments, its help, and what runs it. */
struct bc_cli_cmd {
	const char *name;
	unsigned opts;
	int min_pos, max_pos;
	const char *synopsis;
	const char *summary;
	const char *help; /* what the subcommand does */
	/* Ends with a NULL name; may be NULL. */
	const struct bc_cli_opt_text *texts;
	int (*run)(struct bc_cli_call *a);
};

/* The commands, each defined next to its run function. */
extern const struct bc_cli_cmd bc_cli_cmd_load;
extern const struct bc_cli_cmd bc_cli_cmd_edit;
extern const struct bc_cli_cmd bc_cli_cmd_camera;
extern const struct bc_cli_cmd bc_cli_cmd_present;
extern const struct bc_cli_cmd bc_cli_cmd_follow;
extern const struct bc_cli_cmd bc_cli_cmd_snapshot;
extern const struct bc_cli_cmd bc_cli_cmd_watch;
extern const struct bc_cli_cmd bc_cli_cmd_bench_latency;
extern const struct bc_cli_cmd bc_cli_cmd_nodes;
extern const struct bc_cli_cmd bc_cli_cmd_scene;
extern const struct bc_cli_cmd bc_cli_cmd_delete;
extern const struct bc_cli_cmd bc_cli_cmd_sessions;
extern const struct bc_cli_cmd bc_cli_cmd_undo;
extern const struct bc_cli_cmd bc_cli_cmd_redo;
extern const struct bc_cli_cmd bc_cli_cmd_add;
extern const struct bc_cli_cmd bc_cli_cmd_remove;
extern const struct bc_cli_cmd bc_cli_cmd_move;
extern const struct bc_cli_cmd bc_cli_cmd_wrap;
extern const struct bc_cli_cmd bc_cli_cmd_duplicate;
extern const struct bc_cli_cmd bc_cli_cmd_rename;
extern const struct bc_cli_cmd bc_cli_cmd_history;

/* Prints a failure of the server or the connection (on c, NULL while
 * connecting) and what to do about it; returns its exit status
 * (bc_cli_exit_for). */
int bc_cli_failed(const struct bc_cli_call *a, const struct bc_client *c,
                  const char *what, const struct bc_errinfo *ei);

/* Reports the connection's own error (bc_client_error(), after a receive
 * or send that failed) the way bc_cli_failed() does, with what in front
 * when not NULL; returns the exit status for it. */
int bc_cli_conn_failed(const struct bc_cli_call *a, const struct bc_client *c,
                       const char *what);

/* Reports the server's ERROR message m the way bc_cli_failed() reports our
 * own errors; returns the exit status for it. */
int bc_cli_server_failed(const struct bc_cli_call *a, const struct bc_client *c,
                         const struct bc_msg *m);

/* The connection the options ask for: --server, --token (or their
 * environment variables), --name, --timeout, --ca, --insecure, and H.264
 * announced in HELLO with --encoding h264 (only then: a server of a text
 * before H.264 refuses a HELLO that announces it). */
struct bc_client_opts bc_cli_connect_opts(const struct bc_cli_call *a);

/* Connects as the options say; 0, or the exit status after saying why. */
int bc_cli_connect(const struct bc_cli_call *a, struct bc_client **c);

/* Connects and enters the session; viewers unless the command edits.
 * Returns 0, or the exit status after saying why; *c is the connection
 * either way (NULL when there is none), for the caller to destroy. */
int bc_cli_open_session(const struct bc_cli_call *a, enum bc_proto_role role,
                        enum bc_client_join_mode mode, struct bc_client **c);

/* Overrides the parts of cam that the options give. */
void bc_cli_apply_camera(const struct bc_cli_call *a, struct bc_camera *cam);

/* Sets cam to the session's camera (the default one when the scene has
 * none) changed by the options. Returns 0, or BC_CLI_EXIT_USAGE after
 * saying why the result is not a camera. */
int bc_cli_camera_from_opts(const struct bc_cli_call *a,
                            const struct bc_client *c, struct bc_camera *cam);

/* A long-running command (watch, present, follow) routes SIGINT and
 * SIGTERM to a flag, to end its loop cleanly, and puts back the handlers
 * it found when it ends. */
struct bc_cli_stop {
	struct sigaction old_int, old_term;
};
void bc_cli_stop_install(struct bc_cli_stop *s);
void bc_cli_stop_restore(const struct bc_cli_stop *s);
/* Whether SIGINT or SIGTERM came since bc_cli_stop_install(). */
bool bc_cli_stopped(void);

/* How long watch and follow wait for each frame when --frames asks for a
 * count, in ms; negative waits forever (--timeout -1). */
double bc_cli_frame_idle_limit(const struct bc_cli_call *a);

/* Reports a run of --frames N that ended because no frame came within
 * idle_limit ms; returns the exit status for it. */
int bc_cli_frames_timed_out(const struct bc_cli_call *a, uint64_t nframes,
                            double idle_limit);

/* "still", "interactive", "snapshot", with " incomplete" when the
 * server's time budget stopped refinement: the words for a frame's flags. */
const char *bc_cli_frame_kind(uint16_t flags);

#endif
