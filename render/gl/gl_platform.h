/*
 * The window-system halves of the gl backend: EGL (device and surfaceless
 * platforms, egl.c) and OSMesa (osmesa.c). They create, bind and destroy a
 * context and look entry points up; they see no GL header, because OSMesa's
 * own header drags in <GL/gl.h>, which cannot share a file with glad's.
 */
#ifndef BLOBCAST_RENDER_GL_PLATFORM_H
#define BLOBCAST_RENDER_GL_PLATFORM_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/error.h"
#include "blobcast/render_gl.h"

typedef void (*bc__gl_fn)(void);

/* The context versions asked for, newest first: 4.5 core (drivers that have
 * more hand out their newest compatible version anyway); 4.3 is the least
 * with compute shaders. */
#define BC_GL_VERSIONS                                                         \
	{                                                                      \
		{4, 5}, {4, 4},                                                \
		{                                                              \
			4, 3                                                   \
		}                                                              \
	}
#define BC_GL_NVERSIONS 3

struct bc__gl_plat {
	enum bc_gl_platform platform; /* INVALID (AUTO) while closed */
	void *display;                /* EGLDisplay */
	void *context;                /* EGLContext */
	void *osmesa;                 /* OSMesaContext */
	uint32_t pixel;               /* the 1x1 colour buffer OSMesa binds */
	bool software_device;
	bool asked_robust; /* the context was created with robustness asked */
	int major, minor;  /* the version asked for that was granted */
};

/* EGL. which is DEVICE or SURFACELESS; for DEVICE, any_device admits
 * software devices (Mesa's llvmpipe device) after the hardware ones. debug
 * asks for a debug context. The context is left current. Returns 0,
 * BC_ENOTSUP (the platform's extension is missing: try the next) or BC_EGL,
 * naming the failed call and its error in ei. */
int bc__egl_open(struct bc__gl_plat *p, enum bc_gl_platform which,
                 bool any_device, bool debug, struct bc_errinfo *ei);
void bc__egl_close(struct bc__gl_plat *p);
int bc__egl_bind(struct bc__gl_plat *p, bool bind, struct bc_errinfo *ei);
bc__gl_fn bc__egl_proc(const char *name);

/* OSMesa, same contract. */
int bc__osmesa_open(struct bc__gl_plat *p, struct bc_errinfo *ei);
void bc__osmesa_close(struct bc__gl_plat *p);
int bc__osmesa_bind(struct bc__gl_plat *p, bool bind, struct bc_errinfo *ei);
bc__gl_fn bc__osmesa_proc(const char *name);

#endif
