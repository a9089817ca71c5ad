/*
 * EGL without a display server: the device platform (EGL_EXT_platform_device,
 * a real GPU such as NVIDIA's headless driver) and Mesa's surfaceless
 * platform (llvmpipe on CPU-only hosts). A context is created with no
 * config and no surface (EGL_KHR_no_config_context,
 * EGL_KHR_surfaceless_context), core profile, asking for robust buffer
 * access and lose-context-on-reset where the display offers them (a lost
 * GPU then makes frames fail instead of hanging the daemon).
 *
 * Every call is checked and a failure names the call and the EGL error.
 * Extension lists are matched by exact token. EGL_KHR_debug messages are
 * routed to our logger.
 *
 * Displays are process-wide in EGL: eglGetPlatformDisplay returns the same
 * handle for the same device, and eglTerminate would end it for every
 * context on it. Displays are therefore initialized once and never
 * terminated: each renderer destroys its own context, and the display
 * lives as long as the process. Terminating the last one would also unload
 * Mesa's driver module with its process-wide allocations still held (leak
 * checkers report them) and make the next renderer load it again.
 */
#define EGL_NO_X11
#define MESA_EGL_NO_X11_HEADERS
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <pthread.h>
#include <string.h>

#include "blobcast/log.h"
#include "gl_platform.h"

/* Devices looked at on the device platform: more GPUs than one machine
 * carries. */
#define MAX_DEVICES 16
/* Displays held at once (one per device and one surfaceless). */
#define MAX_DISPLAYS (MAX_DEVICES + 1)

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static EGLDisplay displays[MAX_DISPLAYS];
static bool debug_installed;

static const char *egl_error_name(EGLint e)
{
	switch (e) {
	case EGL_SUCCESS:
		return "EGL_SUCCESS";
	case EGL_NOT_INITIALIZED:
		return "EGL_NOT_INITIALIZED";
	case EGL_BAD_ACCESS:
		return "EGL_BAD_ACCESS";
	case EGL_BAD_ALLOC:
		return "EGL_BAD_ALLOC";
	case EGL_BAD_ATTRIBUTE:
		return "EGL_BAD_ATTRIBUTE";
	case EGL_BAD_CONFIG:
		return "EGL_BAD_CONFIG";
	case EGL_BAD_CONTEXT:
		return "EGL_BAD_CONTEXT";
	case EGL_BAD_CURRENT_SURFACE:
		return "EGL_BAD_CURRENT_SURFACE";
	case EGL_BAD_DISPLAY:
		return "EGL_BAD_DISPLAY";
	case EGL_BAD_MATCH:
		return "EGL_BAD_MATCH";
	case EGL_BAD_NATIVE_PIXMAP:
		return "EGL_BAD_NATIVE_PIXMAP";
	case EGL_BAD_NATIVE_WINDOW:
		return "EGL_BAD_NATIVE_WINDOW";
	case EGL_BAD_PARAMETER:
		return "EGL_BAD_PARAMETER";
	case EGL_BAD_SURFACE:
		return "EGL_BAD_SURFACE";
	case EGL_CONTEXT_LOST:
		return "EGL_CONTEXT_LOST";
	case EGL_BAD_DEVICE_EXT:
		return "EGL_BAD_DEVICE_EXT";
	default:
		return "unknown EGL error";
	}
}

/* Records the failure of call with the pending EGL error. */
static int fail(struct bc_errinfo *ei, const char *call)
{
	EGLint e = eglGetError();
	return bc_errinfo_set(ei, BC_EGL, "%s failed: %s (0x%04x)", call,
	                      egl_error_name(e), (unsigned)e);
}

/* Exact token match in a space-separated extension list. */
static bool has_ext(const char *list, const char *name)
{
	size_t n = strlen(name);
	const char *p = list;
	if (!list) {
		return false;
	}
	while ((p = strstr(p, name)) != NULL) {
		bool starts = p == list || p[-1] == ' ';
		bool ends = p[n] == ' ' || p[n] == '\0';
		if (starts && ends) {
			return true;
		}
		p += n;
	}
	return false;
}

static void EGLAPIENTRY debug_cb(EGLenum error, const char *command,
                                 EGLint type, EGLLabelKHR thread,
                                 EGLLabelKHR object, const char *message)
{
	enum bc_log_level level = BC_LOG_DEBUG;
	(void)thread;
	(void)object;
	/* Failures that matter come back to the caller, who names them; the
	 * driver's own reports are detail. Mesa reports an error for every
	 * hardware driver it probes and does not find ("DRI2: failed to
	 * load driver") before it settles on llvmpipe. */
	if (type == EGL_DEBUG_MSG_CRITICAL_KHR) {
		level = BC_LOG_WARN;
	} else if (type == EGL_DEBUG_MSG_ERROR_KHR) {
		level = BC_LOG_INFO;
	}
	bc_log(level, "EGL: %s: %s (%s)", command ? command : "?",
	       message ? message : "", egl_error_name((EGLint)error));
}

static void install_debug(const char *client_exts)
{
	PFNEGLDEBUGMESSAGECONTROLKHRPROC control;
	static const EGLAttrib attribs[] = {EGL_DEBUG_MSG_CRITICAL_KHR,
	                                    EGL_TRUE,
	                                    EGL_DEBUG_MSG_ERROR_KHR,
	                                    EGL_TRUE,
	                                    EGL_DEBUG_MSG_WARN_KHR,
	                                    EGL_TRUE,
	                                    EGL_DEBUG_MSG_INFO_KHR,
	                                    EGL_FALSE,
	                                    EGL_NONE};
	if (debug_installed || !has_ext(client_exts, "EGL_KHR_debug")) {
		return;
	}
	control = (PFNEGLDEBUGMESSAGECONTROLKHRPROC)eglGetProcAddress(
	    "eglDebugMessageControlKHR");
	if (control && control(debug_cb, attribs) == EGL_SUCCESS) {
		debug_installed = true;
	}
}

/* Initializes display d, once per process. Called with lock held. */
static int display_init(EGLDisplay d, struct bc_errinfo *ei)
{
	EGLint major, minor;
	for (int i = 0; i < MAX_DISPLAYS; i++) {
		if (displays[i] == d) {
			return 0;
		}
	}
	for (int i = 0; i < MAX_DISPLAYS; i++) {
		if (displays[i] == EGL_NO_DISPLAY) {
			if (!eglInitialize(d, &major, &minor)) {
				return fail(ei, "eglInitialize");
			}
			bc_log(BC_LOG_DEBUG, "EGL %d.%d display, vendor %s",
			       (int)major, (int)minor,
			       eglQueryString(d, EGL_VENDOR));
			displays[i] = d;
			return 0;
		}
	}
	return bc_errinfo_set(ei, BC_ELIMIT, "EGL: more than %d displays",
	                      MAX_DISPLAYS);
}

/* Is the EGL version of d at least 1.5 (whose core has the robustness
 * attributes for desktop GL; Mesa refuses the EXT ones there)? */
static bool egl15(EGLDisplay d)
{
	const char *v = eglQueryString(d, EGL_VERSION);
	int major = 0, minor = 0;
	if (!v) {
		return false;
	}
	for (; *v >= '0' && *v <= '9'; v++) {
		major = major * 10 + (*v - '0');
	}
	if (*v == '.') {
		for (v++; *v >= '0' && *v <= '9'; v++) {
			minor = minor * 10 + (*v - '0');
		}
	}
	return major > 1 || (major == 1 && minor >= 5);
}

/* Creates a core context on the initialized display d, newest version
 * first, each with robustness first. */
static int create_context(struct bc__gl_plat *p, EGLDisplay d, bool debug,
                          struct bc_errinfo *ei)
{
	static const int versions[BC_GL_NVERSIONS][2] = BC_GL_VERSIONS;
	const char *exts = eglQueryString(d, EGL_EXTENSIONS);
	bool core15 = egl15(d);
	bool robust_ext = has_ext(exts, "EGL_EXT_create_context_robustness");
	EGLConfig config = EGL_NO_CONFIG_KHR;
	if (!has_ext(exts, "EGL_KHR_surfaceless_context")) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "EGL display lacks "
		                      "EGL_KHR_surfaceless_context");
	}
	if (!core15 && !has_ext(exts, "EGL_KHR_create_context")) {
		return bc_errinfo_set(
		    ei, BC_ENOTSUP,
		    "EGL display lacks EGL_KHR_create_context "
		    "(needed for a core profile)");
	}
	if (!has_ext(exts, "EGL_KHR_no_config_context") &&
	    !has_ext(exts, "EGL_MESA_configless_context")) {
		static const EGLint want[] = {EGL_RENDERABLE_TYPE,
		                              EGL_OPENGL_BIT, EGL_NONE};
		EGLint n = 0;
		if (!eglChooseConfig(d, want, &config, 1, &n)) {
			return fail(ei, "eglChooseConfig");
		}
		if (n < 1) {
			return bc_errinfo_set(ei, BC_EGL,
			                      "eglChooseConfig: no config "
			                      "renders desktop OpenGL");
		}
	}
	if (!eglBindAPI(EGL_OPENGL_API)) {
		return fail(ei, "eglBindAPI(EGL_OPENGL_API)");
	}
	for (int v = 0; v < BC_GL_NVERSIONS; v++) {
		for (int robust = 1; robust >= 0; robust--) {
			EGLint at[16];
			int n = 0;
			EGLContext ctx;
			if (robust && !core15 && !robust_ext) {
				continue;
			}
			at[n++] = EGL_CONTEXT_MAJOR_VERSION;
			at[n++] = versions[v][0];
			at[n++] = EGL_CONTEXT_MINOR_VERSION;
			at[n++] = versions[v][1];
			at[n++] = EGL_CONTEXT_OPENGL_PROFILE_MASK;
			at[n++] = EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT;
			if (robust && core15) {
				at[n++] = EGL_CONTEXT_OPENGL_ROBUST_ACCESS;
				at[n++] = EGL_TRUE;
				at[n++] =
				    EGL_CONTEXT_OPENGL_RESET_NOTIFICATION_STRATEGY;
				at[n++] = EGL_LOSE_CONTEXT_ON_RESET;
			} else if (robust) {
				at[n++] = EGL_CONTEXT_OPENGL_ROBUST_ACCESS_EXT;
				at[n++] = EGL_TRUE;
				at[n++] =
				    EGL_CONTEXT_OPENGL_RESET_NOTIFICATION_STRATEGY_EXT;
				at[n++] = EGL_LOSE_CONTEXT_ON_RESET_EXT;
			}
			if (debug && core15) {
				at[n++] = EGL_CONTEXT_OPENGL_DEBUG;
				at[n++] = EGL_TRUE;
			}
			at[n++] = EGL_NONE;
			ctx = eglCreateContext(d, config, EGL_NO_CONTEXT, at);
			if (ctx == EGL_NO_CONTEXT) {
				EGLint e = eglGetError();
				bc_log(BC_LOG_DEBUG,
				       "eglCreateContext %d.%d core%s: %s",
				       versions[v][0], versions[v][1],
				       robust ? " robust" : "",
				       egl_error_name(e));
				continue;
			}
			if (!eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE,
			                    ctx)) {
				int rc = fail(ei, "eglMakeCurrent");
				eglDestroyContext(d, ctx);
				return rc;
			}
			p->context = ctx;
			p->asked_robust = robust != 0;
			p->major = versions[v][0];
			p->minor = versions[v][1];
			return 0;
		}
	}
	return bc_errinfo_set(ei, BC_EGL,
	                      "eglCreateContext failed for OpenGL 4.3 to 4.5 "
	                      "core: %s",
	                      egl_error_name(eglGetError()));
}

/* Tries d as the display. */
static int open_display(struct bc__gl_plat *p, EGLDisplay d, bool debug,
                        struct bc_errinfo *ei)
{
	int rc;
	pthread_mutex_lock(&lock);
	rc = display_init(d, ei);
	pthread_mutex_unlock(&lock);
	if (rc || (rc = create_context(p, d, debug, ei))) {
		return rc;
	}
	p->display = d;
	return 0;
}

static int open_device(struct bc__gl_plat *p, const char *client, bool any,
                       bool debug, struct bc_errinfo *ei)
{
	PFNEGLQUERYDEVICESEXTPROC query_devices;
	PFNEGLQUERYDEVICESTRINGEXTPROC query_string;
	PFNEGLGETPLATFORMDISPLAYEXTPROC get_display;
	EGLDeviceEXT devs[MAX_DEVICES];
	EGLint n = 0;
	int rc = 0;
	bool tried = false;
	if (!has_ext(client, "EGL_EXT_platform_device") ||
	    !(has_ext(client, "EGL_EXT_device_enumeration") ||
	      has_ext(client, "EGL_EXT_device_base"))) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "EGL lacks EGL_EXT_platform_device");
	}
	query_devices =
	    (PFNEGLQUERYDEVICESEXTPROC)eglGetProcAddress("eglQueryDevicesEXT");
	query_string = (PFNEGLQUERYDEVICESTRINGEXTPROC)eglGetProcAddress(
	    "eglQueryDeviceStringEXT");
	get_display = (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress(
	    "eglGetPlatformDisplayEXT");
	if (!query_devices || !query_string || !get_display) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "EGL device entry points missing");
	}
	if (!query_devices(MAX_DEVICES, devs, &n)) {
		return fail(ei, "eglQueryDevicesEXT");
	}
	/* Hardware devices first; software ones only when asked for the
	 * device platform by name (auto goes on to surfaceless instead,
	 * which is the same renderer). */
	for (int pass = 0; pass < (any ? 2 : 1); pass++) {
		for (EGLint i = 0; i < n; i++) {
			const char *dext =
			    query_string(devs[i], EGL_EXTENSIONS);
			bool soft = has_ext(dext, "EGL_MESA_device_software");
			EGLDisplay d;
			if (soft != (pass == 1)) {
				continue;
			}
			tried = true;
			d = get_display(EGL_PLATFORM_DEVICE_EXT, devs[i], NULL);
			if (d == EGL_NO_DISPLAY) {
				rc = fail(ei,
				          "eglGetPlatformDisplayEXT(device)");
				continue;
			}
			if ((rc = open_display(p, d, debug, ei)) == 0) {
				p->software_device = soft;
				return 0;
			}
			bc_log(BC_LOG_INFO, "EGL device %d: %s", (int)i,
			       ei ? ei->msg : "failed");
		}
	}
	if (!tried) {
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "EGL: no %sdevice to render on (%d "
		                      "found)",
		                      any ? "" : "hardware ", (int)n);
	}
	return rc;
}

int bc__egl_open(struct bc__gl_plat *p, enum bc_gl_platform which,
                 bool any_device, bool debug, struct bc_errinfo *ei)
{
	const char *client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
	int rc;
	if (!client) {
		/* EGL 1.4 without client extensions has neither platform. */
		return bc_errinfo_set(ei, BC_ENOTSUP,
		                      "EGL has no client extensions");
	}
	pthread_mutex_lock(&lock);
	install_debug(client);
	pthread_mutex_unlock(&lock);
	if (which == BC_GL_PLATFORM_DEVICE) {
		rc = open_device(p, client, any_device, debug, ei);
	} else {
		PFNEGLGETPLATFORMDISPLAYEXTPROC get_display;
		EGLDisplay d;
		if (!has_ext(client, "EGL_MESA_platform_surfaceless")) {
			return bc_errinfo_set(ei, BC_ENOTSUP,
			                      "EGL lacks "
			                      "EGL_MESA_platform_surfaceless");
		}
		get_display =
		    (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress(
		        "eglGetPlatformDisplayEXT");
		if (!get_display) {
			return bc_errinfo_set(
			    ei, BC_ENOTSUP, "eglGetPlatformDisplayEXT missing");
		}
		d = get_display(EGL_PLATFORM_SURFACELESS_MESA,
		                EGL_DEFAULT_DISPLAY, NULL);
		if (d == EGL_NO_DISPLAY) {
			return fail(ei,
			            "eglGetPlatformDisplayEXT(surfaceless)");
		}
		rc = open_display(p, d, debug, ei);
	}
	if (rc == 0) {
		p->platform = which;
	}
	return rc;
}

void bc__egl_close(struct bc__gl_plat *p)
{
	if (!p->display) {
		return;
	}
	if (p->context) {
		if (eglGetCurrentContext() == p->context) {
			eglMakeCurrent(p->display, EGL_NO_SURFACE,
			               EGL_NO_SURFACE, EGL_NO_CONTEXT);
		}
		if (!eglDestroyContext(p->display, p->context)) {
			bc_log(BC_LOG_WARN, "eglDestroyContext failed: %s",
			       egl_error_name(eglGetError()));
		}
	}
	p->display = NULL;
	p->context = NULL;
}

int bc__egl_bind(struct bc__gl_plat *p, bool bind, struct bc_errinfo *ei)
{
	if (bind) {
		if (eglGetCurrentContext() == p->context) {
			return 0;
		}
		if (!eglMakeCurrent(p->display, EGL_NO_SURFACE, EGL_NO_SURFACE,
		                    p->context)) {
			return fail(ei, "eglMakeCurrent");
		}
		return 0;
	}
	if (eglGetCurrentContext() == p->context &&
	    !eglMakeCurrent(p->display, EGL_NO_SURFACE, EGL_NO_SURFACE,
	                    EGL_NO_CONTEXT)) {
		return fail(ei, "eglMakeCurrent(release)");
	}
	return 0;
}

bc__gl_fn bc__egl_proc(const char *name)
{
	return (bc__gl_fn)eglGetProcAddress(name);
}
