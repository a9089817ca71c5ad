/*
 * The gl backend's context, whatever its platform: the order in which
 * platforms are tried (a hardware EGL device, then EGL surfaceless, then
 * OSMesa), loading the GL entry points through the platform's own lookup,
 * checking the version and limits the pipeline needs, recording what the
 * driver granted (robust access, reset strategy, debug output), routing
 * GL_KHR_debug messages to our logger and naming GL errors.
 */
#include "gl_priv.h"

#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/log.h"

static const char *const platform_names[BC_GL_PLATFORM_COUNT] = {
    [BC_GL_PLATFORM_AUTO] = "auto",
    [BC_GL_PLATFORM_DEVICE] = "device",
    [BC_GL_PLATFORM_SURFACELESS] = "surfaceless",
    [BC_GL_PLATFORM_OSMESA] = "osmesa",
};

enum bc_gl_platform bc_gl_platform_from_name(const char *name)
{
	if (!name || !*name) {
		return BC_GL_PLATFORM_AUTO;
	}
	for (int p = 0; p < BC_GL_PLATFORM_COUNT; p++) {
		if (strcmp(name, platform_names[p]) == 0) {
			return (enum bc_gl_platform)p;
		}
	}
	return BC_GL_PLATFORM_COUNT;
}

const char *bc_gl_platform_name(enum bc_gl_platform p)
{
	if ((int)p < 0 || p >= BC_GL_PLATFORM_COUNT) {
		return "invalid";
	}
	return platform_names[p];
}

const char *bc__gl_error_name(GLenum e)
{
	switch (e) {
	case GL_NO_ERROR:
		return "GL_NO_ERROR";
	case GL_INVALID_ENUM:
		return "GL_INVALID_ENUM";
	case GL_INVALID_VALUE:
		return "GL_INVALID_VALUE";
	case GL_INVALID_OPERATION:
		return "GL_INVALID_OPERATION";
	case GL_INVALID_FRAMEBUFFER_OPERATION:
		return "GL_INVALID_FRAMEBUFFER_OPERATION";
	case GL_OUT_OF_MEMORY:
		return "GL_OUT_OF_MEMORY";
	case GL_STACK_UNDERFLOW:
		return "GL_STACK_UNDERFLOW";
	case GL_STACK_OVERFLOW:
		return "GL_STACK_OVERFLOW";
	case GL_CONTEXT_LOST:
		return "GL_CONTEXT_LOST";
	default:
		return "unknown GL error";
	}
}

int bc__gl_check(struct bc__gl_ctx *c, const char *stage, struct bc_errinfo *ei)
{
	char names[160] = "";
	size_t len = 0;
	int count = 0;
	GLenum e;
	/* Errors queue up (one per kind); bound the drain in case a lost
	 * context keeps reporting. */
	while (count < 8 && (e = c->gl.GetError()) != GL_NO_ERROR) {
		int n = snprintf(names + len, sizeof(names) - len, "%s%s",
		                 count ? ", " : "", bc__gl_error_name(e));
		if (n > 0 && (size_t)n < sizeof(names) - len) {
			len += (size_t)n;
		}
		count++;
	}
	if (!count) {
		return 0;
	}
	return bc_errinfo_set(ei, BC_EGL, "gl: %s: %s", stage, names);
}

static void GLAD_API_PTR debug_cb(GLenum source, GLenum type, GLuint id,
                                  GLenum severity, GLsizei length,
                                  const GLchar *message, const void *user)
{
	enum bc_log_level level = BC_LOG_DEBUG;
	(void)source;
	(void)length;
	(void)user;
	if (severity == GL_DEBUG_SEVERITY_HIGH || type == GL_DEBUG_TYPE_ERROR) {
		level = BC_LOG_WARN;
	} else if (severity == GL_DEBUG_SEVERITY_MEDIUM) {
		level = BC_LOG_INFO;
	}
	bc_log(level, "GL debug %u: %s", (unsigned)id, message);
}

/* glad's loader signature, with the platform in the user pointer. */
static GLADapiproc load_proc(void *user, const char *name)
{
	const struct bc__gl_plat *p = user;
#if defined(BLOBCAST_GL_OSMESA)
	if (p->platform == BC_GL_PLATFORM_OSMESA) {
		return (GLADapiproc)bc__osmesa_proc(name);
	}
#else
	(void)p; /* no OSMesa context is ever opened */
#endif
	return (GLADapiproc)bc__egl_proc(name);
}

/* Limits the shaders assume (shaders/common.glsl, trace.comp). */
static int check_limits(struct bc__gl_ctx *c, struct bc_errinfo *ei)
{
	GladGLContext *gl = &c->gl;
	GLint v = 0;
	gl->GetIntegerv(GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS, &v);
	if (v < BC__GL_BUF_COUNT) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "gl: %d storage buffer bindings, the "
		                      "pipeline needs %d",
		                      (int)v, BC__GL_BUF_COUNT);
	}
	gl->GetIntegerv(GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS, &v);
	if (v < 10) {
		/* trace.comp reads nine buffers and marks the short rays
		 * in a tenth. */
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "gl: %d storage blocks per compute "
		                      "shader, the tracer needs 10",
		                      (int)v);
	}
	gl->GetIntegerv(GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS, &v);
	if (v < 4) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "gl: %d storage blocks per fragment "
		                      "shader, the A-buffer needs 4",
		                      (int)v);
	}
	gl->GetIntegerv(GL_MAX_COMPUTE_SHARED_MEMORY_SIZE, &v);
	c->info.shared_bytes = v > 0 ? (uint32_t)v : 0;
	return bc__gl_check(c, "limits", ei);
}

/* ---- Software contexts ---------------------------------------------------
 *
 * Two render threads drawing with two llvmpipe contexts at once read memory
 * Mesa had freed: a gl daemon with two workers and three sessions crashed
 * inside swrast_dri.so once ASan filled freed memory (max_free_fill_size),
 * and is clean with one worker. Whether the fault is Mesa's or a rule of
 * EGL's we break is not known yet; until it is, the contexts of a software
 * renderer take turns: a process-wide lock is held from binding to
 * unbinding (and while a context is opened). llvmpipe spreads each draw
 * over its own threads, so little is lost. Hardware contexts run at once. */

static pthread_mutex_t soft_turn = PTHREAD_MUTEX_INITIALIZER;

static void take_turn(struct bc__gl_ctx *c)
{
	if (!c->locked) {
		pthread_mutex_lock(&soft_turn);
		c->locked = true;
	}
}

static void give_turn(struct bc__gl_ctx *c)
{
	if (c->locked) {
		c->locked = false;
		pthread_mutex_unlock(&soft_turn);
	}
}

/* After the context is current: entry points, version, what was granted. */
static int finish_open(struct bc__gl_ctx *c, struct bc_errinfo *ei)
{
	GladGLContext *gl = &c->gl;
	const GLubyte *s;
	GLint flags = 0, strategy = 0;
	int version = gladLoadGLContextUserPtr(gl, load_proc, &c->plat);
	if (!version) {
		return bc_errinfo_set(ei, BC_EGL,
		                      "gl: loading the entry points failed "
		                      "(no glGetString?)");
	}
	c->info.platform = c->plat.platform;
	c->info.software_device = c->plat.software_device;
	c->info.major = GLAD_VERSION_MAJOR(version);
	c->info.minor = GLAD_VERSION_MINOR(version);
	if (c->info.major < 4 || (c->info.major == 4 && c->info.minor < 3) ||
	    !gl->DispatchCompute) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "gl: OpenGL %d.%d has no compute shaders "
		                      "(4.3 needed)",
		                      c->info.major, c->info.minor);
	}
	if ((s = gl->GetString(GL_RENDERER)) != NULL) {
		snprintf(c->info.renderer, sizeof(c->info.renderer), "%s",
		         (const char *)s);
	}
	if ((s = gl->GetString(GL_VERSION)) != NULL) {
		snprintf(c->info.version, sizeof(c->info.version), "%s",
		         (const char *)s);
	}
	gl->GetIntegerv(GL_CONTEXT_FLAGS, &flags);
	c->info.robust_access =
	    (flags & GL_CONTEXT_FLAG_ROBUST_ACCESS_BIT) != 0;
	gl->GetIntegerv(GL_RESET_NOTIFICATION_STRATEGY, &strategy);
	c->info.lose_on_reset = strategy == GL_LOSE_CONTEXT_ON_RESET;
	if (gl->DebugMessageCallback) {
		/* Debug contexts (asked for at the debug log level) report by
		 * default; others only when enabled, which costs speed. */
		gl->DebugMessageCallback(debug_cb, NULL);
		if (bc_log_level() >= BC_LOG_DEBUG) {
			gl->Enable(GL_DEBUG_OUTPUT);
		}
		c->info.debug_output = bc_log_level() >= BC_LOG_DEBUG ||
		                       (flags & GL_CONTEXT_FLAG_DEBUG_BIT) != 0;
	}
	/* glGetIntegerv of the reset strategy is 4.5 or KHR_robustness;
	 * older contexts report an error here that means "not granted". */
	while (gl->GetError() != GL_NO_ERROR) {
	}
	bc_log(BC_LOG_INFO,
	       "gl: %s platform%s, %s, %s; robust access %s, reset %s",
	       bc_gl_platform_name(c->info.platform),
	       c->info.software_device ? " (software device)" : "",
	       c->info.renderer, c->info.version,
	       c->info.robust_access ? "granted" : "not granted",
	       c->info.lose_on_reset ? "loses the context" : "not notified");
	if (c->plat.asked_robust && !c->info.robust_access) {
		bc_log(BC_LOG_INFO, "gl: robust access asked for, not granted");
	}
	return check_limits(c, ei);
}

/* Opens one platform; BC_ENOTSUP means "not here, try the next". */
static int open_one(struct bc__gl_ctx *c, enum bc_gl_platform p, bool any,
                    struct bc_errinfo *ei)
{
	bool debug = bc_log_level() >= BC_LOG_DEBUG;
	int rc;
	memset(&c->plat, 0, sizeof(c->plat));
	/* Which renderer it is shows only once it is open. */
	take_turn(c);
	switch (p) {
	case BC_GL_PLATFORM_DEVICE:
	case BC_GL_PLATFORM_SURFACELESS:
#if defined(BLOBCAST_GL_EGL)
		rc = bc__egl_open(&c->plat, p, any, debug, ei);
#else
		(void)any;
		(void)debug;
		rc = bc_errinfo_set(ei, BC_ENOTSUP, "gl: built without EGL");
#endif
		break;
	case BC_GL_PLATFORM_OSMESA:
#if defined(BLOBCAST_GL_OSMESA)
		rc = bc__osmesa_open(&c->plat, ei);
#else
		rc = bc_errinfo_set(ei, BC_ENOTSUP, "gl: built without OSMesa");
#endif
		break;
	default:
		rc =
		    bc_errinfo_set(ei, BC_EINVAL, "gl: no platform %d", (int)p);
		break;
	}
	if (rc) {
		give_turn(c);
		return rc;
	}
	if ((rc = finish_open(c, ei))) {
		bc__gl_ctx_close(c);
		return rc;
	}
	c->serialize = c->info.software_device ||
	               c->info.platform == BC_GL_PLATFORM_OSMESA ||
	               strstr(c->info.renderer, "llvmpipe") ||
	               strstr(c->info.renderer, "softpipe");
	if (!c->serialize) {
		give_turn(c);
	}
	return 0;
}

int bc__gl_ctx_open(struct bc__gl_ctx *c, enum bc_gl_platform platform,
                    struct bc_errinfo *ei)
{
	static const enum bc_gl_platform order[] = {BC_GL_PLATFORM_DEVICE,
	                                            BC_GL_PLATFORM_SURFACELESS,
	                                            BC_GL_PLATFORM_OSMESA};
	char why[3][96];
	int rc = BC_ENOTSUP;
	memset(c, 0, sizeof(*c));
	if (platform != BC_GL_PLATFORM_AUTO) {
		return open_one(c, platform, true, ei);
	}
	for (size_t i = 0; i < sizeof(order) / sizeof(order[0]); i++) {
		struct bc_errinfo mine = {0};
		/* Auto skips software devices: surfaceless is the same
		 * renderer, reached without enumerating devices. */
		if ((rc = open_one(c, order[i], false, &mine)) == 0) {
			return 0;
		}
		snprintf(why[i], sizeof(why[i]), "%.95s", mine.msg);
		bc_log(BC_LOG_INFO, "gl: %s platform: %s",
		       bc_gl_platform_name(order[i]), mine.msg);
	}
	return bc_errinfo_set(ei, rc,
	                      "gl: no context on any platform (device: %s; "
	                      "surfaceless: %s; osmesa: %s)",
	                      why[0], why[1], why[2]);
}

void bc__gl_ctx_close(struct bc__gl_ctx *c)
{
	if (!c) {
		return;
	}
#if defined(BLOBCAST_GL_EGL)
	bc__egl_close(&c->plat);
#endif
#if defined(BLOBCAST_GL_OSMESA)
	bc__osmesa_close(&c->plat);
#endif
	memset(&c->plat, 0, sizeof(c->plat));
	give_turn(c);
}

int bc__gl_ctx_bind(struct bc__gl_ctx *c, struct bc_errinfo *ei)
{
	int rc = 0;
	bool bound = false;
	if (c->serialize) {
		take_turn(c);
	}
	if (c->plat.platform == BC_GL_PLATFORM_OSMESA) {
#if defined(BLOBCAST_GL_OSMESA)
		rc = bc__osmesa_bind(&c->plat, true, ei);
		bound = true;
#endif
	} else if (c->plat.platform != BC_GL_PLATFORM_AUTO) {
#if defined(BLOBCAST_GL_EGL)
		rc = bc__egl_bind(&c->plat, true, ei);
		bound = true;
#endif
	}
	if (!bound) {
		rc = bc_errinfo_set(ei, BC_ESTATE, "gl: no context");
	}
	if (rc) {
		give_turn(c);
	}
	return rc;
}

void bc__gl_ctx_unbind(struct bc__gl_ctx *c)
{
	struct bc_errinfo ei = {0};
	int rc = 0;
	if (c->plat.platform == BC_GL_PLATFORM_OSMESA) {
#if defined(BLOBCAST_GL_OSMESA)
		rc = bc__osmesa_bind(&c->plat, false, &ei);
#endif
	} else if (c->plat.platform != BC_GL_PLATFORM_AUTO) {
#if defined(BLOBCAST_GL_EGL)
		rc = bc__egl_bind(&c->plat, false, &ei);
#endif
	}
	if (rc) {
		bc_log(BC_LOG_WARN, "%s", ei.msg);
	}
	give_turn(c);
}
