/*
 * `blobcast render`: option parsing and validation (every bad argument is
 * named, exit 2, before any work), scene loading (a file, stdin or the
 * built-in scene), one frame through the backend interface with progress on
 * stderr for long frames, and the image files (OpenImageIO, format from the
 * extension).
 */
#include "cmd_render.h"

#include <errno.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/image.h"
#include "blobcast/render.h"
#if defined(BLOBCAST_HAVE_CPU)
#include "blobcast/render_cpu.h"
#endif
#if defined(__has_include)
#if __has_include("blobcast/scene.h")
#include "blobcast/scene.h"
#define HAVE_SCENE 1
#endif
#endif

/* Most worker threads --threads accepts; the CPU backends cap lower. */
#define MAX_THREADS 1024u

struct args {
	const char *scene;
	uint32_t width, height;
	enum bc_backend backend;
	const char *out, *depth, *ids;
	bool stats, quiet;
	struct bc_render_opts opts;
};

void bc_cli_render_usage(FILE *out)
{
	fprintf(out,
		"usage: blobcast render SCENE --size WxH --out IMAGE [options]\n"
		"\n"
		"Renders SCENE on this machine and writes the image files.\n"
		"SCENE is a JSON scene file, '-' to read one from stdin, or\n"
		"'default' for the built-in scene. The scene's camera is used.\n"
		"\n"
		"  --size WxH         frame size in pixels, each 1..%u (required)\n"
		"  --out IMAGE        colour image; the format follows the\n"
		"                     extension (png, tif, exr, jpg, ...) (required)\n"
		"  --depth IMAGE      ray distance per pixel as one float channel,\n"
		"                     +inf where nothing is hit: .exr, .tif, .pfm\n"
		"  --ids IMAGE        node id of the primitive seen per pixel as\n"
		"                     uint32, 0 where nothing is hit: .tif, .exr\n"
		"  --backend NAME     naive | tiled | gl | svo (default tiled);\n"
		"                     backends not built into this binary are\n"
		"                     refused\n"
		"  --debug MODE       colour by work instead of shading:\n"
		"                     evals    = field evaluations per ray (ramp\n"
		"                                saturates at 128)\n"
		"                     overlaps = primitives listed in the pixel's\n"
		"                                8x8 tile (saturates at 32; naive\n"
		"                                lists every primitive)\n"
		"  --threads N        CPU threads, 0 = one per core (default 0);\n"
		"                     the naive and tiled backends use at most 64\n"
		"  --simd MODE        tiled backend only: vector instructions of\n"
		"                     the tracer, auto (the widest the CPU has) |\n"
		"                     off (one ray at a time) | avx2 | avx512\n"
		"                     (default auto)\n"
		"  --gl-platform P    gl backend only: auto | device | surfaceless\n"
		"                     | osmesa (default auto)\n"
		"  --range A          svo backend only: interval arithmetic ia |\n"
		"                     aa | revaa (default: the backend's, ia)\n"
		"  --threshold T      svo backend only: node-count threshold that\n"
		"                     stops subdivision (default: the backend's)\n"
		"  --max-depth D      svo backend only: octree depth limit\n"
		"                     (default: the backend's)\n"
		"  --stats            print the frame's timings and counters to\n"
		"                     stderr\n"
		"  --quiet            no progress and no summary line\n"
		"  -h, --help         this help\n"
		"\n"
		"Backend-only options are accepted with any backend and ignored by\n"
		"the others. Exit status: 0 done, 1 the scene could not be loaded\n"
		"or rendered or an image written, 2 bad arguments.\n",
		BC_RENDER_MAX_DIM);
}

#if defined(__GNUC__)
__attribute__((format(printf, 1, 2)))
#endif
static int usage_error(const char *fmt, ...)
{
	va_list ap;
	fprintf(stderr, "blobcast render: ");
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fprintf(stderr, "\n(see 'blobcast render --help')\n");
	return 2;
}

/* Parses a decimal uint32 in [lo, hi], the whole string. */
static bool parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
	char *end;
	unsigned long v;
	if (!s || *s < '0' || *s > '9') {
		return false;
	}
	errno = 0;
	v = strtoul(s, &end, 10);
	if (errno || *end != '\0' || v < lo || v > hi) {
		return false;
	}
	*out = (uint32_t)v;
	return true;
}

static bool parse_size(const char *s, uint32_t *w, uint32_t *h)
{
	const char *x = strchr(s, 'x');
	char wbuf[16];
	size_t n;
	if (!x) {
		return false;
	}
	n = (size_t)(x - s);
	if (n == 0 || n >= sizeof(wbuf)) {
		return false;
	}
	memcpy(wbuf, s, n);
	wbuf[n] = '\0';
	return parse_u32(wbuf, 1, BC_RENDER_MAX_DIM, w) &&
	       parse_u32(x + 1, 1, BC_RENDER_MAX_DIM, h);
}

/* Options that take a value, as --name VALUE or --name=VALUE. */
static const char *const valued[] = {
	"--size",    "--out",   "--depth",       "--ids",
	"--backend", "--debug", "--threads",     "--gl-platform",
	"--range",   "--threshold", "--max-depth", "--simd",
};

static int parse(int argc, char **argv, struct args *a)
{
	*a = (struct args){.backend = BC_BACKEND_TILED};
	for (int i = 1; i < argc; i++) {
		const char *arg = argv[i], *val = NULL, *eq;
		char name[32];
		bool takes = false;
		if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
			bc_cli_render_usage(stdout);
			return -1;
		}
		if (strncmp(arg, "--", 2) != 0 || strcmp(arg, "-") == 0) {
			if (arg[0] == '-' && strcmp(arg, "-") != 0) {
				return usage_error("unknown option '%s'", arg);
			}
			if (a->scene) {
				return usage_error("more than one scene given "
						   "('%s')", arg);
			}
			a->scene = arg;
			continue;
		}
		eq = strchr(arg, '=');
		if (strlen(arg) >= sizeof(name) ||
		    (eq && (size_t)(eq - arg) >= sizeof(name))) {
			return usage_error("unknown option '%s'", arg);
		}
		if (eq) {
			memcpy(name, arg, (size_t)(eq - arg));
			name[eq - arg] = '\0';
			val = eq + 1;
		} else {
			strcpy(name, arg);
		}
		for (size_t k = 0; k < sizeof(valued) / sizeof(valued[0]); k++) {
			takes = takes || strcmp(name, valued[k]) == 0;
		}
		if (!takes) {
			if (strcmp(name, "--stats") == 0 && !eq) {
				a->stats = true;
			} else if (strcmp(name, "--quiet") == 0 && !eq) {
				a->quiet = true;
			} else {
				return usage_error("unknown option '%s'", arg);
			}
			continue;
		}
		if (!val) {
			if (i + 1 >= argc) {
				return usage_error("%s needs a value", name);
			}
			val = argv[++i];
		}
		if (strcmp(name, "--size") == 0) {
			if (!parse_size(val, &a->width, &a->height)) {
				fprintf(stderr,
					"blobcast render: --size '%s' is not "
					"WxH with 1 <= W, H <= %u\n",
					val, BC_RENDER_MAX_DIM);
				return 2;
			}
		} else if (strcmp(name, "--out") == 0) {
			a->out = val;
		} else if (strcmp(name, "--depth") == 0) {
			a->depth = val;
		} else if (strcmp(name, "--ids") == 0) {
			a->ids = val;
		} else if (strcmp(name, "--backend") == 0) {
			a->backend = bc_backend_from_name(val);
			if (a->backend == BC_BACKEND_INVALID) {
				return usage_error("unknown backend '%s' (naive, "
						   "tiled, gl, svo)", val);
			}
			if (!bc_backend_available(a->backend)) {
				return usage_error("backend '%s' is not built "
						   "into this blobcast", val);
			}
		} else if (strcmp(name, "--debug") == 0) {
			if (strcmp(val, "evals") == 0) {
				a->opts.debug = BC_DEBUG_EVALS;
			} else if (strcmp(val, "overlaps") == 0) {
				a->opts.debug = BC_DEBUG_OVERLAPS;
			} else {
				return usage_error("unknown debug mode '%s' "
						   "(evals, overlaps)", val);
			}
		} else if (strcmp(name, "--threads") == 0) {
			if (!parse_u32(val, 0, MAX_THREADS, &a->opts.threads)) {
				return usage_error("--threads '%s' is not a "
						   "number in 0..1024", val);
			}
		} else if (strcmp(name, "--simd") == 0) {
			if (strcmp(val, "auto") == 0) {
				a->opts.simd = BC_SIMD_AUTO;
			} else if (strcmp(val, "off") == 0) {
				a->opts.simd = BC_SIMD_OFF;
			} else if (strcmp(val, "avx2") == 0) {
				a->opts.simd = BC_SIMD_AVX2;
			} else if (strcmp(val, "avx512") == 0) {
				a->opts.simd = BC_SIMD_AVX512;
			} else {
				return usage_error("unknown --simd '%s' (auto, "
						   "off, avx2, avx512)", val);
			}
		} else if (strcmp(name, "--gl-platform") == 0) {
			if (strcmp(val, "auto") && strcmp(val, "device") &&
			    strcmp(val, "surfaceless") && strcmp(val, "osmesa")) {
				return usage_error("unknown GL platform '%s' "
						   "(auto, device, surfaceless, "
						   "osmesa)", val);
			}
			a->opts.gl_platform = val;
		} else if (strcmp(name, "--range") == 0) {
			if (strcmp(val, "ia") == 0) {
				a->opts.svo_range = BC_RANGE_IA;
			} else if (strcmp(val, "aa") == 0) {
				a->opts.svo_range = BC_RANGE_AA;
			} else if (strcmp(val, "revaa") == 0) {
				a->opts.svo_range = BC_RANGE_REVAA;
			} else {
				return usage_error("unknown range arithmetic "
						   "'%s' (ia, aa, revaa)", val);
			}
		} else if (strcmp(name, "--threshold") == 0) {
			if (!parse_u32(val, 1, UINT32_MAX, &a->opts.svo_threshold)) {
				return usage_error("--threshold '%s' is not a "
						   "positive number", val);
			}
		} else if (strcmp(name, "--max-depth") == 0) {
			if (!parse_u32(val, 1, UINT32_MAX, &a->opts.svo_max_depth)) {
				return usage_error("--max-depth '%s' is not a "
						   "positive number", val);
			}
		}
	}
	if (!a->scene) {
		return usage_error("%s", "no scene given (a file, '-' or "
					 "'default')");
	}
	if (!a->width) {
		return usage_error("%s", "--size WxH is required");
	}
	if (!a->out) {
		return usage_error("%s", "--out IMAGE is required");
	}
	if (!bc_image_ext_supports(a->out, BC_IMAGE_U8)) {
		return usage_error("--out '%s': no image format for that "
				   "extension (png, tif, exr, jpg, ...)", a->out);
	}
	if (a->depth && !bc_image_ext_supports(a->depth, BC_IMAGE_F32)) {
		return usage_error("--depth '%s': depth needs a float format: "
				   ".exr, .tif or .pfm", a->depth);
	}
	if (a->ids && !bc_image_ext_supports(a->ids, BC_IMAGE_U32)) {
		return usage_error("--ids '%s': ids need a uint32 format: .tif "
				   "or .exr", a->ids);
	}
	return 0;
}

#if defined(HAVE_SCENE)
/* Reads all of stdin, at most BC_SCENE_JSON_MAX_BYTES. */
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
			if (cap >= BC_SCENE_JSON_MAX_BYTES) {
				bc_free(buf);
				return bc_errinfo_set(ei, BC_ELIMIT,
						      "stdin: scene over %u "
						      "bytes",
						      BC_SCENE_JSON_MAX_BYTES);
			}
			cap = cap * 2 > BC_SCENE_JSON_MAX_BYTES
				      ? BC_SCENE_JSON_MAX_BYTES + 1
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
#endif

int bc_cli_load_scene(const char *scene, struct bc_tree *t,
		      struct bc_camera *cam, struct bc_errinfo *ei)
{
	bc_camera_default(cam);
#if defined(HAVE_SCENE)
	if (strcmp(scene, "default") == 0) {
		const char *json = bc_scene_default_json();
		return bc_scene_parse_json(json, strlen(json), t, cam, ei);
	}
	if (strcmp(scene, "-") == 0) {
		char *text = NULL;
		size_t len = 0;
		int rc = read_stdin(&text, &len, ei);
		if (rc == 0) {
			rc = bc_scene_parse_json(text, len, t, cam, ei);
			bc_free(text);
		}
		return rc;
	}
	return bc_scene_load_json(scene, t, cam, ei);
#else
	(void)t;
	return bc_errinfo_set(ei, BC_ENOTSUP,
			      "%s: this build cannot read scene files", scene);
#endif
}

struct progress {
	bool tty;
	int last;
};

#if defined(BLOBCAST_HAVE_CPU)
static void on_progress(void *user, uint32_t done, uint32_t total)
{
	struct progress *p = user;
	int pct = total ? (int)(100.0 * done / total) : 100;
	if (p->tty) {
		fprintf(stderr, "\rrender: %3d%%", pct);
	} else if (pct / 10 > p->last / 10) {
		/* Logs get one line per tenth. */
		fprintf(stderr, "render: %d%%\n", pct);
	}
	p->last = pct;
}
#endif

static int render(const struct args *a, const struct bc_tree *t,
		  const struct bc_camera *cam, struct bc_frame *frame,
		  struct bc_render_stats *stats, struct bc_errinfo *ei)
{
	struct bc_renderer *r = NULL;
	struct progress prog = {isatty(STDERR_FILENO) == 1, 0};
	int rc;
	if ((rc = bc_renderer_create(&r, a->backend, &a->opts, ei))) {
		return rc;
	}
#if defined(BLOBCAST_HAVE_CPU)
	if (!a->quiet && (a->backend == BC_BACKEND_NAIVE ||
			  a->backend == BC_BACKEND_TILED)) {
		bc_render_cpu_set_progress(r, on_progress, &prog);
	}
#endif
	if ((rc = bc_renderer_sync(r, t, NULL, ei)) == 0) {
		rc = bc_renderer_render(r, cam, frame, stats, ei);
	}
	if (prog.tty && prog.last) {
		fputc('\n', stderr);
	}
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
	int rc, status = 1;
	if ((rc = parse(argc, argv, &a))) {
		return rc < 0 ? 0 : rc;
	}
	if (!(t = bc_tree_create())) {
		fprintf(stderr, "blobcast render: out of memory\n");
		goto cleanup;
	}
	if ((rc = bc_cli_load_scene(a.scene, t, &cam, &ei))) {
		fprintf(stderr, "blobcast render: %s\n",
			ei.msg[0] ? ei.msg : bc_strerror(rc));
		goto cleanup;
	}
	if ((rc = bc_frame_init(&frame, a.width, a.height))) {
		fprintf(stderr, "blobcast render: %ux%u frame: %s\n", a.width,
			a.height, bc_strerror(rc));
		goto cleanup;
	}
	if ((rc = render(&a, t, &cam, &frame, &stats, &ei))) {
		fprintf(stderr, "blobcast render: %s\n",
			ei.msg[0] ? ei.msg : bc_strerror(rc));
		goto cleanup;
	}
	if ((rc = bc_image_write_rgba8(a.out, a.width, a.height, frame.rgba,
				       &ei)) ||
	    (a.depth && (rc = bc_image_write_float(a.depth, a.width, a.height,
						   frame.depth, &ei))) ||
	    (a.ids && (rc = bc_image_write_u32(a.ids, a.width, a.height,
					       frame.ids, &ei)))) {
		fprintf(stderr, "blobcast render: %s\n", ei.msg);
		goto cleanup;
	}
	if (a.stats) {
		fprintf(stderr,
			"render: backend %s, %ux%u, %u primitives: total %.2f "
			"ms, a-buffer %.2f ms, trace %.2f ms, upload %.2f ms, "
			"%llu field evaluations, max overlap %u%s\n",
			bc_backend_name(a.backend), a.width, a.height,
			bc_tree_prim_count(t), stats.ms_total, stats.ms_abuffer,
			stats.ms_trace, stats.ms_upload,
			(unsigned long long)stats.field_evals, stats.max_overlap,
			stats.incomplete ? ", incomplete" : "");
	} else if (!a.quiet) {
		fprintf(stderr, "render: %s %ux%u in %.1f ms -> %s\n",
			bc_backend_name(a.backend), a.width, a.height,
			stats.ms_total, a.out);
	}
	status = 0;
cleanup:
	bc_frame_finish(&frame);
	bc_tree_destroy(t);
	return status;
}
