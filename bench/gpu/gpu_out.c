/*
 * The GPU run driver's shared parts (gpu.h): step outputs, failure reports,
 * medians, and the gl renderer every gl step opens.
 */
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "gpu.h"

double gpu_now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

void gpu_jstr(FILE *f, const char *s)
{
	fputc('"', f);
	for (; s && *s; s++) {
		unsigned char c = (unsigned char)*s;
		if (c == '"' || c == '\\') {
			fprintf(f, "\\%c", c);
		} else if (c < 0x20 || c >= 0x7f) {
			fprintf(f, "\\u%04x", c);
		} else {
			fputc(c, f);
		}
	}
	fputc('"', f);
}

/* A number, or null when it is not finite (JSON has no inf or NaN). */
void gpu_jnum(FILE *f, double v)
{
	if (isfinite(v)) {
		fprintf(f, "%.4f", v);
	} else {
		fputs("null", f);
	}
}

int gpu_out_open(struct gpu_out *o, const struct gpu_opts *op)
{
	memset(o, 0, sizeof(*o));
	o->json_path = op->json;
	if (op->json) {
		snprintf(o->json_tmp, sizeof(o->json_tmp), "%s.tmp", op->json);
		o->json = fopen(o->json_tmp, "w");
	} else {
		o->json = fopen("/dev/null", "w");
	}
	o->md = fopen(op->md ? op->md : "/dev/null", "w");
	if (!o->json || !o->md) {
		fprintf(stderr, "bench_gpu: cannot write %s / %s\n",
		        op->json ? op->json : "-", op->md ? op->md : "-");
		return -1;
	}
	return 0;
}

int gpu_out_close(struct gpu_out *o)
{
	int rc = o->failures ? 1 : 0;
	if (o->json) {
		if (fclose(o->json) != 0) {
			rc = 1;
		} else if (o->json_path &&
		           rename(o->json_tmp, o->json_path) != 0) {
			fprintf(stderr, "bench_gpu: cannot write %s\n",
			        o->json_path);
			rc = 1;
		}
	}
	if (o->md && fclose(o->md) != 0) {
		rc = 1;
	}
	return rc;
}

/* The step's failures, for its "errors" list. */
#define MAX_ERRORS 64
static char errors[MAX_ERRORS][300];
static int nerrors;

void gpu_fail(struct gpu_out *o, const char *fmt, ...)
{
	va_list ap;
	char msg[300];
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	fprintf(stderr, "bench_gpu: %s\n", msg);
	if (nerrors < MAX_ERRORS) {
		memcpy(errors[nerrors++], msg, sizeof(msg));
	}
	o->failures++;
}

void gpu_json_errors(FILE *f)
{
	fputs(",\"errors\":[", f);
	for (int i = 0; i < nerrors; i++) {
		if (i) {
			fputc(',', f);
		}
		gpu_jstr(f, errors[i]);
	}
	fputc(']', f);
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

double gpu_median(double *v, int n)
{
	if (n <= 0) {
		return NAN;
	}
	qsort(v, (size_t)n, sizeof(*v), cmp_double);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

bool gpu_is_software(const struct bc_gl_info *info)
{
	return info->software_device || strstr(info->renderer, "llvmpipe") ||
	       strstr(info->renderer, "softpipe") ||
	       info->platform == BC_GL_PLATFORM_SURFACELESS ||
	       info->platform == BC_GL_PLATFORM_OSMESA;
}

struct bc_renderer *gpu_open_gl(const struct gpu_opts *op, struct gpu_out *o,
                                struct bc_gl_info *info)
{
	struct bc_render_opts ro = {.gl_platform = op->platform,
	                            .abuffer_limit = op->abuffer_limit};
	struct bc_errinfo ei = {0};
	struct bc_renderer *r = NULL;
	if (bc_renderer_create(&r, BC_BACKEND_GL, &ro, &ei)) {
		gpu_fail(o, "gl renderer (platform %s): %s",
		         op->platform ? op->platform : "auto", ei.msg);
		return NULL;
	}
	bc_render_gl_info(r, info);
	printf("gl: %s platform%s, GL_RENDERER %s, GL_VERSION %s\n",
	       bc_gl_platform_name(info->platform),
	       info->software_device ? " (software device)" : "",
	       info->renderer, info->version);
	/* On a GPU host a software context would spend the run's minutes
	 * measuring the wrong thing: refuse it. */
	if (op->expect_hardware && gpu_is_software(info)) {
		gpu_fail(o,
		         "a GPU was expected, the context is %s on the %s "
		         "platform%s",
		         info->renderer, bc_gl_platform_name(info->platform),
		         info->software_device ? " (software device)" : "");
		bc_renderer_destroy(r);
		return NULL;
	}
	return r;
}
