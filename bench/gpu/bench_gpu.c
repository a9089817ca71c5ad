/*
 * The GPU run's driver: every measurement and check that bench/gpu/run.sh
 * makes on a GPU host (or on llvmpipe here, with small sizes), one
 * subcommand per step. Each step writes a JSON object (--json FILE) and a
 * Markdown section (--md FILE) that run.sh assembles into results.json and
 * results.md, prints what it does to stdout and what it could not do to
 * stderr, and exits non-zero when anything failed — after doing the rest.
 *
 *   refs    (packing, here) generates the correctness scenes, saves them as
 *           JSON and renders each with the CPU tiled renderer: depth and
 *           ids into NAME.ref (gzip; the hit mask is depth < inf).
 *   info    creates a gl renderer on the asked platform and reports what
 *           it got (GL_RENDERER, version, platform, limits).
 *   check   renders every NAME.json of a folder with gl and compares with
 *           NAME.ref as tests/gl compares with the tiled renderer.
 *   table2  Zanni 2024 Table 2: fig18 boxes/spheres (and the intersected
 *           spheres, "lenses"), sharp and smooth, and fig16 L1..L6, per
 *           frame median ms after warm-up with the A-buffer / tracing
 *           split of the paper's Fig. 20 (GPU timer queries).
 *   edit    a parameter edit on the GPU: bytes uploaded, sync ms, the
 *           damaged region re-rendered (ms, tiles) against a whole frame,
 *           and the region-assembled frame compared with a whole render.
 *   daemon  edit -> frame through blobcastd --backend gl, JPEG, p50/p99,
 *           at each asked view size (bench/latency.h's measurement).
 *   verify  reads results.json: every step ran and succeeded, every scene
 *           correct, at least N scenes.
 *
 * Usage: bench_gpu COMMAND [options]; bench_gpu --help lists them. The
 * steps live in gpu_check.c, gpu_perf.c and gpu_daemon.c, what they share
 * in gpu.h and gpu_out.c.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/gen.h"
#include "gpu.h"

/* ---- Arguments ---------------------------------------------------------- */

static const char usage[] =
    "usage: bench_gpu COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  refs    --dir DIR [--size N]   write the correctness scenes and "
    "their\n"
    "          tiled CPU references (NAME.json, NAME.ref) into DIR\n"
    "  info    the gl context: GL_RENDERER, platform\n"
    "  check   --dir DIR [--min-scenes N]  gl against the references\n"
    "  table2  [--size N] [--reps R] [--warmup W] [--counts LIST]\n"
    "          [--lens-counts LIST] [--levels LIST] [--budget-s S]\n"
    "          [--smooth-spheres]\n"
    "          Zanni 2024 Table 2 (fig18, fig16) with the A-buffer / "
    "tracing split;\n"
    "          --smooth-spheres: of fig18, smooth spheres only\n"
    "  edit    [--size N] [--counts LIST] [--edits E]  parameter edits "
    "on the GPU\n"
    "  daemon  --blobcastd PATH [--counts N] [--sizes WxH,...] [--edits "
    "E]\n"
    "          edit -> frame through blobcastd --backend gl (JPEG)\n"
    "  verify  FILE [--min-scenes N]  results.json: every step ran and "
    "succeeded,\n"
    "          every scene correct\n"
    "\n"
    "common options:\n"
    "  --platform P   gl platform: auto | device | surfaceless | osmesa\n"
    "  --expect-hardware  fail at once (info: after reporting it) when the\n"
    "                 gl context is software (llvmpipe, surfaceless, "
    "OSMesa)\n"
    "  --abuffer-limit N  the gl A-buffer's limit in fragments "
    "(1..2^24;\n"
    "                 default the backend's): views over it are drawn in "
    "bands\n"
    "  --json FILE    the step's results as one JSON object\n"
    "  --md FILE      the step's results as Markdown\n"
    "LIST: comma-separated numbers (table2 --counts 16,64,256,1024,4096;\n"
    "--levels 1,2,3,4,5,6; an empty LIST leaves that family out).\n"
    "Exit status: 0 when everything asked for ran and passed, 1 when "
    "something\nfailed (what ran is still reported), 2 for bad usage.\n";

static int parse_list(const char *s, uint32_t *v, uint32_t *n)
{
	*n = 0;
	while (s && *s) {
		char *end;
		unsigned long x = strtoul(s, &end, 10);
		if (end == s || x == 0 || x > (1ul << 24) ||
		    *n >= GPU_MAX_LIST) {
			return -1;
		}
		v[(*n)++] = (uint32_t)x;
		s = *end == ',' ? end + 1 : end;
		if (*end && *end != ',') {
			return -1;
		}
	}
	return 0;
}

static int parse_sizes(const char *s, struct gpu_opts *op)
{
	op->nsizes = 0;
	while (s && *s) {
		unsigned w, h;
		int used = 0;
		if (op->nsizes >= GPU_MAX_LIST ||
		    sscanf(s, "%ux%u%n", &w, &h, &used) != 2 || w == 0 ||
		    h == 0 || w > 8192 || h > 8192) {
			return -1;
		}
		op->sizes[op->nsizes][0] = w;
		op->sizes[op->nsizes][1] = h;
		op->nsizes++;
		s += used;
		if (*s == ',') {
			s++;
		} else if (*s) {
			return -1;
		}
	}
	return 0;
}

int main(int argc, char **argv)
{
	struct gpu_opts op = {
	    .size = 512, .reps = 20, .warmup = 3, .edits = 50, .min_scenes = 1};
	const char *cmd;
	if (argc < 2 || strcmp(argv[1], "--help") == 0 ||
	    strcmp(argv[1], "-h") == 0) {
		fputs(usage, argc < 2 ? stderr : stdout);
		return argc < 2 ? 2 : 0;
	}
	cmd = argv[1];
	parse_list("16,64,256,1024,4096", op.counts, &op.ncounts);
	/* Lenses of two spheres: the paper's 24..6144 primitives. */
	parse_list("12,48,192,768,3072", op.lens_counts, &op.nlens);
	parse_list("1,2,3,4,5,6", op.levels, &op.nlevels);
	parse_sizes("1920x1080,1024x768", &op);
	for (int i = 2; i < argc; i++) {
		const char *a = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : NULL;
		bool bad = false;
		if (strcmp(a, "--expect-hardware") == 0) {
			op.expect_hardware = true;
			continue;
		}
		if (strcmp(a, "--smooth-spheres") == 0) {
			op.smooth_spheres = true;
			continue;
		}
		if (a[0] != '-' && strcmp(cmd, "verify") == 0 && !op.file) {
			op.file = a;
			continue;
		}
		if (!v) {
			fprintf(stderr, "bench_gpu: %s needs a value\n%s", a,
			        usage);
			return 2;
		}
		i++;
		if (strcmp(a, "--platform") == 0) {
			op.platform = v;
		} else if (strcmp(a, "--json") == 0) {
			op.json = v;
		} else if (strcmp(a, "--md") == 0) {
			op.md = v;
		} else if (strcmp(a, "--dir") == 0) {
			op.dir = v;
		} else if (strcmp(a, "--blobcastd") == 0) {
			op.blobcastd = v;
		} else if (strcmp(a, "--size") == 0) {
			op.size = (uint32_t)atoi(v);
			bad = op.size == 0 || op.size > 4096;
		} else if (strcmp(a, "--reps") == 0) {
			op.reps = atoi(v);
			bad = op.reps < 1 || op.reps > 10000;
		} else if (strcmp(a, "--warmup") == 0) {
			op.warmup = atoi(v);
			bad = op.warmup < 0 || op.warmup > 1000;
		} else if (strcmp(a, "--edits") == 0) {
			op.edits = atoi(v);
			bad = op.edits < 1 || op.edits > 100000;
		} else if (strcmp(a, "--min-scenes") == 0) {
			op.min_scenes = atoi(v);
		} else if (strcmp(a, "--budget-s") == 0) {
			op.budget_s = atof(v);
		} else if (strcmp(a, "--counts") == 0) {
			bad = parse_list(v, op.counts, &op.ncounts) != 0;
		} else if (strcmp(a, "--lens-counts") == 0) {
			bad = parse_list(v, op.lens_counts, &op.nlens) != 0;
		} else if (strcmp(a, "--levels") == 0) {
			bad = parse_list(v, op.levels, &op.nlevels) != 0;
			for (uint32_t k = 0; k < op.nlevels; k++) {
				bad |= op.levels[k] > BC_GEN_MAX_LEVEL;
			}
		} else if (strcmp(a, "--sizes") == 0) {
			bad = parse_sizes(v, &op) != 0;
		} else if (strcmp(a, "--abuffer-limit") == 0) {
			uint32_t n = 0;
			bad =
			    parse_list(v, &op.abuffer_limit, &n) != 0 || n != 1;
		} else {
			fprintf(stderr, "bench_gpu: unknown option %s\n%s", a,
			        usage);
			return 2;
		}
		if (bad) {
			fprintf(stderr, "bench_gpu: bad value for %s: %s\n", a,
			        v);
			return 2;
		}
	}
	/* Output is read through pipes and files: line by line. */
	setvbuf(stdout, NULL, _IOLBF, 0);
	if (strcmp(cmd, "refs") == 0) {
		return gpu_cmd_refs(&op);
	} else if (strcmp(cmd, "info") == 0) {
		return gpu_cmd_info(&op);
	} else if (strcmp(cmd, "check") == 0) {
		return gpu_cmd_check(&op);
	} else if (strcmp(cmd, "table2") == 0) {
		return gpu_cmd_table2(&op);
	} else if (strcmp(cmd, "edit") == 0) {
		return gpu_cmd_edit(&op);
	} else if (strcmp(cmd, "daemon") == 0) {
		return gpu_cmd_daemon(&op);
	} else if (strcmp(cmd, "verify") == 0) {
		return gpu_cmd_verify(&op);
	}
	fprintf(stderr, "bench_gpu: unknown command %s\n%s", cmd, usage);
	return 2;
}
