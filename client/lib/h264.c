/*
 * Finding and opening bc_client_h264.so (h264_module.h says why it is a
 * module), once per process. It is looked for, in order, at
 * $BLOBCAST_H264_MODULE; in blobcast/ beside the object libblobcast is in
 * (LIBDIR/blobcast/ for the installed libblobcast.so); beside an installed
 * program (BIN/../LIBDIR/blobcast/); and where the build tree put it.
 */
#define _GNU_SOURCE /* dladdr */
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "h264_module.h"

static pthread_once_t load_once = PTHREAD_ONCE_INIT;
static const struct bc_h264_ops *loaded;
static char why[768];

/* Opens path and takes its table; 0 when it is a module of this build. */
static int try_module(const char *path)
{
	void *handle, *sym;
	bc_h264_module_fn entry = NULL;
	const struct bc_h264_ops *o;
	if (access(path, R_OK) != 0) {
		return -1;
	}
	if (!(handle = dlopen(path, RTLD_NOW | RTLD_LOCAL))) {
		const char *e = dlerror();
		snprintf(why, sizeof(why), "%s", e ? e : path);
		return -1;
	}
	if ((sym = dlsym(handle, BC_H264_MODULE_ENTRY))) {
		memcpy(&entry, &sym, sizeof(entry));
	}
	o = entry ? entry() : NULL;
	if (!o || o->abi != BC_H264_MODULE_ABI) {
		snprintf(why, sizeof(why),
		         "%s is not this build's H.264 module", path);
		dlclose(handle);
		return -1;
	}
	/* Never closed: decoders may live until the process ends. */
	loaded = o;
	return 0;
}

/* Tries dir + "/" + rel; 0 when the module loaded. */
static int try_in(const char *file, const char *rel)
{
	char dir[PATH_MAX], path[PATH_MAX + 128];
	char *slash;
	if (!file || strlen(file) >= sizeof(dir)) {
		return -1;
	}
	memcpy(dir, file, strlen(file) + 1);
	if (!(slash = strrchr(dir, '/'))) {
		return -1;
	}
	*slash = '\0';
	snprintf(path, sizeof(path), "%s/%s", dir, rel);
	return try_module(path);
}

static void load(void)
{
	const char *env = getenv(BC_H264_MODULE_ENV);
	char exe[PATH_MAX];
	ssize_t n;
	Dl_info self;
	why[0] = '\0';
	if (env && *env) {
		if (try_module(env) && !why[0]) {
			snprintf(why, sizeof(why), "%s cannot be read", env);
		}
		return;
	}
	if (dladdr((void *)(uintptr_t)bc__client_h264, &self) &&
	    try_in(self.dli_fname, "blobcast/" BC_H264_MODULE_FILE) == 0) {
		return;
	}
	n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (n > 0) {
		exe[n] = '\0';
		if (try_in(exe, BC_H264_MODULE_INSTALLED) == 0) {
			return;
		}
	}
	(void)try_module(BC_H264_MODULE_BUILT);
}

int bc__client_h264(const struct bc_h264_ops **ops, struct bc_errinfo *ei)
{
	const char *env = getenv(BC_H264_MODULE_ENV);
	pthread_once(&load_once, load);
	*ops = loaded;
	if (loaded) {
		return 0;
	}
	if (env && *env) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "H.264 frames need the decoder module "
		                      "%s: %s; name it in %s, or unset that",
		                      BC_H264_MODULE_FILE, why,
		                      BC_H264_MODULE_ENV);
	}
	return bc_errinfo_set(ei, BC_ENOTSUP,
	                      "H.264 frames need the decoder module %s, "
	                      "not found in blobcast/ beside libblobcast or "
	                      "the program, nor in the build tree%s%s; "
	                      "install it or name it in %s",
	                      BC_H264_MODULE_FILE, why[0] ? ": " : "", why,
	                      BC_H264_MODULE_ENV);
}
