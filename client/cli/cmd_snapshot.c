/*
 * `blobcast snapshot`: one lossless still of a session, from its camera or
 * one given for this picture, written as image files: the colour and, when
 * asked, the depth and node id planes of the same render.
 */
#include "cmd_client.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>

#include "blobcast/client.h"
#include "blobcast/image.h"

/* Progress on stderr: one line rewritten in place on a terminal. */
static void tile_progress(void *ud, uint32_t done, uint32_t total)
{
	bool tty = *(const bool *)ud;
	/* Into a log: about every 5 %, not a line per tile. */
	if (!tty && done < total &&
	    done * 20u / total == (done - 1u) * 20u / total) {
		return;
	}
	fprintf(stderr, "%sblobcast snapshot: tile %u of %u%s", tty ? "\r" : "",
	        done, total, tty && done < total ? "" : "\n");
	fflush(stderr);
}

/* The picture: one SNAPSHOT of the VIEW's size when it fits the server's
 * max_dim and no --tile was given, else tiles (PROTOCOL.md 7.17). */
static int take(struct bc_cli_call *a, struct bc_client *c, unsigned planes,
                struct bc_client_image *img, struct bc_errinfo *ei)
{
	const struct bc_client_info *in = bc_client_info(c);
	bool tiled =
	    a->tile || a->width > in->max_dim || a->height > in->max_dim;
	bool tty = isatty(fileno(stderr));
	uint32_t seq;
	/* The VIEW gives a single SNAPSHOT its size; its stream frame is a
	 * cheap JPEG we skip. Tiles need a VIEW too, of any size: a small
	 * one of the picture's shape costs the server least. */
	struct bc_msg_view v = {.width = a->width,
	                        .height = a->height,
	                        .encoding = BC_PROTO_ENC_JPEG,
	                        .quality_interactive = 30,
	                        .quality_still = 30};
	if (tiled) {
		uint32_t big = a->width > a->height ? a->width : a->height;
		uint32_t div = (big + 255) / 256;
		v.width = (uint16_t)((a->width + div - 1) / div);
		v.height = (uint16_t)((a->height + div - 1) / div);
	}
	if (bc_client_view(c, &v, &seq, ei)) {
		return -1;
	}
	if (!tiled) {
		return bc_client_snapshot_planes(c, BC_PROTO_ENC_PNG, planes,
		                                 img, ei);
	}
	return bc_client_snapshot_big(
	    c,
	    &(struct bc_client_big_opts){.width = a->width,
	                                 .height = a->height,
	                                 .encoding = BC_PROTO_ENC_PNG,
	                                 .planes = planes,
	                                 .tile = a->tile,
	                                 .progress = tile_progress,
	                                 .ud = &tty},
	    img, ei);
}

static int run_snapshot(struct bc_cli_call *a)
{
	uint64_t bytes_at;
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
		return BC_CLI_EXIT_USAGE;
	}
	if (a->depth && !bc_image_ext_supports(a->depth, BC_IMAGE_F32)) {
		fprintf(
		    stderr,
		    "blobcast snapshot: --depth \"%s\": depth needs a float "
		    "format: .exr, .tif or .pfm\n",
		    a->depth);
		return BC_CLI_EXIT_USAGE;
	}
	if (a->ids && !bc_image_ext_supports(a->ids, BC_IMAGE_U32)) {
		fprintf(stderr,
		        "blobcast snapshot: --ids \"%s\": ids need a uint32 "
		        "format: .tif or .exr\n",
		        a->ids);
		return BC_CLI_EXIT_USAGE;
	}
	if (!bc_image_ext_supports(a->out, BC_IMAGE_U8)) {
		fprintf(stderr,
		        "blobcast snapshot: \"%s\": no image format for this "
		        "extension (use .png, .tif, .exr, .jpg, ...)\n",
		        a->out);
		return BC_CLI_EXIT_USAGE;
	}
	bc_client_image_init(&img);
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_VIEWER,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (a->has_eye || a->has_target || a->has_up || a->has_fov) {
		bc_client_scene(c, &cam);
		bc_cli_apply_camera(a, &cam);
		if (bc_camera_validate(&cam, &ei)) {
			fprintf(stderr, "blobcast snapshot: %s\n", ei.msg);
			status = BC_CLI_EXIT_USAGE;
			goto out;
		}
		/* Before VIEW, so that the one stream frame VIEW causes is
		 * already from this camera. */
		if (bc_client_camera(c, &cam, false, &seq, &ei)) {
			status = bc_cli_failed(a, c, NULL, &ei);
			goto out;
		}
	}
	/* The picture's bytes: the answers (and the VIEW's one frame). */
	bytes_at = bc_client_info(c)->bytes_in;
	if (take(a, c, planes, &img, &ei)) {
		status = bc_cli_failed(a, c, "snapshot", &ei);
		goto out;
	}
	if (img.flags & BC_PROTO_FLAG_INCOMPLETE) {
		fprintf(
		    stderr,
		    "blobcast snapshot: the server hit its frame time budget "
		    "and sent a partial picture; nothing written (a smaller "
		    "--size renders faster)\n");
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (!img.complete || img.width != a->width || img.height != a->height) {
		fprintf(stderr,
		        "blobcast snapshot: the server sent a %ux%u picture%s "
		        "for a %ux%u request\n",
		        img.width, img.height, img.complete ? "" : " in part",
		        a->width, a->height);
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	if (bc_image_write_rgba8(a->out, img.width, img.height, img.rgba,
	                         &ei) ||
	    (a->depth && bc_image_write_float(a->depth, img.width, img.height,
	                                      img.depth, &ei)) ||
	    (a->ids &&
	     bc_image_write_u32(a->ids, img.width, img.height, img.ids, &ei))) {
		fprintf(stderr, "blobcast snapshot: %s\n", ei.msg);
		status = BC_CLI_EXIT_FAIL;
		goto out;
	}
	printf("wrote %s (%ux%u, frame %u, edit order %llu, %llu bytes from "
	       "the server)\n",
	       a->out, img.width, img.height, img.frame_no,
	       (unsigned long long)img.order,
	       (unsigned long long)(bc_client_info(c)->bytes_in - bytes_at));
out:
	bc_client_image_finish(&img);
	bc_client_destroy(c);
	return status;
}

const struct bc_cli_cmd bc_cli_cmd_snapshot = {
    .name = "snapshot",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_SIZE | BC_CLI_O_OUT | BC_CLI_O_DEPTH |
            BC_CLI_O_IDS | BC_CLI_O_CAMERA | BC_CLI_O_TILE,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME --size WxH --out IMG [--depth IMG] [--ids IMG] "
                "[--tile N]",
    .summary = "save a lossless still of a session to an image file",
    .help =
        "Asks the server for a lossless (PNG) still of session NAME at WxH\n"
        "and writes it to IMG (any format OpenImageIO writes, by extension;\n"
        ".jpg is lossy). The camera is the session's, or the one given by\n"
        "--eye/--target/--up/--fov (for this picture only). Depth and ids\n"
        "come from the same render as the colour, sent losslessly by the\n"
        "server. A picture larger than the server's max_dim (blobcastd:\n"
        "4096) comes in tiles, up to 8192x8192, with a progress line on\n"
        "stderr; every tile shows the same edit of the scene.",
    .texts =
        (const struct bc_cli_opt_text[]){
            {"size", NULL,
             "picture size, each {range} (required); over the server's\n"
             "WELCOME max_dim (blobcastd: 4096) it comes in tiles"},
            {"out", NULL, "write the picture to IMG (required)"},
            {NULL, NULL, NULL}},
    .run = run_snapshot};
