/*
 * `blobcast watch`: joins a session as a viewer and prints a line per
 * frame, with the latency this client can measure, and a line per member
 * list, change and presenter; a lost connection is joined again. It owns
 * the arrival times that frames are measured against and the --record
 * file of an H.264 stream; the authors of changes are named from the
 * library's roster (bc_client_members).
 */
#include "cmd_client.h"

#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/clock.h"

/* Edit orders whose arrival time is remembered for the latency of
 * the frame that shows them (frames lag edits by a few at most). */
#define WATCH_ORDERS 256u

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

/* "members 3: alice (editor, 4), blobcast-cli (viewer, 7, this client)",
 * from the library's roster of the session. */
static void print_members(const struct bc_client *c)
{
	const struct bc_client_member *list;
	uint32_t self = bc_client_info(c)->member_id;
	size_t n;
	bc_client_members(c, &list, &n);
	printf("members %zu:", n);
	for (size_t i = 0; i < n; i++) {
		printf("%s \"%s\" (%s, %u%s)", i ? "," : "", list[i].name,
		       list[i].role == BC_PROTO_ROLE_EDITOR ? "editor"
		                                            : "viewer",
		       list[i].id, list[i].id == self ? ", this client" : "");
	}
	printf("\n");
}

/* The name member id gave in HELLO, or NULL once it has left. */
static const char *member_name(const struct bc_client *c, uint32_t id)
{
	const struct bc_client_member *e = bc_client_member_find(c, id);
	return e ? e->name : NULL;
}

/* `edit order=5 by="carol" member=20 ops=1`: the author's name comes from
 * the member list (an author who already left prints as ""). */
static void print_change(const struct bc_client *c, const char *what,
                         uint64_t order, uint32_t author, const char *tail)
{
	const char *name = member_name(c, author);
	printf("%s order=%llu by=\"%s\" member=%u%s\n", what,
	       (unsigned long long)order, name ? name : "", author, tail);
}

/* `undo order=6 of=5 by="bob" author="alice" member=20 ops=3` (or redo):
 * edit 6, sent by bob (member 20), takes back (applies again) edit 5, whose
 * author the server names. */
static void print_undo(const struct bc_client *c, const struct bc_msg *m)
{
	const struct bc_msg_edit_applied *e = &m->edit_applied;
	const char *name = member_name(c, e->author);
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
static void print_presenter(const struct bc_client *c, uint32_t id,
                            bool following)
{
	const char *name = member_name(c, id);
	if (!id) {
		printf("presenter none\n");
		return;
	}
	printf("presenter member=%u name=\"%s\"%s\n", id, name ? name : "",
	       following ? " following" : "");
}

/* --record: the access units of an H.264 stream, appended as they come
 * (an Annex B byte stream is its access units one after the other), from
 * a KEY frame on: the file starts with an SPS and a decoder can play it
 * from its start. After a frame this client could not decode (the chain
 * is broken) recording waits for the next KEY frame. */
struct recorder {
	FILE *f;
	const char *path;
	bool keyed; /* a KEY frame started the chain being written */
	uint64_t frames, bytes;
};

/* Containers the file name may ask for that this build cannot write. */
static const char *const containers[] = {".mp4", ".m4v",  ".mov",
                                         ".mkv", ".webm", NULL};

/* Opens --record's file. Returns 0, or the exit status after saying why. */
static int record_open(const struct bc_cli_call *a, struct recorder *r)
{
	const char *ext = strrchr(a->record, '.');
	memset(r, 0, sizeof(*r));
	if (a->encoding != BC_PROTO_ENC_H264) {
		fprintf(stderr, "blobcast watch: --record saves an H.264 "
		                "stream: give --encoding h264 too\n");
		return BC_CLI_EXIT_USAGE;
	}
	for (size_t i = 0; ext && containers[i]; i++) {
		if (strcasecmp(ext, containers[i]) == 0) {
			fprintf(stderr,
			        "blobcast watch: --record %s: this build "
			        "writes raw H.264 only, not %s (it has no "
			        "muxer); record to a .h264 file and wrap it "
			        "later, e.g. ffmpeg -i FILE.h264 -c copy "
			        "FILE%s\n",
			        a->record, ext, ext);
			return BC_CLI_EXIT_USAGE;
		}
	}
	if (!(r->f = fopen(a->record, "wb"))) {
		fprintf(stderr, "blobcast watch: cannot write %s: %s\n",
		        a->record, strerror(errno));
		return BC_CLI_EXIT_FAIL;
	}
	r->path = a->record;
	return 0;
}

/* Appends FRAME m's access unit when it belongs to the stream being
 * recorded. Returns 0, or the exit status after saying why. */
static int record_frame(struct recorder *r, const struct bc_msg *m)
{
	const struct bc_proto_rect *rect = &m->frame.rects[0];
	if (!r->f || m->frame.encoding != BC_PROTO_ENC_H264 ||
	    (m->flags & BC_PROTO_FLAG_SNAPSHOT) || m->frame.nrects != 1) {
		return 0;
	}
	if (m->flags & BC_PROTO_FLAG_KEY) {
		r->keyed = true;
	}
	if (!r->keyed) {
		return 0;
	}
	if (fwrite(rect->data.ptr, 1, rect->data.len, r->f) != rect->data.len) {
		fprintf(stderr, "blobcast watch: writing %s: %s\n", r->path,
		        strerror(errno));
		return BC_CLI_EXIT_FAIL;
	}
	r->frames++;
	r->bytes += rect->data.len;
	return 0;
}

/* Closes the file and prints `record file=PATH frames=N bytes=B`.
 * Returns 0, or the exit status after saying why. */
static int record_close(struct recorder *r, bool report)
{
	int failed;
	if (!r->f) {
		return 0;
	}
	failed = fclose(r->f) != 0;
	r->f = NULL;
	if (failed) {
		fprintf(stderr, "blobcast watch: writing %s: %s\n", r->path,
		        strerror(errno));
		return BC_CLI_EXIT_FAIL;
	}
	if (report) {
		printf("record file=%s frames=%llu bytes=%llu\n", r->path,
		       (unsigned long long)r->frames,
		       (unsigned long long)r->bytes);
	}
	return 0;
}

/* Sends the VIEW the options ask for. */
static int send_view(const struct bc_cli_call *a, struct bc_client *c,
                     struct bc_errinfo *ei)
{
	return bc_client_view(c,
	                      &(struct bc_msg_view){.width = a->width,
	                                            .height = a->height,
	                                            .encoding = a->encoding,
	                                            .downscale = a->downscale},
	                      NULL, ei);
}

/* After joining (the roster is the library's): prints the member list,
 * asks who presents and sends the VIEW, whose time *view_at receives.
 * Returns 0 or a BC_E* code with the reason in ei. */
static int watch_start(const struct bc_cli_call *a, struct bc_client *c,
                       double *view_at, struct bc_errinfo *ei)
{
	int rc;
	print_members(c);
	/* FOLLOW 0 follows nobody; it asks the server to say who presents
	 * (PRESENTER), now and whenever that changes. */
	if ((rc = bc_client_follow(c, false, ei))) {
		return rc;
	}
	print_presenter(c, bc_client_info(c)->presenter, false);
	*view_at = bc_clock_ms();
	return send_view(a, c, ei);
}

/* Connects, joins a->session as a viewer and asks for frames.
 * Returns 0 or a BC_E* code with the reason in ei; *c is set either way
 * (NULL when the connection failed). */
static int watch_open(const struct bc_cli_call *a, struct bc_client **c,
                      double *view_at, struct bc_errinfo *ei)
{
	struct bc_client_opts opts = bc_cli_connect_opts(a);
	int rc;
	if ((rc = bc_client_connect(c, &opts, ei)) ||
	    (rc = bc_client_join(*c, a->session, BC_PROTO_ROLE_VIEWER,
	                         BC_CLIENT_JOIN_EXISTING, ei))) {
		return rc;
	}
	return watch_start(a, *c, view_at, ei);
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
 * retried with the library's doubling delay (bc_client_backoff) and the
 * session joined again (bc_client_rejoin); errors that a retry would meet
 * again (bc_client_retry_useless: a refused token, a missing session) end
 * the run. With --frames N the run also ends when no frame has come for the
 * --timeout (end=timeout, status 1).
 */
static int run_watch(struct bc_cli_call *a)
{
	/* While offline, c is the lost connection, disconnected:
	 * bc_client_rejoin() takes the address, options and session from
	 * it. */
	struct bc_client *c = NULL, *fresh = NULL;
	struct bc_client_backoff backoff;
	bool offline = false;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	struct order_times *times = NULL;
	struct bc_cli_stop sig;
	struct bc_msg m;
	struct bc_msg_stats st;
	struct recorder rec = {0};
	/* An H.264 frame did not decode and VIEW went again: until its KEY
	 * frame comes, frames that fail are expected. */
	bool awaiting_key = false;
	uint64_t nframes = 0, last_order = 0, total_bytes = 0;
	uint64_t joined_at_frame = 0;
	double view_at = 0.0, last_frame_at;
	int rc, status = 0;
	/* --timeout bounds the wait for each frame when --frames asks for a
	 * count; without it watch runs until stopped. */
	double idle_limit = bc_cli_frame_idle_limit(a);
	const char *end = "stopped";
	bc_client_image_init(&img);
	bc_client_backoff_init(&backoff, 0, 0);
	bc_cli_stop_install(&sig);
	if (!(times = bc_calloc(1, sizeof(*times)))) {
		fprintf(stderr, "blobcast watch: out of memory\n");
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (a->record && (status = record_open(a, &rec))) {
		goto out;
	}
	/* The first connection must work: a wrong address or session is a
	 * mistake to report, not to retry. */
	if ((rc = watch_open(a, &c, &view_at, &ei))) {
		status = bc_cli_failed(a, c, NULL, &ei);
		goto out;
	}
	last_frame_at = bc_clock_ms();
	while (!bc_cli_stopped() && (a->frames == 0 || nframes < a->frames)) {
		double at, since;
		const char *after = "-";
		if (a->frames && idle_limit >= 0.0 &&
		    bc_clock_ms() - last_frame_at > idle_limit) {
			end = "timeout";
			break;
		}
		if (offline) {
			/* Reconnecting: wait out the back-off in slices so
			 * that Ctrl-C and the timeout are noticed. */
			if (!bc_client_backoff_due(&backoff, bc_clock_ms())) {
				struct timespec ts = {0, BC_CLI_SLICE_MS *
				                             1000000L};
				nanosleep(&ts, NULL);
				continue;
			}
			memset(&ei, 0, sizeof(ei));
			rc = bc_client_rejoin(c, 0, &fresh, &ei);
			if (!rc) {
				rc = watch_start(a, fresh, &view_at, &ei);
			}
			if (rc && bc_client_retry_useless(rc)) {
				status = bc_cli_failed(a, fresh, "reconnecting",
				                       &ei);
				goto out;
			}
			if (rc) {
				int delay;
				bc_client_destroy(fresh);
				fresh = NULL;
				delay = bc_client_backoff_next(&backoff,
				                               bc_clock_ms());
				fprintf(
				    stderr,
				    "blobcast watch: reconnecting failed: %s "
				    "(%s); next try in %d ms\n",
				    ei.msg, bc_err_name(rc), delay);
				continue;
			}
			bc_client_destroy(c);
			c = fresh;
			fresh = NULL;
			offline = false;
			fprintf(stderr, "blobcast watch: rejoined session %s\n",
			        a->session);
			printf("rejoined session=%s\n", a->session);
			joined_at_frame = nframes;
			last_order = 0;
			/* A new stream: it starts at a KEY frame. */
			rec.keyed = false;
			awaiting_key = false;
		}
		rc = bc_client_recv(c, &m, BC_CLI_SLICE_MS);
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
			if (bc_client_retry_useless(ei.code)) {
				status = bc_cli_failed(a, c, NULL, &ei);
				goto out;
			}
			fprintf(stderr,
			        "blobcast watch: connection lost: %s (%s); "
			        "reconnecting\n",
			        ei.msg[0] ? ei.msg : bc_strerror(ei.code),
			        bc_err_name(ei.code));
			printf("lost reason=%s\n", bc_err_name(ei.code));
			fflush(stdout);
			offline = true;
			bc_client_disconnect(c);
			bc_client_backoff_reset(&backoff, bc_clock_ms());
			continue;
		}
		at = bc_clock_ms();
		switch (m.type) {
		case BC_MSG_SESSION_INFO:
			print_members(c);
			fflush(stdout);
			break;
		case BC_MSG_EDIT_APPLIED: {
			const struct bc_msg_edit_applied *e = &m.edit_applied;
			order_seen(times, e->order, at);
			if (m.flags &
			    (BC_PROTO_FLAG_UNDO | BC_PROTO_FLAG_REDO)) {
				print_undo(c, &m);
			} else {
				char tail[32];
				snprintf(tail, sizeof(tail), " ops=%u%s",
				         e->nops,
				         (m.flags & BC_PROTO_FLAG_INTERACTING)
				             ? " interacting"
				             : "");
				print_change(c, "edit", e->order, e->author,
				             tail);
			}
			fflush(stdout);
			break;
		}
		case BC_MSG_PRESENTER:
			print_presenter(c, m.presenter.presenter,
			                m.presenter.following != 0);
			fflush(stdout);
			break;
		case BC_MSG_SESSION_CAMERA_SET:
			order_seen(times, m.session_camera_set.order, at);
			print_change(c, "camera", m.session_camera_set.order,
			             m.session_camera_set.author, "");
			fflush(stdout);
			break;
		case BC_MSG_SCENE_STATE:
			order_seen(times, m.scene_state.order, at);
			if (m.scene_state.author) {
				print_change(c, "load", m.scene_state.order,
				             m.scene_state.author, "");
				fflush(stdout);
			}
			break;
		case BC_MSG_ERROR:
			/* The server's H.264 encoder failed: the frames go on
			 * in another encoding, which the text names. */
			if (m.error.code == (uint16_t)-BC_ECODEC &&
			    m.seq == 0) {
				fprintf(
				    stderr, "blobcast watch: server: %.*s\n",
				    (int)m.error.text.len, m.error.text.ptr);
				break;
			}
			status = bc_cli_server_failed(a, c, &m);
			goto out;
		case BC_MSG_FRAME:
			nframes++;
			last_frame_at = at;
			total_bytes += bc_client_info(c)->last_msg_bytes;
			if (m.flags & BC_PROTO_FLAG_KEY) {
				awaiting_key = false;
			}
			if (bc_client_image_apply(&img, &m, &ei) &&
			    !awaiting_key) {
				fprintf(stderr,
				        "blobcast watch: frame %u does not "
				        "decode: %s\n",
				        m.frame.frame_no, ei.msg);
				/* A broken H.264 chain: VIEW again brings a
				 * KEY frame, where the file goes on too. */
				if (m.frame.encoding == BC_PROTO_ENC_H264) {
					rec.keyed = false;
					awaiting_key = true;
					if (send_view(a, c, &ei)) {
						status = bc_cli_failed(
						    a, c, "VIEW", &ei);
						goto out;
					}
				}
			} else if (!awaiting_key &&
			           (status = record_frame(&rec, &m))) {
				goto out;
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
			printf("frame %llu no=%u order=%llu bytes=%u rects=%u "
			       "image=%ux%u level=%u %s latency_ms=",
			       (unsigned long long)nframes, m.frame.frame_no,
			       (unsigned long long)m.frame.order,
			       bc_client_info(c)->last_msg_bytes,
			       m.frame.nrects, m.frame.image_width,
			       m.frame.image_height,
			       bc_proto_flags_level(m.flags),
			       bc_cli_frame_kind(m.flags));
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
	if ((status = record_close(&rec, true))) {
		goto out;
	}
	/* Server averages when the connection is up; a run that ends while
	 * reconnecting reports its own counts only. */
	memset(&st, 0, sizeof(st));
	if (!offline &&
	    bc_client_stats_parts(c, BC_PROTO_STATS_LINK, &st, &ei)) {
		status = bc_cli_failed(a, c, "stats", &ei);
		goto out;
	}
	printf("stats frames=%llu bytes=%llu server_frames=%llu "
	       "server_fps=%.1f render_ms_avg=%.2f encode_ms_avg=%.2f "
	       "edit_ms_avg=%.3f rtt_ms=%.2f link_mbit=%.2f paced=%u "
	       "spoiled=%llu end=%s\n",
	       (unsigned long long)nframes, (unsigned long long)total_bytes,
	       (unsigned long long)st.frames, (double)st.fps,
	       (double)st.render_ms_avg, (double)st.encode_ms_avg,
	       (double)st.edit_ms_avg, (double)st.link.rtt_us / 1e3,
	       (double)st.link.delivery_bps * 8.0 / 1e6, st.link.frames_paced,
	       (unsigned long long)st.link.frames_spoiled, end);
	if (strcmp(end, "timeout") == 0) {
		status = bc_cli_frames_timed_out(a, nframes, idle_limit);
	}
out:
	record_close(&rec, false);
	bc_cli_stop_restore(&sig);
	bc_free(times);
	bc_client_image_finish(&img);
	bc_client_destroy(fresh);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_watch = {
    .name = "watch",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_SIZE | BC_CLI_O_FRAMES |
            BC_CLI_O_ENCODING | BC_CLI_O_DOWNSCALE | BC_CLI_O_RECORD,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--frames N] [--size WxH] [--encoding h264 "
                "[--record FILE]]",
    .summary = "print a line per frame the session sends",
    .help =
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
        "'stats' line gives the server's averages, what its TCP measures of\n"
        "the link (rtt_ms, link_mbit: the delivery rate; 0 over a Unix\n"
        "socket), the frames that waited for the link (paced) or that a\n"
        "newer one replaced unsent (spoiled), and end=frames (N frames\n"
        "came), end=timeout or end=stopped (Ctrl-C, SIGTERM).\n"
        "With --encoding h264 every frame is one H.264 access unit of the\n"
        "whole view (a KEY frame where a decoder may start: after each\n"
        "VIEW, and every still), decoded here to check it; a frame that\n"
        "does not decode sends the VIEW again for a KEY frame. The server\n"
        "must have an H.264 encoder (else it refuses, ENOTSUP). --record\n"
        "FILE saves those access units as they come, from the first KEY\n"
        "frame, as a raw H.264 Annex B stream (ffplay FILE, ffprobe FILE;\n"
        "ffmpeg -i FILE -c copy OUT.mp4 makes an MP4), and prints\n"
        "  record file=FILE frames=N bytes=B\n"
        "before the stats line. Containers (.mp4, .mkv, ...) are refused:\n"
        "this build has no muxer.",
    .run = run_watch};
