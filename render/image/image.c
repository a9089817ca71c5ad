/*
 * blobcast/image.h for every program: the cheap answers here, the file work
 * in the OpenImageIO module (image.cpp, built as bc_image_oiio), which is
 * loaded with dlopen() the first time a file is read or written
 * (image_module.h says why). The module is looked for, in order, at
 * $BLOBCAST_IMAGE_MODULE, beside an installed program
 * (BIN/../LIBDIR/blobcast/), and where the build tree put it.
 */
#include "blobcast/image.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "image_module.h"

static pthread_once_t load_once = PTHREAD_ONCE_INIT;
static const struct bc_image_ops *ops;
static char load_error[512];

static void *host_calloc(size_t n, size_t size)
{
	return bc_calloc(n, size);
}

static void host_free(void *ptr)
{
	bc_free(ptr);
}

static const struct bc_image_host host = {host_calloc, host_free,
                                          bc_image_ext_supports};

/* Opens path and asks it for its functions; 0 when it provided them. */
static int try_module(const char *path)
{
	void *handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
	if (!handle) {
		const char *why = dlerror();
		snprintf(load_error, sizeof(load_error), "%s",
		         why ? why : path);
		return -1;
	}
	void *sym = dlsym(handle, BC_IMAGE_MODULE_ENTRY);
	bc_image_module_open_fn open_fn = NULL;
	if (sym) {
		memcpy(&open_fn, &sym, sizeof(open_fn));
	}
	const struct bc_image_ops *o = open_fn ? open_fn(&host) : NULL;
	if (!o || o->abi != BC_IMAGE_MODULE_ABI) {
		snprintf(load_error, sizeof(load_error),
		         "%s: not an image module of this build", path);
		dlclose(handle);
		return -1;
	}
	ops = o;
	return 0;
}

static void load_module(void)
{
	const char *env = getenv("BLOBCAST_IMAGE_MODULE");
	if (env && *env) {
		(void)try_module(env);
		return;
	}
	char exe[PATH_MAX];
	ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (n > 0) {
		exe[n] = '\0';
		char *slash = strrchr(exe, '/');
		char path[PATH_MAX + 64];
		if (slash) {
			*slash = '\0';
			snprintf(path, sizeof(path), "%s/%s", exe,
			         BC_IMAGE_MODULE_INSTALLED);
			if (access(path, R_OK) == 0 && try_module(path) == 0) {
				return;
			}
		}
	}
	if (access(BC_IMAGE_MODULE_BUILT, R_OK) == 0) {
		(void)try_module(BC_IMAGE_MODULE_BUILT);
		return;
	}
	if (!load_error[0]) {
		snprintf(load_error, sizeof(load_error),
		         "bc_image_oiio not found (installed beside the "
		         "program or at BLOBCAST_IMAGE_MODULE)");
	}
}

static void load_and_report(void)
{
	load_module();
	if (!ops) {
		/* Once, so that a caller which only asks whether a format is
		 * supported still tells the user why none is. */
		bc_log(BC_LOG_ERROR,
		       "image files need the OpenImageIO module: %s",
		       load_error);
	}
}

/* The module's functions, or NULL with the reason in ei. */
static const struct bc_image_ops *module(struct bc_errinfo *ei)
{
	pthread_once(&load_once, load_and_report);
	if (!ops) {
		bc_errinfo_set(ei, BC_ENOTSUP,
		               "image files need the OpenImageIO module: %s",
		               load_error);
	}
	return ops;
}

/* Whether the extension of path, ignoring case, is one of the NULL-ended
 * list. */
static bool ext_is(const char *path, const char *const *exts)
{
	const char *slash = strrchr(path, '/');
	const char *dot = strrchr(path, '.');
	if (!dot || (slash && dot < slash)) {
		return false;
	}
	for (; *exts; exts++) {
		const char *a = dot + 1, *b = *exts;
		while (
		    *a && *b &&
		    (*a == *b || (*a >= 'A' && *a <= 'Z' && *a + 32 == *b))) {
			a++;
			b++;
		}
		if (!*a && !*b) {
			return true;
		}
	}
	return false;
}

bool bc_image_ext_supports(const char *path, enum bc_image_type type)
{
	static const char *const f32[] = {"tif", "tiff", "exr", "pfm", NULL};
	static const char *const u32[] = {"tif", "tiff", "exr", NULL};
	if (!path) {
		return false;
	}
	switch (type) {
	case BC_IMAGE_F32:
		return ext_is(path, f32);
	case BC_IMAGE_U32:
		return ext_is(path, u32);
	case BC_IMAGE_U8: {
		const struct bc_image_ops *o = module(NULL);
		return o && o->ext_supports_u8(path);
	}
	default:
		return false;
	}
}

int bc_image_write(const char *path, const struct bc_image *img,
                   struct bc_errinfo *ei)
{
	const struct bc_image_ops *o = module(ei);
	return o ? o->write(path, img, ei) : BC_ENOTSUP;
}

int bc_image_write_rgba8(const char *path, uint32_t width, uint32_t height,
                         const uint8_t *rgba, struct bc_errinfo *ei)
{
	struct bc_image img = {width, height, 4, BC_IMAGE_U8, (void *)rgba};
	return bc_image_write(path, &img, ei);
}

int bc_image_write_float(const char *path, uint32_t width, uint32_t height,
                         const float *values, struct bc_errinfo *ei)
{
	struct bc_image img = {width, height, 1, BC_IMAGE_F32, (void *)values};
	return bc_image_write(path, &img, ei);
}

int bc_image_write_u32(const char *path, uint32_t width, uint32_t height,
                       const uint32_t *values, struct bc_errinfo *ei)
{
	struct bc_image img = {width, height, 1, BC_IMAGE_U32, (void *)values};
	return bc_image_write(path, &img, ei);
}

int bc_image_read(const char *path, enum bc_image_type type,
                  struct bc_image *out, struct bc_errinfo *ei)
{
	if (!out) {
		return bc_errinfo_set(ei, BC_EINVAL, "image read: no output");
	}
	memset(out, 0, sizeof(*out));
	const struct bc_image_ops *o = module(ei);
	return o ? o->read(path, type, out, ei) : BC_ENOTSUP;
}

void bc_image_finish(struct bc_image *img)
{
	if (img) {
		bc_free(img->pixels);
		memset(img, 0, sizeof(*img));
	}
}
