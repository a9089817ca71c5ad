/*
 * `blobcast present|follow`: the two sides of a presentation. present
 * shows this client's camera to the members who follow until it is
 * stopped, runs out or is replaced; follow prints the presenter's cameras
 * and the frames the server renders from them.
 */
#include "cmd_client.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/client.h"
#include "blobcast/clock.h"
#include "blobcast/image.h"

/*
 * A one-shot presenter: it sets this connection's camera (the session's,
 * changed by the camera options), presents, and stays until Ctrl-C,
 * SIGTERM, --for SECONDS or another member taking over; then it stops
 * presenting (unless replaced), which ends every follow. Any role may
 * present, so it joins as a viewer.
 */
static int run_present(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	struct bc_msg m;
	struct bc_cli_stop sig;
	double until = 0.0;
	const char *end = "stopped";
	uint32_t me;
	int status, rc;
	bc_cli_stop_install(&sig);
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_VIEWER,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if ((status = bc_cli_camera_from_opts(a, c, &cam))) {
		goto out;
	}
	if (bc_client_camera(c, &cam, false, NULL, &ei) ||
	    bc_client_present(c, true, &ei)) {
		status = bc_cli_failed(a, c, "present", &ei);
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
	while (!bc_cli_stopped()) {
		if (until > 0.0 && bc_clock_ms() >= until) {
			end = "time";
			break;
		}
		rc = bc_client_recv(c, &m, BC_CLI_SLICE_MS);
		if (rc < 0) {
			status = bc_cli_conn_failed(a, c, NULL);
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
			status = bc_cli_server_failed(a, c, &m);
			goto out;
		}
	}
	if (strcmp(end, "replaced") != 0 && bc_client_present(c, false, &ei)) {
		status = bc_cli_failed(a, c, "stop presenting", &ei);
		goto out;
	}
	printf("end=%s\n", end);
out:
	bc_cli_stop_restore(&sig);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_present = {
    .name = "present",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_CAMERA | BC_CLI_O_FOR,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis =
        "--session NAME [--eye x,y,z --target x,y,z ...] [--for SECONDS]",
    .summary = "present: members who follow see this client's camera",
    .help =
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
    .run = run_present};

/*
 * Follows the session's presenter: whoever presents now or starts later
 * (a presentation that ends is waited out). Prints who presents, each
 * camera the presenter moves to and each frame, rendered at --size.
 */
static int run_follow(struct bc_cli_call *a)
{
	struct bc_client *c = NULL;
	struct bc_errinfo ei = {0};
	struct bc_client_image img;
	struct bc_msg m;
	struct bc_cli_stop sig;
	uint64_t nframes = 0;
	double last_frame_at;
	double idle_limit = bc_cli_frame_idle_limit(a);
	const char *end = "stopped";
	int status, rc;
	bc_client_image_init(&img);
	bc_cli_stop_install(&sig);
	if (a->out && !bc_image_ext_supports(a->out, BC_IMAGE_U8)) {
		fprintf(stderr,
		        "blobcast follow: \"%s\": no image format for this "
		        "extension (use .png, .tif, .exr, .jpg, ...)\n",
		        a->out);
		status = BC_CLI_EXIT_USAGE;
		goto out;
	}
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_VIEWER,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	/* FOLLOW 0 first: the server then says who presents (PRESENTER). */
	if (bc_client_follow(c, false, &ei)) {
		status = bc_cli_failed(a, c, "follow", &ei);
		goto out;
	}
	if (bc_client_view(c,
	                   &(struct bc_msg_view){.width = a->width,
	                                         .height = a->height,
	                                         .encoding = a->encoding,
	                                         .downscale = a->downscale},
	                   NULL, &ei)) {
		status = bc_cli_failed(a, c, "view", &ei);
		goto out;
	}
	/* Behave as if PRESENTER had just said who presents. */
	memset(&m, 0, sizeof(m));
	m.type = BC_MSG_PRESENTER;
	m.presenter.presenter = bc_client_info(c)->presenter;
	rc = 1;
	last_frame_at = bc_clock_ms();
	while (!bc_cli_stopped() && (a->frames == 0 || nframes < a->frames)) {
		if (rc == 0) {
			if (a->frames && idle_limit >= 0.0 &&
			    bc_clock_ms() - last_frame_at > idle_limit) {
				end = "timeout";
				break;
			}
			rc = bc_client_recv(c, &m, BC_CLI_SLICE_MS);
			if (rc < 0) {
				status = bc_cli_conn_failed(a, c, NULL);
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
					status =
					    bc_cli_conn_failed(a, c, "follow");
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
			       bc_cli_frame_kind(m.flags));
			fflush(stdout);
			break;
		case BC_MSG_ERROR:
			/* A FOLLOW that met no presenter: the next
			 * PRESENTER says when one starts. */
			if (-(int)m.error.code == BC_ESTATE && m.seq != 0) {
				break;
			}
			status = bc_cli_server_failed(a, c, &m);
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
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (a->out && img.complete) {
		printf("wrote %s (%ux%u)\n", a->out, img.width, img.height);
	}
	printf("end=%s frames=%llu\n", end, (unsigned long long)nframes);
	if (strcmp(end, "timeout") == 0) {
		status = bc_cli_frames_timed_out(a, nframes, idle_limit);
	}
out:
	bc_cli_stop_restore(&sig);
	bc_client_image_finish(&img);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_follow = {
    .name = "follow",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_SIZE | BC_CLI_O_FRAMES |
            BC_CLI_O_ENCODING | BC_CLI_O_DOWNSCALE | BC_CLI_O_OUT,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME [--frames N] [--size WxH] [--out IMG]",
    .summary = "follow the presenter and print its camera and frames",
    .help =
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
    .texts =
        (const struct bc_cli_opt_text[]){
            {"frames", NULL,
             "stop after N frames ({range}); give up "
             "when no\nframe came for --timeout MS "
             "(default 10000),\nexit status 1"},
            {"encoding", NULL, "{choices} (default jpeg)"},
            {"out", NULL,
             "at the end, write the last picture to "
             "IMG"},
            {NULL, NULL, NULL}},
    .run = run_follow};
