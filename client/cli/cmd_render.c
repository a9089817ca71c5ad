/*
 * `blobcast render`: option parsing and validation (every bad argument is
 * named, exit 2, before any work), scene loading (a file, stdin or the
 * built-in scene), one frame through the backend interface with progress on
 * stderr for long frames, and the image files (OpenImageIO, format from the
 * extension).
 */
#include "cmd_render.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/image.h"
#include "blobcast/render.h"
#include "blobcast/scene.h"
#include "cli.h"

/* Most worker threads --threads accepts; the CPU backends cap lower. */
#define MAX_THREADS 1024u
/* Most bands --bands accepts (a band is at least 8 rows). */
#define MAX_BANDS (BC_RENDER_MAX_DIM / BC_RENDER_TILE)

struct args {
	const char *scene;
	uint32_t size[2];
	enum bc_backend backend;
	/* Filled by the parser, then moved into backend and opts. */
	int backend_opt, debug, simd, gl_platform, range;
	const char *out, *depth, *ids;
	bool stats, quiet;
	uint32_t bands; /* windows; 0: one */
	struct bc_render_opts opts;
};

static const struct bc_opt_name backend_names[] = {{"naive", BC_BACKEND_NAIVE},
                                                   {"tiled", BC_BACKEND_TILED},
                                                   {"gl", BC_BACKEND_GL},
                                                   {"svo", BC_BACKEND_SVO},
                                                   {NULL, 0}};
static const struct bc_opt_name debug_names[] = {
    {"evals", BC_DEBUG_EVALS}, {"overlaps", BC_DEBUG_OVERLAPS}, {NULL, 0}};
static const struct bc_opt_name simd_names[] = {{"auto", BC_SIMD_AUTO},
                                                {"off", BC_SIMD_OFF},
                                                {"avx2", BC_SIMD_AVX2},
                                                {"avx512", BC_SIMD_AVX512},
                                                {NULL, 0}};
/* The renderer takes the platform by name: the index into this table. */
static const struct bc_opt_name platform_names[] = {
    {"auto", 0}, {"device", 1}, {"surfaceless", 2}, {"osmesa", 3}, {NULL, 0}};
static const struct bc_opt_name range_names[] = {{"ia", BC_RANGE_IA},
                                                 {"aa", BC_RANGE_AA},
                                                 {"revaa", BC_RANGE_REVAA},
                                                 {NULL, 0}};

/* The option table over a; --help is generated from it. */
#define RENDER_OPTS(a)                                                         \
	{                                                                      \
		{.name = "size",                                               \
		 .kind = BC_OPT_SIZE,                                          \
		 .dst = (a)->size,                                             \
		 .lo = 1,                                                      \
		 .hi = BC_RENDER_MAX_DIM,                                      \
		 .arg = "WxH",                                                 \
		 .help = "frame size in pixels, each {range} (required)",      \
		 .flags = BC_OPT_REQUIRED},                                    \
		    {.name = "out",                                            \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(a)->out,                                         \
		     .arg = "IMAGE",                                           \
		     .help = "colour image; the format follows the\n"          \
		             "extension (png, tif, exr, jpg, ...) (required)", \
		     .flags = BC_OPT_REQUIRED},                                \
		    {.name = "depth",                                          \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(a)->depth,                                       \
		     .arg = "IMAGE",                                           \
		     .help = "ray distance per pixel as one float channel,\n"  \
		             "+inf where nothing is hit: .exr, .tif, .pfm"},   \
		    {.name = "ids",                                            \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(a)->ids,                                         \
		     .arg = "IMAGE",                                           \
		     .help = "node id of the primitive seen per pixel as\n"    \
		             "uint32, 0 where nothing is hit: .tif, .exr"},    \
		    {.name = "backend",                                        \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->backend_opt,                                 \
		     .arg = "NAME",                                            \
		     .help = "{choices} (default tiled);\n"                    \
		             "backends not built into this binary are\n"       \
		             "refused",                                        \
		     .names = backend_names},                                  \
		    {.name = "debug",                                          \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->debug,                                       \
		     .arg = "MODE",                                            \
		     .help = "colour by work instead of shading:\n"            \
		             "evals    = field evaluations per ray (ramp\n"    \
		             "           saturates at 128)\n"                  \
		             "overlaps = primitives listed in the pixel's\n"   \
		             "           8x8 tile (saturates at 32; naive\n"   \
		             "           lists every primitive)",              \
		     .names = debug_names},                                    \
		    {.name = "threads",                                        \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->opts.threads,                                \
		     .hi = MAX_THREADS,                                        \
		     .arg = "N",                                               \
		     .help = "CPU threads {range}, 0 = one per core\n"         \
		             "(default 0); the naive and tiled backends\n"     \
		             "use at most 64"},                                \
		    {.name = "simd",                                           \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->simd,                                        \
		     .arg = "MODE",                                            \
		     .help = "tiled backend only: vector instructions of\n"    \
		             "the tracer, auto (the widest the CPU has) |\n"   \
		             "off (one ray at a time) | avx2 | avx512\n"       \
		             "(default auto)",                                 \
		     .names = simd_names},                                     \
		    {.name = "gl-platform",                                    \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->gl_platform,                                 \
		     .arg = "P",                                               \
		     .help = "gl backend only: {choices}\n(default auto)",     \
		     .names = platform_names},                                 \
		    {.name = "range",                                          \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->range,                                       \
		     .arg = "A",                                               \
		     .help = "svo backend only: interval arithmetic\n"         \
		             "{choices} (default: chosen per scene,\n"         \
		             "docs/svo.md)",                                   \
		     .names = range_names},                                    \
		    {.name = "threshold",                                      \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->opts.svo_threshold,                          \
		     .lo = 1,                                                  \
		     .hi = UINT32_MAX,                                         \
		     .arg = "T",                                               \
		     .help = "svo backend only: node-count threshold that\n"   \
		             "stops subdivision, {range} (default: the\n"      \
		             "backend's)"},                                    \
		    {.name = "max-depth",                                      \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->opts.svo_max_depth,                          \
		     .lo = 1,                                                  \
		     .hi = UINT32_MAX,                                         \
		     .arg = "D",                                               \
		     .help = "svo backend only: octree depth limit\n"          \
		             "(default: the backend's)"},                      \
		    {.name = "bands",                                          \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->bands,                                       \
		     .hi = MAX_BANDS,                                          \
		     .arg = "N",                                               \
		     .help = "draw the frame in N horizontal bands, each\n"    \
		             "a window with its own A-buffer (the same\n"      \
		             "pixels, less memory; 0 = one). The tiled\n"      \
		             "and gl backends band a frame whose A-buffer\n"   \
		             "would pass its limit by themselves (default\n"   \
		             "0)"},                                            \
		    {.name = "stats",                                          \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(a)->stats,                                       \
		     .help = "print the frame's timings and counters to\n"     \
		             "stderr"},                                        \
		    {.name = "quiet",                                          \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(a)->quiet,                                       \
		     .help = "no progress and no summary line"},               \
		    {.kind = BC_OPT_INVALID},                                  \
	}

static const char render_about[] =
    "Renders SCENE on this machine and writes the image files.\n"
    "SCENE is a scene file (JSON or binary), '-' to read one from\n"
    "stdin, or 'default' for the built-in scene. The scene's camera\n"
    "is used.";
static const char render_footer[] =
    "Backend-only options are accepted with any backend and ignored by\n"
    "the others. Exit status: 0 done, 1 the scene could not be loaded\n"
    "or rendered or an image written, 2 bad arguments.\n"
    "Environment: SOURCE_DATE_EPOCH (seconds since 1970, UTC), when set,\n"
    "is the time .tif and .exr files state instead of the time of\n"
    "writing, so that one scene rendered twice gives the same bytes.";

static struct bc_args render_args(const struct bc_opt *opts)
{
	return (struct bc_args){
	    .prog = "blobcast render",
	    .usage = "blobcast render SCENE --size WxH --out IMAGE "
	             "[options]",
	    .about = render_about,
	    .footer = render_footer,
	    .opts = opts};
}

void bc_cli_render_usage(FILE *out)
{
	struct args a;
	const struct bc_opt opts[] = RENDER_OPTS(&a);
	struct bc_args p = render_args(opts);
	bc_args_help(&p, out);
}

/* Returns 0 to go on, -1 after --help, 2 on a bad argument. */
static int parse(int argc, char **argv, struct args *a)
{
	const struct bc_opt opts[] = RENDER_OPTS(a);
	struct bc_args p = render_args(opts);
	*a = (struct args){.backend_opt = BC_BACKEND_TILED};
	if (bc_cli_args_parse(&p, argc, argv)) {
		return p.status == 0 ? -1 : p.status;
	}
	if (p.npos == 0) {
		return bc_args_error(&p, "%s",
		                     "no scene given (a file, '-' or "
		                     "'default')");
	}
	if (p.npos > 1) {
		return bc_args_error(&p, "more than one scene given ('%s')",
		                     p.pos[1]);
	}
	a->scene = p.pos[0];
	a->backend = (enum bc_backend)a->backend_opt;
	if (!bc_backend_available(a->backend)) {
		return bc_args_error(&p,
		                     "backend '%s' is not built into this "
		                     "blobcast",
		                     bc_backend_name(a->backend));
	}
	a->opts.debug = (enum bc_debug_mode)a->debug;
	a->opts.simd = (enum bc_simd)a->simd;
	a->opts.svo_range = (enum bc_range_arith)a->range;
	a->opts.gl_platform =
	    a->gl_platform ? platform_names[a->gl_platform].name : NULL;
	if (!bc_image_ext_supports(a->out, BC_IMAGE_U8)) {
		return bc_args_error(&p,
		                     "--out '%s': no image format for that "
		                     "extension (png, tif, exr, jpg, ...)",
		                     a->out);
	}
	if (a->depth && !bc_image_ext_supports(a->depth, BC_IMAGE_F32)) {
		return bc_args_error(&p,
		                     "--depth '%s': depth needs a float "
		                     "format: .exr, .tif or .pfm",
		                     a->depth);
	}
	if (a->ids && !bc_image_ext_supports(a->ids, BC_IMAGE_U32)) {
		return bc_args_error(&p,
		                     "--ids '%s': ids need a uint32 format: "
		                     ".tif or .exr",
		                     a->ids);
	}
	return 0;
}

/* The most a scene on stdin may take: a JSON text, or a binary scene
 * file with its header. */
#define STDIN_MAX_BYTES                                                        \
	(BC_SCENE_JSON_MAX_BYTES >                                             \
	         BC_SCENE_FILE_MAX_BYTES + BC_SCENE_FILE_HEADER                \
	     ? BC_SCENE_JSON_MAX_BYTES                                         \
	     : BC_SCENE_FILE_MAX_BYTES + BC_SCENE_FILE_HEADER)

/* Reads all of stdin, at most STDIN_MAX_BYTES. */
static int read_stdin(char **text, size_t *len, struct bc_errinfo *ei)
{
	size_t cap = 1 << 16, n = 0;
	char *buf = bc_malloc(cap);
	if (!buf) {
		return bc_errinfo_set(ei, BC_ENOMEM, "stdin: out of memory");
	}
	for (;;) {
		size_t got;
		if (n == cap) {
			char *grown;
			if (cap >= STDIN_MAX_BYTES) {
				bc_free(buf);
				return bc_errinfo_set(ei, BC_ELIMIT,
				                      "stdin: scene over %u "
				                      "bytes",
				                      STDIN_MAX_BYTES);
			}
			cap = cap * 2 > STDIN_MAX_BYTES ? STDIN_MAX_BYTES + 1
			                                : cap * 2;
			if (!(grown = bc_realloc(buf, cap))) {
				bc_free(buf);
				return bc_errinfo_set(ei, BC_ENOMEM,
				                      "stdin: out of memory");
			}
			buf = grown;
		}
		got = fread(buf + n, 1, cap - n, stdin);
		n += got;
		if (got == 0) {
			break;
		}
	}
	if (ferror(stdin)) {
		bc_free(buf);
		return bc_errinfo_set(ei, BC_EIO, "stdin: read error");
	}
	*text = buf;
	*len = n;
	return 0;
}

int bc_cli_load_scene(const char *scene, struct bc_tree *t,
                      struct bc_camera *cam, struct bc_errinfo *ei)
{
	bc_camera_default(cam);
	if (strcmp(scene, "default") == 0) {
		const char *json = bc_scene_default_json();
		return bc_scene_parse_json(json, strlen(json), t, cam, ei);
	}
	if (strcmp(scene, "-") == 0) {
		char *text = NULL;
		size_t len = 0;
		int rc = read_stdin(&text, &len, ei);
		if (rc == 0) {
			/* A binary scene file by its first bytes, as
			 * bc_scene_load_file tells them apart. */
			bool binary = len >= 4 &&
			              memcmp(text, BC_SCENE_FILE_MAGIC, 4) == 0;
			rc = binary
			         ? bc_scene_file_decode((const uint8_t *)text,
			                                len, t, cam, ei)
			         : bc_scene_parse_json(text, len, t, cam, ei);
			bc_free(text);
		}
		return rc;
	}
	return bc_scene_load_file(scene, t, cam, ei);
}

struct progress {
	bool tty;
	int last;
	uint32_t band, nbands; /* the band being drawn, of how many */
};

static void on_progress(void *user, uint32_t done, uint32_t total)
{
	struct progress *p = user;
	double part = total ? (double)done / total : 1.0;
	int pct = (int)(100.0 * (p->band + part) / p->nbands);
	if (p->tty) {
		fprintf(stderr, "\rrender: %3d%%", pct);
	} else if (pct / 10 > p->last / 10) {
		/* Logs get one line per tenth. */
		fprintf(stderr, "render: %d%%\n", pct);
	}
	p->last = pct;
}

/* Adds a band's stats to the frame's. */
static void add_stats(struct bc_render_stats *sum,
                      const struct bc_render_stats *s)
{
	sum->ms_total += s->ms_total;
	sum->ms_abuffer += s->ms_abuffer;
	sum->ms_trace += s->ms_trace;
	sum->ms_upload += s->ms_upload;
	sum->field_evals += s->field_evals;
	sum->tiles += s->tiles;
	sum->rays += s->rays;
	sum->max_overlap = s->max_overlap > sum->max_overlap ? s->max_overlap
	                                                     : sum->max_overlap;
	sum->incomplete = sum->incomplete || s->incomplete;
	sum->short_rays += s->short_rays;
	sum->bands += s->bands;
	sum->ab_pairs += s->ab_pairs;
	sum->ab_candidates += s->ab_candidates;
}

/* Draws the frame in nb horizontal bands of a multiple of 8 rows (the
 * last one shorter): each is a window of the whole view, so its pixels
 * are the whole render's (bc_frame_window), and each builds an A-buffer
 * of its own rows only. */
static int render_bands(struct bc_renderer *r, uint32_t nb,
                        struct progress *prog, const struct bc_camera *cam,
                        struct bc_frame *frame, struct bc_render_stats *stats,
                        struct bc_errinfo *ei)
{
	uint32_t w = frame->width, h = frame->height;
	uint32_t rows = (h + nb - 1) / nb;
	struct bc_frame band = {0};
	int rc = 0;
	rows = (rows + BC_RENDER_TILE - 1) / BC_RENDER_TILE * BC_RENDER_TILE;
	prog->nbands = (h + rows - 1) / rows;
	*stats = (struct bc_render_stats){0};
	for (uint32_t y = 0; y < h && rc == 0; y += rows) {
		uint32_t bh = h - y < rows ? h - y : rows;
		struct bc_render_stats s = {0};
		size_t px = (size_t)w * y;
		if (band.height != bh) {
			bc_frame_finish(&band);
			if ((rc = bc_frame_init(&band, w, bh))) {
				break;
			}
		}
		prog->band = y / rows;
		if ((rc = bc_frame_window(&band, 0, y, w, h)) ||
		    (rc = bc_renderer_render(r, cam, &band, &s, ei))) {
			break;
		}
		add_stats(stats, &s);
		memcpy(frame->rgba + 4 * px, band.rgba, (size_t)4 * w * bh);
		memcpy(frame->depth + px, band.depth,
		       (size_t)w * bh * sizeof(*band.depth));
		memcpy(frame->ids + px, band.ids,
		       (size_t)w * bh * sizeof(*band.ids));
	}
	bc_frame_finish(&band);
	if (rc == BC_ENOMEM) {
		return bc_errinfo_set(ei, rc, "render: out of memory");
	}
	return rc;
}

/* Draws the frame in a->bands windows (0: one). *bands is how many
 * A-buffers it took: the windows, or the backend's own bands (tiled, gl)
 * of a frame whose lists pass its limit, if more. */
static int render(const struct args *a, const struct bc_tree *t,
                  const struct bc_camera *cam, struct bc_frame *frame,
                  struct bc_render_stats *stats, uint32_t *bands,
                  struct bc_errinfo *ei)
{
	struct bc_renderer *r = NULL;
	struct progress prog = {isatty(STDERR_FILENO) == 1, 0, 0, 1};
	uint32_t nb = a->bands ? a->bands : 1, windows;
	int rc;
	if ((rc = bc_renderer_create(&r, a->backend, &a->opts, ei))) {
		return rc;
	}
	if (!a->quiet) {
		bc_renderer_set_progress(r, on_progress, &prog);
	}
	if ((rc = bc_renderer_sync(r, t, NULL, ei)) == 0) {
		rc = nb == 1
		         ? bc_renderer_render(r, cam, frame, stats, ei)
		         : render_bands(r, nb, &prog, cam, frame, stats, ei);
	}
	if (prog.tty && prog.last) {
		fputc('\n', stderr);
	}
	windows = nb == 1 ? 1 : prog.nbands; /* bands of 8 rows at least */
	*bands = stats->bands > windows ? stats->bands : windows;
	bc_renderer_destroy(r);
	return rc;
}

int bc_cli_render(int argc, char **argv)
{
	struct args a;
	struct bc_errinfo ei = {0};
	struct bc_tree *t = NULL;
	struct bc_camera cam;
	struct bc_frame frame = {0};
	struct bc_render_stats stats = {0};
	uint32_t bands = 1;
	int rc, status = 1;
	if ((rc = parse(argc, argv, &a))) {
		return rc < 0 ? 0 : rc;
	}
	if (!(t = bc_tree_create())) {
		fprintf(stderr, "blobcast render: out of memory\n");
		goto cleanup;
	}
	if ((rc = bc_cli_load_scene(a.scene, t, &cam, &ei))) {
		bc_cli_explain(stderr, "blobcast render",
		               ei.msg[0] ? ei.msg : bc_strerror(rc));
		goto cleanup;
	}
	if ((rc = bc_frame_init(&frame, a.size[0], a.size[1]))) {
		fprintf(stderr, "blobcast render: %ux%u frame: %s\n", a.size[0],
		        a.size[1], bc_strerror(rc));
		goto cleanup;
	}
	if ((rc = render(&a, t, &cam, &frame, &stats, &bands, &ei))) {
		fprintf(stderr, "blobcast render: %s\n",
		        ei.msg[0] ? ei.msg : bc_strerror(rc));
		goto cleanup;
	}
	if ((rc = bc_image_write_rgba8(a.out, a.size[0], a.size[1], frame.rgba,
	                               &ei)) ||
	    (a.depth &&
	     (rc = bc_image_write_float(a.depth, a.size[0], a.size[1],
	                                frame.depth, &ei))) ||
	    (a.ids && (rc = bc_image_write_u32(a.ids, a.size[0], a.size[1],
	                                       frame.ids, &ei)))) {
		fprintf(stderr, "blobcast render: %s\n", ei.msg);
		goto cleanup;
	}
	if (a.stats) {
		char pairs[96] = "";
		if (stats.ab_pairs) {
			snprintf(pairs, sizeof(pairs),
			         ", %llu tile pairs, %llu candidates",
			         (unsigned long long)stats.ab_pairs,
			         (unsigned long long)stats.ab_candidates);
		}
		fprintf(
		    stderr,
		    "render: backend %s, %ux%u, %u primitives: total %.2f "
		    "ms, a-buffer %.2f ms, trace %.2f ms, upload %.2f ms, "
		    "%llu field evaluations, max overlap %u, %u band%s%s%s\n",
		    bc_backend_name(a.backend), a.size[0], a.size[1],
		    bc_tree_prim_count(t), stats.ms_total, stats.ms_abuffer,
		    stats.ms_trace, stats.ms_upload,
		    (unsigned long long)stats.field_evals, stats.max_overlap,
		    bands, bands == 1 ? "" : "s", pairs,
		    stats.incomplete ? ", incomplete" : "");
	} else if (!a.quiet) {
		fprintf(stderr, "render: %s %ux%u in %.1f ms -> %s\n",
		        bc_backend_name(a.backend), a.size[0], a.size[1],
		        stats.ms_total, a.out);
	}
	status = 0;
cleanup:
	bc_frame_finish(&frame);
	bc_tree_destroy(t);
	return status;
}
