/*
 * OSMesa, the last resort: Mesa rendering into client memory with no EGL at
 * all. A core-profile context (4.5 down to 4.3) is created with no depth
 * buffer and bound to a one-pixel colour buffer, because OSMesa needs one
 * to make a context current; everything the backend draws goes to its own
 * textures and buffers. OSMesa offers no robustness or reset notification.
 */
#include <GL/osmesa.h>

#include "blobcast/log.h"
#include "gl_platform.h"

int bc__osmesa_open(struct bc__gl_plat *p, struct bc_errinfo *ei)
{
	static const int versions[BC_GL_NVERSIONS][2] = BC_GL_VERSIONS;
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
		OSMesaContext ctx = OSMesaCreateContextAttribs(attribs, NULL);
		if (!ctx) {
			bc_log(BC_LOG_DEBUG,
			       "OSMesaCreateContextAttribs %d.%d core refused",
			       versions[v][0], versions[v][1]);
			continue;
		}
		if (!OSMesaMakeCurrent(ctx, &p->pixel, GL_UNSIGNED_BYTE, 1, 1)) {
			OSMesaDestroyContext(ctx);
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

void bc__osmesa_close(struct bc__gl_plat *p)
{
	if (!p->osmesa) {
		return;
	}
	if (OSMesaGetCurrentContext() == p->osmesa) {
		OSMesaMakeCurrent(NULL, NULL, 0, 0, 0);
	}
	OSMesaDestroyContext(p->osmesa);
	p->osmesa = NULL;
}

int bc__osmesa_bind(struct bc__gl_plat *p, bool bind, struct bc_errinfo *ei)
{
	if (bind) {
		if (OSMesaGetCurrentContext() == p->osmesa) {
			return 0;
		}
		if (!OSMesaMakeCurrent(p->osmesa, &p->pixel, GL_UNSIGNED_BYTE,
				       1, 1)) {
			return bc_errinfo_set(ei, BC_EGL,
					      "OSMesaMakeCurrent failed");
		}
		return 0;
	}
	if (OSMesaGetCurrentContext() == p->osmesa) {
		OSMesaMakeCurrent(NULL, NULL, 0, 0, 0);
	}
	return 0;
}

bc__gl_fn bc__osmesa_proc(const char *name)
{
	/* OSMESAproc is declared without a prototype; casting through
	 * void (*)(void) is the form compilers accept quietly. */
	return (bc__gl_fn)OSMesaGetProcAddress(name);
}
