/*
 * `blobcast load|edit|camera|present|follow|snapshot|watch|bench-latency|
 * nodes|scene|...`: the command-line client of blobcastd. Its commands
 * share one option table (blobcast/args.h): every value is checked, an
 * option a command does not take is refused as not applying and left out
 * of that command's help. This file holds the list of the commands and
 * that table; the commands themselves live in a file per group
 * (cmd_edit.c, cmd_session.c, cmd_watch.c, cmd_present.c, cmd_snapshot.c,
 * cmd_bench.c) and share client_common.c. All protocol work goes through
 * libblobcast (blobcast/client.h); image files through bc_image (OpenImageIO).
 *
 * Exit status (cli.h, docs/client.md): 0 success, 1 the server refused
 * (its ERROR text is printed), 2 usage error, 3 the network (no
 * connection, TLS, a timeout, a closed connection, not a blobcastd), 4
 * authentication; every failure also says what to do.
 */
#include "cmd_client.h"

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/args.h"
#include "blobcast/client.h"
#include "cli.h"

/* bench-latency: edits per run. A million at ~10 ms each is hours: more is
 * a typing mistake. */
#define MAX_BENCH_EDITS 1000000u

/* ---- dispatch ------------------------------------------------------------ */

/* Every client command, in the order the overview lists them. */
static const struct bc_cli_cmd *const cmds[] = {
    &bc_cli_cmd_load,      &bc_cli_cmd_edit,          &bc_cli_cmd_camera,
    &bc_cli_cmd_present,   &bc_cli_cmd_follow,        &bc_cli_cmd_snapshot,
    &bc_cli_cmd_watch,     &bc_cli_cmd_bench_latency, &bc_cli_cmd_nodes,
    &bc_cli_cmd_scene,     &bc_cli_cmd_delete,        &bc_cli_cmd_sessions,
    &bc_cli_cmd_undo,      &bc_cli_cmd_redo,          &bc_cli_cmd_add,
    &bc_cli_cmd_remove,    &bc_cli_cmd_move,          &bc_cli_cmd_wrap,
    &bc_cli_cmd_duplicate, &bc_cli_cmd_rename,        &bc_cli_cmd_history};

static const struct bc_cli_cmd *find_cmd(const char *name)
{
	for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
		if (strcmp(cmds[i]->name, name) == 0) {
			return cmds[i];
		}
	}
	return NULL;
}

void bc_cli_client_usage(FILE *out)
{
	for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
		fprintf(out, "  %-14s %s\n", cmds[i]->name, cmds[i]->summary);
	}
}

static const struct bc_opt_name encoding_names[] = {
    {"jpeg", BC_PROTO_ENC_JPEG},
    {"png", BC_PROTO_ENC_PNG},
    {"raw", BC_PROTO_ENC_RAW},
    {"h264", BC_PROTO_ENC_H264},
    {NULL, 0},
};

/* Where the table parses to; copied into struct bc_cli_call after the checks
 * that the table cannot make. */
struct parsed {
	uint32_t size[2];
	uint32_t timeout_ms, edits, node, downscale;
	float eye[3], target[3], up[3], fov;
	int encoding;
};

/* Most options of the table below. */
#define MAX_OPTS 33

/*
 * One table of every client command's options: the command-specific ones,
 * then the common ones (need 0). need[i] is the O_ bit a command's mask
 * must hold for opts[i]; options of other commands stay in the table, so
 * that giving one is refused as not applying (not as unknown), but are
 * hidden from this command's help. Returns the number of options.
 */
static int client_opts(const struct bc_cli_cmd *k, struct bc_cli_call *a,
                       struct parsed *p, struct bc_opt opts[MAX_OPTS + 1],
                       unsigned need[MAX_OPTS])
{
	const struct {
		unsigned need;
		struct bc_opt opt;
	} all[] = {
	    {BC_CLI_O_SESSION,
	     {.name = "session",
	      .kind = BC_OPT_STRING,
	      .dst = &a->session,
	      .arg = "NAME",
	      .help = "the session (1..64 bytes; required)"}},
	    {BC_CLI_O_SIZE,
	     {.name = "size",
	      .kind = BC_OPT_SIZE,
	      .dst = p->size,
	      .lo = 1,
	      .hi = BC_PROTO_MAX_DIM,
	      .arg = "WxH",
	      .help = "view size, each {range} (default 640x480;\n"
	              "blobcastd serves up to 4096, its WELCOME max_dim)"}},
	    {BC_CLI_O_FRAMES,
	     {.name = "frames",
	      .kind = BC_OPT_U64,
	      .dst = &a->frames,
	      .lo = 1,
	      .hi = 18446744073709551616.0,
	      .arg = "N",
	      .help = "stop after N frames ({range}; default: run until\n"
	              "stopped); give up when no frame came for --timeout\n"
	              "MS (default 10000; 0: never), exit status 1"}},
	    {BC_CLI_O_TILE,
	     {.name = "tile",
	      .kind = BC_OPT_U32,
	      .dst = &a->tile,
	      .lo = 8,
	      .hi = BC_PROTO_MAX_DIM,
	      .arg = "N",
	      .help = "ask for the picture in N x N tiles ({range},\n"
	              "rounded down to a multiple of 8; default: one\n"
	              "picture when the server's max_dim allows, else\n"
	              "1024)"}},
	    {BC_CLI_O_FOR,
	     {.name = "for",
	      .kind = BC_OPT_U64,
	      .dst = &a->for_s,
	      .lo = 1,
	      .hi = 86400,
	      .arg = "SECONDS",
	      .help = "present for SECONDS ({range}; default: until\n"
	              "Ctrl-C or SIGTERM)"}},
	    {BC_CLI_O_EDITS,
	     {.name = "edits",
	      .kind = BC_OPT_U32,
	      .dst = &p->edits,
	      .lo = 1,
	      .hi = MAX_BENCH_EDITS,
	      .arg = "N",
	      .help = "number of edits ({range}; required)"}},
	    {BC_CLI_O_NODE,
	     {.name = "node",
	      .kind = BC_OPT_U32,
	      .dst = &p->node,
	      .lo = 1,
	      .hi = UINT32_MAX,
	      .arg = "ID",
	      .help = "primitive to move (default: the first one)"}},
	    {BC_CLI_O_ENCODING,
	     {.name = "encoding",
	      .kind = BC_OPT_ENUM,
	      .dst = &p->encoding,
	      .arg = "E",
	      .names = encoding_names,
	      .help = "{choices} (default jpeg); h264: one H.264\n"
	              "access unit of the whole view per frame, still\n"
	              "included (the server must have an encoder)"}},
	    {BC_CLI_O_RECORD,
	     {.name = "record",
	      .kind = BC_OPT_STRING,
	      .dst = &a->record,
	      .arg = "FILE",
	      .help = "with --encoding h264: save the stream as a raw\n"
	              "H.264 Annex B file (.h264; ffplay and ffprobe\n"
	              "read it), from its first KEY frame"}},
	    {BC_CLI_O_DOWNSCALE,
	     {.name = "downscale",
	      .kind = BC_OPT_U32,
	      .dst = &p->downscale,
	      .lo = 1,
	      .hi = BC_PROTO_MAX_DOWNSCALE,
	      .arg = "D",
	      .help = "coarsest block accepted ({range}): refinement\n"
	              "frames at 1/2^n resolution with 2^n <= D\n"
	              "(default 1)"}},
	    {BC_CLI_O_INTERACTING,
	     {.name = "interacting",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->interacting,
	      .help = "send the edits as a drag (interactive frames)"}},
	    {BC_CLI_O_OUT,
	     {.name = "out",
	      .kind = BC_OPT_STRING,
	      .dst = &a->out,
	      .arg = "IMG",
	      .help = "write the picture to IMG"}},
	    {BC_CLI_O_DEPTH,
	     {.name = "depth",
	      .kind = BC_OPT_STRING,
	      .dst = &a->depth,
	      .arg = "IMG",
	      .help = "also write the ray distance per pixel as one\n"
	              "float channel (+inf where nothing is hit; .exr,\n"
	              ".tif or .pfm)"}},
	    {BC_CLI_O_IDS,
	     {.name = "ids",
	      .kind = BC_OPT_STRING,
	      .dst = &a->ids,
	      .arg = "IMG",
	      .help = "also write the node id of the primitive seen per\n"
	              "pixel as one uint32 channel (0 where nothing is\n"
	              "hit; .tif or .exr)"}},
	    {BC_CLI_O_EYE,
	     {.name = "eye",
	      .kind = BC_OPT_VEC3,
	      .dst = p->eye,
	      .arg = "x,y,z",
	      .help = "camera position"}},
	    {BC_CLI_O_TARGET,
	     {.name = "target",
	      .kind = BC_OPT_VEC3,
	      .dst = p->target,
	      .arg = "x,y,z",
	      .help = "the point the camera looks at"}},
	    {BC_CLI_O_UP,
	     {.name = "up",
	      .kind = BC_OPT_VEC3,
	      .dst = p->up,
	      .arg = "x,y,z",
	      .help = "camera up direction"}},
	    {BC_CLI_O_FOV,
	     {.name = "fov",
	      .kind = BC_OPT_F32,
	      .dst = &p->fov,
	      .lo = 0,
	      .hi = 180,
	      .arg = "DEG",
	      .help = "vertical field of view in degrees (between 0\n"
	              "and 180)"}},
	    {BC_CLI_O_PARENT,
	     {.name = "parent",
	      .kind = BC_OPT_U32,
	      .dst = &a->parent,
	      .lo = 1,
	      .hi = UINT32_MAX,
	      .arg = "ID",
	      .help = "the operator to add under (default: the root,\n"
	              "or the operator under the unary nodes on top)"}},
	    {BC_CLI_O_POSITION,
	     {.name = "position",
	      .kind = BC_OPT_STRING,
	      .dst = &a->position,
	      .arg = "N",
	      .help = "child index under the parent, 0 first (default:\n"
	              "after the last child)"}},
	    {BC_CLI_O_AT,
	     {.name = "at",
	      .kind = BC_OPT_STRING,
	      .dst = &a->at,
	      .arg = "x,y,z",
	      .help = "where new primitives go without translate=\n"
	              "(default: the session camera's target)"}},
	    {BC_CLI_O_CHILD,
	     {.name = "child",
	      .kind = BC_OPT_STRING,
	      .dst = &a->child,
	      .arg = "KIND",
	      .help = "the primitive a new operator or unary node\n"
	              "starts with (default sphere)"}},
	    {BC_CLI_O_OFFSET,
	     {.name = "offset",
	      .kind = BC_OPT_STRING,
	      .dst = &a->offset,
	      .arg = "x,y,z",
	      .help = "move the copy by x,y,z (default: on the\n"
	              "original)"}},
	    {BC_CLI_O_ANY,
	     {.name = "any",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->any,
	      .help = "the session's newest change, whoever made it\n"
	              "(the session's owner or presenter only)"}},
	    {BC_CLI_O_JSON,
	     {.name = "json",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->json,
	      .help = "print JSON"}},
	    {BC_CLI_O_BINARY,
	     {.name = "binary",
	      .kind = BC_OPT_FLAG,
	      .dst = &a->binary,
	      .help = "write a binary scene file"}},
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
		for (const struct bc_cli_opt_text *t = k->texts; t && t->name;
		     t++) {
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

/* Checks what the table cannot and copies p into a; 0 or BC_CLI_EXIT_USAGE
 * after printing why. */
static int check_opts(const struct bc_args *pa, struct bc_cli_call *a,
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
	const struct bc_cli_cmd *k = find_cmd(subcommand);
	struct bc_opt opts[MAX_OPTS + 1];
	unsigned need[MAX_OPTS];
	char prog[64], usage[256], about[4096];
	struct parsed p = {.size = {640, 480},
	                   .timeout_ms = 10000,
	                   .edits = 0,
	                   .downscale = 1,
	                   .encoding = BC_PROTO_ENC_JPEG};
	struct bc_args pa = {0};
	struct bc_cli_call a;
	int nopts, status;
	if (!k) {
		fprintf(stderr, "blobcast: '%s' is not a client command\n",
		        subcommand);
		return BC_CLI_EXIT_USAGE;
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
		return bc_args_error(&pa,
		                     "unexpected argument '%s' (usage: %s %s)",
		                     pa.pos[k->max_pos], prog, k->synopsis);
	}
	if (pa.npos < k->min_pos) {
		return bc_args_error(&pa, "missing arguments (usage: %s %s)",
		                     prog, k->synopsis);
	}
	if ((k->opts & BC_CLI_O_SESSION) && !a.session) {
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
