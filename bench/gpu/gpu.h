/*
 * What the GPU run's driver (bench_gpu.c and its gpu_*.c steps) shares: the
 * options, a step's outputs (a JSON object and a Markdown section), how a
 * step reports what it could not do, and the gl renderer it measures.
 * Every step is one gpu_cmd_* function: it writes its results whatever
 * fails and returns 0 when everything asked for ran and passed, 1 when
 * something failed, 2 for bad usage.
 */
#ifndef BLOBCAST_BENCH_GPU_H
#define BLOBCAST_BENCH_GPU_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "blobcast/log.h"
#include "blobcast/render.h"
#include "blobcast/render_gl.h"

/* Longest list an option takes (counts, levels, view sizes). */
#define GPU_MAX_LIST 32

struct gpu_opts {
	const char *platform; /* gl platform name, NULL: auto */
	const char *json, *md;
	const char *dir;       /* refs: output; check: scenes and refs */
	const char *blobcastd; /* daemon */
	uint32_t size;         /* frame edge */
	int reps, warmup, edits;
	double budget_s; /* table2: start no scene after this */
	uint32_t counts[GPU_MAX_LIST], ncounts;    /* fig18 counts */
	uint32_t lens_counts[GPU_MAX_LIST], nlens; /* fig18 lenses counts */
	uint32_t levels[GPU_MAX_LIST], nlevels;    /* fig16 levels */
	uint32_t sizes[GPU_MAX_LIST][2], nsizes;   /* daemon view sizes */
	int min_scenes;
	bool expect_hardware; /* refuse a software gl context */
	/* table2: fig18 smooth spheres only (and the floors), not every
	 * kind and blend (the big view's step). */
	bool smooth_spheres;
	/* gl: the A-buffer's limit (bc_render_opts.abuffer_limit), 0: the
	 * backend's own. */
	uint32_t abuffer_limit;
	const char *file; /* verify */
};

struct gpu_out {
	FILE *json, *md;
	char json_tmp[4200];
	const char *json_path;
	int failures;
};

/* Milliseconds of CLOCK_MONOTONIC. */
double gpu_now_ms(void);
/* s as a JSON string; v as a JSON number, null when not finite. */
void gpu_jstr(FILE *f, const char *s);
void gpu_jnum(FILE *f, double v);
/* Opens op->json (through a temporary file renamed at close, so a crash
 * leaves none) and op->md; either may be NULL (nothing written). Returns
 * 0 or -1 (reported). */
int gpu_out_open(struct gpu_out *o, const struct gpu_opts *op);
/* Closes both; returns the step's exit status: 1 when gpu_fail was called
 * or a file could not be written, else 0. */
int gpu_out_close(struct gpu_out *o);
/* Reports what a step could not do: to stderr now, and into the step's
 * "errors" list (gpu_json_errors). */
void gpu_fail(struct gpu_out *o, const char *fmt, ...) BC__PRINTF(2, 3);
/* Writes ,"errors":[...] into f. */
void gpu_json_errors(FILE *f);
/* Median of v[0..n) (sorts v); NAN for n <= 0. */
double gpu_median(double *v, int n);
/* Whether the context is software (llvmpipe, surfaceless, OSMesa). */
bool gpu_is_software(const struct bc_gl_info *info);
/* A gl renderer on op's platform, its info in *info; NULL (reported) when
 * none can be created, or when op asks for hardware and it is software.
 * The caller destroys it. */
struct bc_renderer *gpu_open_gl(const struct gpu_opts *op, struct gpu_out *o,
                                struct bc_gl_info *info);

int gpu_cmd_refs(const struct gpu_opts *op);
int gpu_cmd_info(const struct gpu_opts *op);
int gpu_cmd_check(const struct gpu_opts *op);
int gpu_cmd_verify(const struct gpu_opts *op);
int gpu_cmd_table2(const struct gpu_opts *op);
int gpu_cmd_edit(const struct gpu_opts *op);
int gpu_cmd_daemon(const struct gpu_opts *op);

#endif
