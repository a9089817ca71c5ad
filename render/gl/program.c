/*
 * The gl backend's programs, compiled from the GLSL stages that the build
 * embedded (shaders/, bc_shaders_gen.h): the A-buffer raster program
 * (vertex, geometry, fragment) and the scan, sort and tracing compute
 * programs. Info logs are always reported: a non-empty log of a successful
 * compile goes to the debug log, a failure's log to the error and to the
 * caller's message (source-string numbers in it index the parts table in
 * bc_shaders_gen.h).
 */
#include "gl_priv.h"

#include <stdio.h>
#include <string.h>

#include "bc_shaders_gen.h"
#include "blobcast/alloc.h"
#include "blobcast/log.h"

struct stage {
	GLenum type;
	const char *name;
	const char *src;
	const char *define; /* a line put after #version, or NULL */
};

/* Logs the info log of a shader or program and copies its start into ei
 * (when failed). */
static int report(struct bc__gl_ctx *c, GLuint obj, bool program,
                  const char *what, bool failed, struct bc_errinfo *ei)
{
	GladGLContext *gl = &c->gl;
	GLint len = 0;
	char *log = NULL;
	if (program) {
		gl->GetProgramiv(obj, GL_INFO_LOG_LENGTH, &len);
	} else {
		gl->GetShaderiv(obj, GL_INFO_LOG_LENGTH, &len);
	}
	if (len > 1 && (log = bc_malloc((size_t)len)) != NULL) {
		if (program) {
			gl->GetProgramInfoLog(obj, len, NULL, log);
		} else {
			gl->GetShaderInfoLog(obj, len, NULL, log);
		}
		bc_log(failed ? BC_LOG_ERROR : BC_LOG_DEBUG, "gl: %s: %s", what,
		       log);
	}
	if (failed) {
		/* Log lines read "string:line": say which file is which. */
		for (int i = 0; i < BC_SHADER_NPARTS; i++) {
			bc_log(BC_LOG_ERROR, "gl: source string %d is %s", i,
			       bc_shader_parts[i]);
		}
		bc_errinfo_set(ei, BC_EGL, "gl: %s failed: %.200s", what,
		               log ? log : "(no info log)");
	}
	bc_free(log);
	return failed ? BC_EGL : 0;
}

static GLuint compile(struct bc__gl_ctx *c, const struct stage *st,
                      struct bc_errinfo *ei)
{
	GladGLContext *gl = &c->gl;
	GLint ok = 0;
	GLuint sh = gl->CreateShader(st->type);
	char what[64];
	if (!sh) {
		bc__gl_check(c, "glCreateShader", ei);
		return 0;
	}
	if (st->define) {
		/* #version must stay the first line: the define follows it. */
		const char *nl = strchr(st->src, '\n');
		const char *parts[3] = {st->src, st->define, nl ? nl + 1 : ""};
		GLint lens[3] = {nl ? (GLint)(nl + 1 - st->src) : 0, -1, -1};
		if (!nl) {
			parts[0] = "";
		}
		gl->ShaderSource(sh, 3, parts, lens);
	} else {
		gl->ShaderSource(sh, 1, &st->src, NULL);
	}
	gl->CompileShader(sh);
	gl->GetShaderiv(sh, GL_COMPILE_STATUS, &ok);
	snprintf(what, sizeof(what), "compiling %s", st->name);
	if (report(c, sh, false, what, !ok, ei)) {
		gl->DeleteShader(sh);
		return 0;
	}
	return sh;
}

static GLuint link(struct bc__gl_ctx *c, const char *name,
                   const struct stage *stages, int n, struct bc_errinfo *ei)
{
	GladGLContext *gl = &c->gl;
	GLuint shaders[3] = {0, 0, 0};
	GLuint prog = 0;
	GLint ok = 0;
	char what[64];
	for (int i = 0; i < n; i++) {
		if (!(shaders[i] = compile(c, &stages[i], ei))) {
			goto cleanup;
		}
	}
	if (!(prog = gl->CreateProgram())) {
		bc__gl_check(c, "glCreateProgram", ei);
		goto cleanup;
	}
	for (int i = 0; i < n; i++) {
		gl->AttachShader(prog, shaders[i]);
	}
	gl->LinkProgram(prog);
	gl->GetProgramiv(prog, GL_LINK_STATUS, &ok);
	snprintf(what, sizeof(what), "linking %s", name);
	if (report(c, prog, true, what, !ok, ei)) {
		gl->DeleteProgram(prog);
		prog = 0;
	}
cleanup:
	/* Attached shaders live on with the program until it is deleted. */
	for (int i = 0; i < n; i++) {
		if (shaders[i]) {
			gl->DeleteShader(shaders[i]);
		}
	}
	return prog;
}

int bc__gl_programs_build(struct bc__gl_ctx *c, GLuint progs[BC__GL_PROG_COUNT],
                          struct bc_errinfo *ei)
{
	const struct stage abuffer[] = {
	    {GL_VERTEX_SHADER, "abuffer.vert", bc_shader_abuffer_vert, NULL},
	    {GL_GEOMETRY_SHADER, "abuffer.geom", bc_shader_abuffer_geom, NULL},
	    {GL_FRAGMENT_SHADER, "abuffer.frag", bc_shader_abuffer_frag, NULL},
	};
	const struct stage scan = {GL_COMPUTE_SHADER, "abuffer_scan.comp",
	                           bc_shader_abuffer_scan_comp, NULL};
	const struct stage sort = {GL_COMPUTE_SHADER, "abuffer_sort.comp",
	                           bc_shader_abuffer_sort_comp, NULL};
	const struct stage trace = {GL_COMPUTE_SHADER, "trace.comp",
	                            bc_shader_trace_comp, NULL};
	memset(progs, 0, BC__GL_PROG_COUNT * sizeof(progs[0]));
	if (!(progs[BC__GL_PROG_ABUFFER] =
	          link(c, "abuffer", abuffer, 3, ei)) ||
	    !(progs[BC__GL_PROG_SCAN] =
	          link(c, "abuffer_scan", &scan, 1, ei)) ||
	    !(progs[BC__GL_PROG_SORT] =
	          link(c, "abuffer_sort", &sort, 1, ei)) ||
	    !(progs[BC__GL_PROG_TRACE] = link(c, "trace", &trace, 1, ei))) {
		bc__gl_programs_free(c, progs);
		return ei && ei->code ? ei->code : BC_EGL;
	}
	return 0;
}

int bc__gl_program_trace_unary(struct bc__gl_ctx *c, GLuint *prog,
                               struct bc_errinfo *ei)
{
	const struct stage trace = {GL_COMPUTE_SHADER, "trace.comp",
	                            bc_shader_trace_comp,
	                            "#define BC_UNARY 1\n"};
	*prog = link(c, "trace (unary nodes)", &trace, 1, ei);
	return *prog ? 0 : (ei && ei->code ? ei->code : BC_EGL);
}

void bc__gl_programs_free(struct bc__gl_ctx *c, GLuint progs[BC__GL_PROG_COUNT])
{
	for (int i = 0; i < BC__GL_PROG_COUNT; i++) {
		if (progs[i]) {
			c->gl.DeleteProgram(progs[i]);
			progs[i] = 0;
		}
	}
}
