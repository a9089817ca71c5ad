/*
 * What the client commands share (cmd_client.h): connecting and joining
 * with the options given, reporting a failure with its hint and exit
 * status, the camera the options describe, the Ctrl-C and SIGTERM
 * handling of the long-running commands, and the words for a frame.
 */
#include "cmd_client.h"

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/client.h"
#include "cli.h"

/* Prints a failure of the server or the connection (on c, NULL while
 * connecting) and what to do about it; returns its exit status
 * (bc_cli_exit_for). */
int bc_cli_failed(const struct bc_cli_call *a, const struct bc_client *c,
                  const char *what, const struct bc_errinfo *ei)
{
	enum bc_cli_stage stage =
	    c ? BC_CLI_STAGE_SESSION : BC_CLI_STAGE_CONNECT;
	const char *hint = bc_cli_hint(ei->code, stage, ei->msg);
	size_t wl = what ? strlen(what) : 0;
	if (what && strncmp(ei->msg, what, wl) == 0 && ei->msg[wl] == ':') {
		what = NULL; /* the server's text says it already */
	}
	fprintf(stderr, "blobcast %s: %s%s%s (%s)\n", a->cmd, what ? what : "",
	        what ? ": " : "", ei->msg[0] ? ei->msg : bc_strerror(ei->code),
	        bc_err_name(ei->code));
	if (hint) {
		fprintf(stderr, "blobcast %s: %s\n", a->cmd, hint);
	}
	return bc_cli_exit_for(ei->code, stage,
	                       c && bc_client_error(c, NULL) != 0);
}

/* A receive or send that failed: its reason is the connection's sticky
 * error (bc_client_error). */
int bc_cli_conn_failed(const struct bc_cli_call *a, const struct bc_client *c,
                       const char *what)
{
	struct bc_errinfo ei = {0};
	bc_client_error(c, &ei);
	return bc_cli_failed(a, c, what, &ei);
}

/* The connection the options ask for: --server, --token (or their
 * environment variables), --name, --timeout, --ca, --insecure. */
struct bc_client_opts bc_cli_connect_opts(const struct bc_cli_call *a)
{
	return (struct bc_client_opts){
	    .addr = a->server ? a->server : getenv("BLOBCAST_SERVER"),
	    .name = a->name ? a->name : "blobcast-cli",
	    .token = a->token ? a->token : getenv("BLOBCAST_TOKEN"),
	    .timeout_ms = a->timeout_ms,
	    .ca_file = a->ca,
	    .insecure = a->insecure,
	    /* No command draws from the mirror (mesh copies it). */
	    .bare_scene = true,
	    .encodings = a->encoding == BC_PROTO_ENC_H264
	                     ? BC_PROTO_ENCODINGS_ALL
	                     : BC_PROTO_ENCODINGS_IMAGES};
}

int bc_cli_connect(const struct bc_cli_call *a, struct bc_client **c)
{
	struct bc_errinfo ei = {0};
	struct bc_client_opts opts = bc_cli_connect_opts(a);
	if (bc_client_connect(c, &opts, &ei)) {
		return bc_cli_failed(a, NULL, NULL, &ei);
	}
	return 0;
}

/* Connects and enters the session; viewers unless the command edits. */
int bc_cli_open_session(const struct bc_cli_call *a, enum bc_proto_role role,
                        enum bc_client_join_mode mode, struct bc_client **c)
{
	struct bc_errinfo ei = {0};
	int status = bc_cli_connect(a, c);
	if (status) {
		return status;
	}
	if (bc_client_join(*c, a->session, role, mode, &ei)) {
		char what[128];
		snprintf(what, sizeof(what), "session %s", a->session);
		return bc_cli_failed(a, *c, what, &ei);
	}
	return 0;
}

/* Overrides the parts of cam that the options give. */
void bc_cli_apply_camera(const struct bc_cli_call *a, struct bc_camera *cam)
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
 * none) changed by the options. Returns 0, or BC_CLI_EXIT_USAGE after saying
 * why the result is not a camera. */
int bc_cli_camera_from_opts(const struct bc_cli_call *a,
                            const struct bc_client *c, struct bc_camera *cam)
{
	struct bc_errinfo ei = {0};
	if (!bc_client_scene(c, cam)) {
		bc_camera_default(cam);
	}
	bc_cli_apply_camera(a, cam);
	if (bc_camera_validate(cam, &ei)) {
		fprintf(stderr, "blobcast %s: %s\n", a->cmd, ei.msg);
		return BC_CLI_EXIT_USAGE;
	}
	return 0;
}

/* Set by SIGINT and SIGTERM while a long-running command (watch, present,
 * follow) runs, to end its loop cleanly (bc_cli_stop_install). */
static volatile sig_atomic_t interrupted;

static void on_interrupt(int sig)
{
	(void)sig;
	interrupted = 1;
}

void bc_cli_stop_install(struct bc_cli_stop *s)
{
	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_interrupt;
	sigemptyset(&sa.sa_mask);
	interrupted = 0;
	sigaction(SIGINT, &sa, &s->old_int);
	sigaction(SIGTERM, &sa, &s->old_term);
}

void bc_cli_stop_restore(const struct bc_cli_stop *s)
{
	sigaction(SIGINT, &s->old_int, NULL);
	sigaction(SIGTERM, &s->old_term, NULL);
}

bool bc_cli_stopped(void)
{
	return interrupted != 0;
}

/* How long watch and follow wait for each frame when --frames asks for a
 * count, in ms; negative waits forever (--timeout -1). */
double bc_cli_frame_idle_limit(const struct bc_cli_call *a)
{
	return a->timeout_ms < 0    ? -1.0
	       : a->timeout_ms == 0 ? (double)BC_CLIENT_DEFAULT_TIMEOUT_MS
	                            : (double)a->timeout_ms;
}

/* Reports a run of --frames N that ended because no frame came within
 * idle_limit ms; returns the exit status for it. */
int bc_cli_frames_timed_out(const struct bc_cli_call *a, uint64_t nframes,
                            double idle_limit)
{
	fprintf(stderr,
	        "blobcast %s: timed out: %llu of %llu frames, none "
	        "for %.0f ms (--timeout)\n",
	        a->cmd, (unsigned long long)nframes,
	        (unsigned long long)a->frames, idle_limit);
	return BC_CLI_EXIT_FAIL;
}

/* Reports the server's ERROR message m the way bc_cli_failed() reports our own
 * errors; returns the exit status for it. */
int bc_cli_server_failed(const struct bc_cli_call *a, const struct bc_client *c,
                         const struct bc_msg *m)
{
	struct bc_errinfo ei = {0};
	ei.code = -(int)m->error.code;
	snprintf(ei.msg, sizeof(ei.msg), "%.*s", (int)m->error.text.len,
	         m->error.text.ptr);
	return bc_cli_failed(a, c, NULL, &ei);
}

const char *bc_cli_frame_kind(uint16_t flags)
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
