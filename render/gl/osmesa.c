/*
 * OSMesa, the last resort: Mesa rendering into client memory with no EGL at
 * all. A core-profile context (4.5 down to 4.3) is created with no depth
 * buffer and bound to a one-pixel colour buffer, because OSMesa needs one
 * to make a context current; everything the backend draws goes to its own
 * textures and buffers. OSMesa offers no robustness or reset notification.
 *
 * libOSMesa is opened with dlopen the first time a context is asked for,
 * not linked: it brings libLLVM, and every program that links the gl
 * backend (the blobcast CLI among them) would otherwise spend about 80 ms
 * loading and relocating it at start even when it never renders
 * (docs/benchmarks.md, "CLI start-up"). Only its header is used at build
 * time, for the types and attribute tokens. The library stays loaded until
 * the process ends: LLVM registers process-wide state (options, signal
 * handlers) that does not survive dlclose, and a context may be created
 * again later. Sanitizer builds open it the same way; their programs start
 * with the options of base/asan_defaults.c, without which LeakSanitizer's
 * exit-time check crashed once libLLVM had come by dlopen, and a test that
 * renders through OSMesa there names the library in its LeakSanitizer
 * suppressions (tests/gl/lsan.supp) for the state it keeps.
 */
#include <GL/osmesa.h>
#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/log.h"
#include "gl_platform.h"

#ifndef BLOBCAST_OSMESA_LIB
#define BLOBCAST_OSMESA_LIB "libOSMesa.so"
#endif

/* The five entry points the backend uses. */
static struct {
	OSMesaContext (*create)(const int *attribs, OSMesaContext share);
	GLboolean (*make_current)(OSMesaContext ctx, void *buffer, GLenum type,
	                          GLsizei width, GLsizei height);
	void (*destroy)(OSMesaContext ctx);
	OSMesaContext (*get_current)(void);
	OSMESAproc (*get_proc)(const char *name);
} api;
/* Empty once the library is loaded, else why it is not. */
static char load_error[512];
static pthread_once_t load_once = PTHREAD_ONCE_INIT;

/* dlsym returns an object pointer; copying its bytes is the conversion to
 * a function pointer that POSIX guarantees and ISO C does not forbid. */
static bool sym(void *lib, const char *name, void *fn, size_t size)
{
	void *p = dlsym(lib, name);
	if (!p) {
		snprintf(load_error, sizeof(load_error), "%s: no symbol %s",
		         BLOBCAST_OSMESA_LIB, name);
		return false;
	}
	memcpy(fn, &p, size);
	return true;
}

static void load(void)
{
	/* The runtime package's name first (no -dev package on a server),
	 * then the file the build found. */
	static const char *const names[] = {"libOSMesa.so.8",
	                                    BLOBCAST_OSMESA_LIB};
	void *lib = NULL;
	for (size_t i = 0; i < sizeof(names) / sizeof(names[0]) && !lib; i++) {
		lib = dlopen(names[i], RTLD_NOW | RTLD_LOCAL);
	}
	if (!lib) {
		const char *why = dlerror();
		snprintf(load_error, sizeof(load_error), "cannot load %s: %s",
		         names[0], why ? why : "unknown reason");
		return;
	}
	if (!sym(lib, "OSMesaCreateContextAttribs", &api.create,
	         sizeof(api.create)) ||
	    !sym(lib, "OSMesaMakeCurrent", &api.make_current,
	         sizeof(api.make_current)) ||
	    !sym(lib, "OSMesaDestroyContext", &api.destroy,
	         sizeof(api.destroy)) ||
	    !sym(lib, "OSMesaGetCurrentContext", &api.get_current,
	         sizeof(api.get_current)) ||
	    !sym(lib, "OSMesaGetProcAddress", &api.get_proc,
	         sizeof(api.get_proc))) {
		/* Never dlclose (see the top of this file). */
		memset(&api, 0, sizeof(api));
		return;
	}
	load_error[0] = '\0';
}

int bc__osmesa_open(struct bc__gl_plat *p, struct bc_errinfo *ei)
{
	static const int versions[BC_GL_NVERSIONS][2] = BC_GL_VERSIONS;
	pthread_once(&load_once, load);
	if (!api.create) {
		return bc_errinfo_set(ei, BC_ENOTSUP, "OSMesa: %s", load_error);
	}
	for (int v = 0; v < BC_GL_NVERSIONS; v++) {
		const int attribs[] = {OSMESA_FORMAT,
		                       OSMESA_RGBA,
		                       OSMESA_DEPTH_BITS,
		                       0,
		                       OSMESA_STENCIL_BITS,
		                       0,
		                       OSMESA_PROFILE,
		                       OSMESA_CORE_PROFILE,
		                       OSMESA_CONTEXT_MAJOR_VERSION,
		                       versions[v][0],
		                       OSMESA_CONTEXT_MINOR_VERSION,
		                       versions[v][1],
		                       0};
		OSMesaContext ctx = api.create(attribs, NULL);
		if (!ctx) {
			bc_log(BC_LOG_DEBUG,
			       "OSMesaCreateContextAttribs %d.%d core refused",
			       versions[v][0], versions[v][1]);
			continue;
		}
		if (!api.make_current(ctx, &p->pixel, GL_UNSIGNED_BYTE, 1, 1)) {
			api.destroy(ctx);
			return bc_errinfo_set(ei, BC_EGL,
			                      "OSMesaMakeCurrent failed");
		}
		p->osmesa = ctx;
		p->platform = BC_GL_PLATFORM_OSMESA;
		p->major = versions[v][0];
		p->minor = versions[v][1];
		return 0;
	}
	return bc_errinfo_set(ei, BC_EGL,
	                      "OSMesaCreateContextAttribs failed for OpenGL "
	                      "4.3 to 4.5 core");
}

/* close, bind and proc run only on a context open succeeded for, so the
 * library is loaded whenever they are called. */
void bc__osmesa_close(struct bc__gl_plat *p)
{
	if (!p->osmesa) {
		return;
	}
	if (api.get_current() == p->osmesa) {
		api.make_current(NULL, NULL, 0, 0, 0);
	}
	api.destroy(p->osmesa);
	p->osmesa = NULL;
}

int bc__osmesa_bind(struct bc__gl_plat *p, bool bind, struct bc_errinfo *ei)
{
	if (bind) {
		if (api.get_current() == p->osmesa) {
			return 0;
		}
		if (!api.make_current(p->osmesa, &p->pixel, GL_UNSIGNED_BYTE, 1,
		                      1)) {
			return bc_errinfo_set(ei, BC_EGL,
			                      "OSMesaMakeCurrent failed");
		}
		return 0;
	}
	if (api.get_current() == p->osmesa) {
		api.make_current(NULL, NULL, 0, 0, 0);
	}
	return 0;
}

bc__gl_fn bc__osmesa_proc(const char *name)
{
	/* OSMESAproc is declared without a prototype; casting through
	 * void (*)(void) is the form compilers accept quietly. */
	return (bc__gl_fn)api.get_proc(name);
}
