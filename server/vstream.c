/*
 * A client's H.264 stream (vstream.h): the encoder of one member's view,
 * reference counted between the loop thread and the worker that encodes.
 */
#include "vstream.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "h264_module.h"

/* ---- the encoder module (h264_module.h), opened once ---------------------- */

static pthread_once_t load_once = PTHREAD_ONCE_INIT;
static const struct bc_srv_h264_ops *ops;
static atomic_bool load_done;
static char load_why[640];

/* Where the module may be, in the order they are tried: $BLOBCASTD_H264_
 * MODULE, beside an installed blobcastd (BIN/../LIBDIR/blobcast/), where
 * the build tree put it. Returns how many (0 for "none"); why says what
 * a failure to find any should. */
#define MODULE_PATHS 3
static uint32_t module_paths(char paths[MODULE_PATHS][PATH_MAX + 128],
                             char *why, size_t why_len)
{
	char exe[PATH_MAX];
	const char *env = getenv(BC_SRV_H264_ENV);
	uint32_t n = 0;
	ssize_t len;
	if (env && strcmp(env, "none") == 0) {
		snprintf(why, why_len, "%s is none", BC_SRV_H264_ENV);
		return 0;
	}
	snprintf(why, why_len, "no %s found (set %s to its path)",
	         BC_SRV_H264_FILE, BC_SRV_H264_ENV);
	if (env && *env) {
		snprintf(paths[n++], sizeof(paths[0]), "%s", env);
	}
	len = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (len > 0) {
		char *slash;
		exe[len] = '\0';
		if ((slash = strrchr(exe, '/'))) {
			*slash = '\0';
			snprintf(paths[n++], sizeof(paths[0]), "%s/%s", exe,
			         BC_SRV_H264_INSTALLED);
		}
	}
	snprintf(paths[n++], sizeof(paths[0]), "%s", BC_SRV_H264_BUILT);
	return n;
}

/* Opens path and takes its table; true when it is this build's module. */
static bool try_module(const char *path)
{
	void *handle, *sym;
	bc_srv_h264_fn entry = NULL;
	const struct bc_srv_h264_ops *o;
	if (!path || access(path, R_OK) != 0) {
		return false;
	}
	if (!(handle = dlopen(path, RTLD_NOW | RTLD_LOCAL))) {
		const char *e = dlerror();
		snprintf(load_why, sizeof(load_why), "%.600s", e ? e : path);
		return false;
	}
	if ((sym = dlsym(handle, BC_SRV_H264_ENTRY))) {
		memcpy(&entry, &sym, sizeof(entry));
	}
	o = entry ? entry() : NULL;
	if (!o || o->abi != BC_SRV_H264_ABI) {
		snprintf(load_why, sizeof(load_why),
		         "%.560s is not this build's H.264 module", path);
		dlclose(handle);
		return false;
	}
	ops = o; /* never closed: encoders live until the daemon ends */
	return true;
}

/* The first module of module_paths that is this build's ("none": no
 * module, no FFmpeg loaded). */
static void load(void)
{
	char paths[MODULE_PATHS][PATH_MAX + 128];
	uint32_t n = module_paths(paths, load_why, sizeof(load_why));
	for (uint32_t i = 0; i < n && !try_module(paths[i]); i++) {
	}
	atomic_store_explicit(&load_done, true, memory_order_release);
}

int bc_vstream_find(struct bc_errinfo *ei)
{
	char paths[MODULE_PATHS][PATH_MAX + 128], why[640];
	uint32_t n = module_paths(paths, why, sizeof(why));
	for (uint32_t i = 0; i < n; i++) {
		if (access(paths[i], R_OK) == 0) {
			return 0;
		}
	}
	return bc_errinfo_set(ei, BC_ENOTSUP, "H.264 encoder: %s", why);
}

int bc_vstream_load(struct bc_errinfo *ei)
{
	pthread_once(&load_once, load);
	return ops ? 0
	           : bc_errinfo_set(ei, BC_ENOTSUP, "H.264 encoder: %s",
	                            load_why);
}

bool bc_vstream_loaded(void)
{
	return atomic_load_explicit(&load_done, memory_order_acquire);
}

static void *preload_run(void *arg)
{
	(void)arg;
	(void)bc_vstream_load(NULL);
	return NULL;
}

/* The preload thread (loop thread only: bc_vstream_preload and
 * bc_vstream_settle). */
static bool preload_started;
static pthread_t preload_thread;

void bc_vstream_preload(void)
{
	if (bc_vstream_loaded() || preload_started) {
		return;
	}
	/* Without the thread the first VIEW of encoding 4 loads it. */
	preload_started =
	    pthread_create(&preload_thread, NULL, preload_run, NULL) == 0;
}

void bc_vstream_settle(void)
{
	if (preload_started) {
		pthread_join(preload_thread, NULL);
		preload_started = false;
	}
}

bool bc_vstream_can_encode(enum bc_video_backend backend)
{
	return bc_vstream_load(NULL) == 0 && ops->available(backend);
}

uint32_t bc_vstream_default_bitrate(uint32_t width, uint32_t height)
{
	return bc_vstream_load(NULL) == 0
	           ? ops->default_bitrate(width, height, 0)
	           : 0u;
}

struct bc_vstream {
	atomic_uint refs;
	/* Set by the loop thread, taken by the worker. */
	atomic_bool restart;
	atomic_uint bitrate;   /* asked; 0: the default */
	atomic_uint delivered; /* access units the loop thread sent */
	/* The worker's. */
	unsigned encoded; /* access units made */
	uint32_t applied; /* bitrate the encoder runs at (0: default) */
	struct bc_video_opts opts;
	char preset[32];
	struct bc_video_encoder *enc;
	uint32_t width, height; /* of enc */
	uint8_t *scaled;        /* a coarse level's picture scaled up */
	size_t scaled_cap;
	uint8_t *rows; /* its rows scaled across, one per traced row */
	size_t rows_cap;
};

struct bc_vstream *bc_vstream_new(const struct bc_video_opts *opts)
{
	struct bc_vstream *vs = bc_calloc(1, sizeof(*vs));
	if (!vs) {
		return NULL;
	}
	atomic_init(&vs->refs, 1u);
	atomic_init(&vs->restart, false);
	atomic_init(&vs->bitrate, 0u);
	atomic_init(&vs->delivered, 0u);
	if (opts) {
		vs->opts = *opts;
	}
	if (vs->opts.x264_preset) {
		snprintf(vs->preset, sizeof(vs->preset), "%s",
		         vs->opts.x264_preset);
		vs->opts.x264_preset = vs->preset;
	}
	return vs;
}

void bc_vstream_ref(struct bc_vstream *vs)
{
	atomic_fetch_add(&vs->refs, 1u);
}

void bc_vstream_unref(struct bc_vstream *vs)
{
	if (!vs || atomic_fetch_sub(&vs->refs, 1u) != 1u) {
		return;
	}
	if (vs->enc) {
		ops->destroy(vs->enc);
	}
	bc_free(vs->scaled);
	bc_free(vs->rows);
	bc_free(vs);
}

void bc_vstream_delivered(struct bc_vstream *vs)
{
	atomic_fetch_add(&vs->delivered, 1u);
}

void bc_vstream_restart(struct bc_vstream *vs)
{
	atomic_store(&vs->restart, true);
}

void bc_vstream_set_bitrate(struct bc_vstream *vs, uint32_t bps)
{
	if (bps != 0 && bps < BC_VIDEO_MIN_BITRATE) {
		bps = BC_VIDEO_MIN_BITRATE;
	}
	if (bps > BC_VIDEO_MAX_BITRATE) {
		bps = BC_VIDEO_MAX_BITRATE;
	}
	atomic_store(&vs->bitrate, bps);
}

/* The encoder for width x height at the asked bitrate, opened or reopened
 * (a new size: a new stream, so an IDR). */
static int ready(struct bc_vstream *vs, uint32_t width, uint32_t height,
                 struct bc_errinfo *ei)
{
	uint32_t bps = atomic_load(&vs->bitrate);
	int rc;
	if ((rc = bc_vstream_load(ei))) {
		return rc;
	}
	if (vs->enc && (vs->width != width || vs->height != height)) {
		ops->destroy(vs->enc);
		vs->enc = NULL;
	}
	if (!vs->enc) {
		struct bc_video_opts o = vs->opts;
		o.bitrate = bps;
		if ((rc = ops->open(width, height, &o, &vs->enc, ei))) {
			return rc;
		}
		vs->width = width;
		vs->height = height;
		vs->applied = bps;
		return 0;
	}
	if (bps != 0 && bps != vs->applied &&
	    ops->set_bitrate(vs->enc, bps, ei) == 0) {
		vs->applied = bps;
	}
	return 0;
}

static bool reserve(uint8_t **p, size_t *cap, size_t bytes)
{
	if (*cap < bytes) {
		uint8_t *q = bc_realloc(*p, bytes);
		if (!q) {
			return false;
		}
		*p = q;
		*cap = bytes;
	}
	return true;
}

/* Row j of the traced samples (view pixels (i << l, j << l)) across the
 * whole width: pixel x between samples x >> l and the next, linearly. */
static void across(const uint8_t *rgba, uint32_t width, uint32_t j, int l,
                   uint8_t *out)
{
	const uint8_t *src = rgba + (size_t)(j << l) * width * 4u;
	uint32_t s = 1u << l, last = (width - 1u) >> l;
	for (uint32_t x = 0; x < width; x++) {
		uint32_t i0 = x >> l, f = x & (s - 1u);
		uint32_t i1 = i0 < last ? i0 + 1u : last;
		const uint8_t *a = src + (size_t)(i0 << l) * 4u;
		const uint8_t *b = src + (size_t)(i1 << l) * 4u;
		for (int k = 0; k < 4; k++) {
			out[(size_t)x * 4u + (size_t)k] =
			    (uint8_t)((a[k] * (s - f) + b[k] * f) >> l);
		}
	}
}

/* The picture of level `level` scaled up to width x height, bilinearly
 * between the traced pixels (the top-left pixel of each 2^level block):
 * smoother than blocks, so the encoder spends its bits on the picture and
 * the client sees what JPEG clients get from their own scaling. Across on
 * the traced rows first, then down, which costs a blend of two rows per
 * output row. */
static const uint8_t *scaled_up(struct bc_vstream *vs, const uint8_t *rgba,
                                uint32_t width, uint32_t height, int level)
{
	size_t row = (size_t)width * 4u;
	uint32_t s = 1u << level, rows;
	if (level <= 0) {
		return rgba;
	}
	rows = ((height - 1u) >> level) + 1u;
	if (!reserve(&vs->scaled, &vs->scaled_cap, row * height) ||
	    !reserve(&vs->rows, &vs->rows_cap, row * rows)) {
		return NULL;
	}
	for (uint32_t j = 0; j < rows; j++) {
		across(rgba, width, j, level, vs->rows + row * j);
	}
	for (uint32_t y = 0; y < height; y++) {
		uint32_t j0 = y >> level, f = y & (s - 1u);
		uint32_t j1 = j0 + 1u < rows ? j0 + 1u : j0;
		const uint8_t *a = vs->rows + row * j0,
		              *b = vs->rows + row * j1;
		uint8_t *dst = vs->scaled + row * y;
		for (size_t k = 0; k < row; k++) {
			dst[k] =
			    (uint8_t)((a[k] * (s - f) + b[k] * f) >> level);
		}
	}
	return vs->scaled;
}

int bc_vstream_encode(struct bc_vstream *vs, const uint8_t *rgba,
                      uint32_t width, uint32_t height, int level, bool still,
                      struct bc_vstream_au *out, struct bc_errinfo *ei)
{
	struct bc_video_au au;
	const uint8_t *pix;
	unsigned flags = still ? BC_VIDEO_STILL : 0u;
	int rc;
	memset(out, 0, sizeof(*out));
	if ((rc = ready(vs, width, height, ei))) {
		return rc;
	}
	/* A restart asked, or an access unit made that never reached the
	 * client: its decoder does not hold what ours does. */
	if (atomic_exchange(&vs->restart, false) ||
	    atomic_load(&vs->delivered) != vs->encoded) {
		flags |= BC_VIDEO_FORCE_IDR;
		atomic_store(&vs->delivered, vs->encoded);
	}
	if (!(pix = scaled_up(vs, rgba, width, height, level))) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "no memory for a scaled picture");
	}
	if ((rc = ops->encode(vs->enc, pix, (size_t)width * 4u, flags, &au,
	                      ei))) {
		return rc;
	}
	if (!(out->data = bc_malloc(au.len ? au.len : 1u))) {
		/* The encoder moved on without it: an IDR next. */
		atomic_store(&vs->restart, true);
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "no memory for an access unit");
	}
	memcpy(out->data, au.data, au.len);
	out->len = au.len;
	out->key = au.idr;
	vs->encoded++;
	return 0;
}
