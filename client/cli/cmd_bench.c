/*
 * `blobcast bench-latency`: moves one primitive back and forth and
 * measures, on this client, the time from each edit sent to the first
 * frame that shows it; prints the percentiles and the server's averages as
 * one JSON line.
 */
#include "cmd_client.h"

#include <jansson.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/client.h"
#include "blobcast/clock.h"
#include "blobcast/scene.h"

/* How far bench-latency moves the primitive, in world units: visible in
 * the picture (so the frame has damage to send) yet small. */
#define BENCH_STEP 0.05f

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
static int one_edit(const struct bc_cli_call *a, struct bc_client *c,
                    uint32_t node, const float pos[3], uint64_t *frames,
                    uint64_t *bytes, uint64_t *incomplete)
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
		return bc_cli_failed(a, c, NULL, &ei);
	}
	for (;;) {
		double left = deadline - bc_clock_ms();
		int rc = bc_client_recv(
		    c, &m, timeout < 0 ? -1 : (left > 0.0 ? (int)left + 1 : 0));
		if (rc < 0) {
			return bc_cli_conn_failed(a, c, NULL);
		}
		if (rc == 0) {
			fprintf(stderr,
			        "blobcast %s: no frame showing edit %u within "
			        "%d ms\n",
			        a->cmd, seq, timeout);
			return BC_CLI_EXIT_FAIL;
		}
		if (m.type == BC_MSG_ERROR) {
			return bc_cli_server_failed(a, c, &m);
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

static int run_bench(struct bc_cli_call *a)
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
		return BC_CLI_EXIT_USAGE;
	}
	if (!(lat = bc_calloc(a->edits, sizeof(*lat)))) {
		fprintf(stderr, "blobcast bench-latency: out of memory\n");
		return BC_CLI_EXIT_FAIL;
	}
	if ((status = bc_cli_open_session(a, BC_PROTO_ROLE_EDITOR,
	                                  BC_CLIENT_JOIN_EXISTING, &c))) {
		goto out;
	}
	if (!bc_client_scene(c, NULL)) {
		fprintf(stderr, "blobcast bench-latency: the session's scene "
		                "did not arrive intact\n");
		status = BC_CLI_EXIT_FAIL;
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
		status = BC_CLI_EXIT_USAGE;
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
		status = bc_cli_failed(a, c, "first frame", &ei);
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
		status = bc_cli_failed(a, c, "stats", &ei);
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
		status = BC_CLI_EXIT_FAIL;
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

const struct bc_cli_cmd bc_cli_cmd_bench_latency = {
    .name = "bench-latency",
    .opts = BC_CLI_O_SESSION | BC_CLI_O_SIZE | BC_CLI_O_EDITS | BC_CLI_O_NODE |
            BC_CLI_O_ENCODING | BC_CLI_O_INTERACTING | BC_CLI_O_DOWNSCALE,
    .min_pos = 0,
    .max_pos = 0,
    .synopsis = "--session NAME --edits N [--size WxH]",
    .summary = "measure edit-to-frame latency (prints JSON)",
    .help =
        "Moves one primitive back and forth by 0.05 in x, N times, each time\n"
        "waiting for the first frame whose edit order includes the edit,\n"
        "and prints one JSON line: p50_ms, p99_ms, mean_ms, min_ms, max_ms\n"
        "of edit sent -> frame received, frames and bytes_per_frame (mean\n"
        "over every frame received during the run), and the server's render,\n"
        "encode and edit averages. The primitive is put back at the end.",
    .run = run_bench};
