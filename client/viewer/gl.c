/*
 * The viewer's GL code (see viewer_gl.h). It keeps to what GL 2.1 and GLES 2
 * share: one shader program from viewer.vert/viewer.frag (embedded at build
 * time), client-side vertex arrays, RGBA8 textures with linear filtering and
 * clamped edges (so non-power-of-two sizes are fine on GLES 2), and
 * glReadPixels of GL_RGBA / GL_UNSIGNED_BYTE, the one format GLES 2
 * guarantees.
 */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "viewer_gl.h"
#include "viewer_shaders.h"

/* Tokens of GL 1.2 and 2.0 that GL/gl.h (GL 1.1 and up) need not define. */
#ifndef GL_CLAMP_TO_EDGE
#define GL_CLAMP_TO_EDGE 0x812F
#endif
#ifndef GL_TEXTURE0
#define GL_TEXTURE0 0x84C0
#endif
#ifndef GL_FRAGMENT_SHADER
#define GL_FRAGMENT_SHADER 0x8B30
#define GL_VERTEX_SHADER 0x8B31
#define GL_COMPILE_STATUS 0x8B81
#define GL_LINK_STATUS 0x8B82
#define GL_INFO_LOG_LENGTH 0x8B84
#endif

/* Generic vertex attribute slots. Position is 0: on a compatibility
 * context attribute 0 aliases gl_Vertex and must be an enabled array. */
enum { ATTR_POS = 0, ATTR_UV = 1 };

static const struct {
	const char *name;
	size_t offset;
} glfn_table[] = {
#define FN(n)                                                                  \
	{                                                                      \
		"gl" #n, offsetof(struct bc_viewer_glfn, n)                    \
	}
    FN(ActiveTexture),
    FN(AttachShader),
    FN(BindAttribLocation),
    FN(BindTexture),
    FN(BlendFunc),
    FN(Clear),
    FN(ClearColor),
    FN(CompileShader),
    FN(CreateProgram),
    FN(CreateShader),
    FN(DeleteProgram),
    FN(DeleteShader),
    FN(DeleteTextures),
    FN(Disable),
    FN(DisableVertexAttribArray),
    FN(DrawArrays),
    FN(Enable),
    FN(EnableVertexAttribArray),
    FN(Finish),
    FN(GenTextures),
    FN(GetError),
    FN(GetIntegerv),
    FN(GetProgramInfoLog),
    FN(GetProgramiv),
    FN(GetShaderInfoLog),
    FN(GetShaderiv),
    FN(GetString),
    FN(GetUniformLocation),
    FN(LinkProgram),
    FN(PixelStorei),
    FN(ReadPixels),
    FN(ShaderSource),
    FN(TexImage2D),
    FN(TexParameteri),
    FN(TexSubImage2D),
    FN(Uniform1f),
    FN(Uniform1i),
    FN(Uniform2f),
    FN(Uniform4f),
    FN(UseProgram),
    FN(VertexAttribPointer),
    FN(Viewport),
#undef FN
};

static int load_functions(struct bc_viewer_gl *gl, struct bc_errinfo *ei)
{
	for (size_t i = 0; i < sizeof(glfn_table) / sizeof(glfn_table[0]);
	     i++) {
		GLFWglproc p = glfwGetProcAddress(glfn_table[i].name);
		if (!p) {
			return bc_errinfo_set(ei, BC_EGL,
			                      "the GL driver lacks %s",
			                      glfn_table[i].name);
		}
		/* Every member is a function pointer of GLFWglproc's size;
		 * copying the bytes avoids one cast per prototype. */
		memcpy((char *)&gl->f + glfn_table[i].offset, &p, sizeof(p));
	}
	return 0;
}

static GLuint compile(struct bc_viewer_gl *gl, GLenum stage, const char *name,
                      const unsigned char *text, struct bc_errinfo *ei)
{
	const GLchar *src = (const GLchar *)text;
	GLuint sh = gl->f.CreateShader(stage);
	GLint ok = 0, len = 0;
	char log[1024] = "";
	if (!sh) {
		bc_errinfo_set(ei, BC_EGL, "glCreateShader failed for %s",
		               name);
		return 0;
	}
	gl->f.ShaderSource(sh, 1, &src, NULL);
	gl->f.CompileShader(sh);
	gl->f.GetShaderiv(sh, GL_COMPILE_STATUS, &ok);
	gl->f.GetShaderiv(sh, GL_INFO_LOG_LENGTH, &len);
	if (len > 1) {
		gl->f.GetShaderInfoLog(sh, (GLsizei)sizeof(log), NULL, log);
	}
	if (!ok) {
		bc_errinfo_set(ei, BC_EGL, "%s does not compile: %s", name,
		               log);
		gl->f.DeleteShader(sh);
		return 0;
	}
	if (log[0]) {
		/* Drivers' warnings are worth seeing once. */
		bc_log(BC_LOG_INFO, "%s: %s", name, log);
	}
	return sh;
}

static int build_program(struct bc_viewer_gl *gl, struct bc_errinfo *ei)
{
	GLuint vs = 0, fs = 0;
	GLint ok = 0;
	char log[1024] = "";
	int rc = 0;
	if (!(vs = compile(gl, GL_VERTEX_SHADER, "viewer.vert", viewer_vert,
	                   ei)) ||
	    !(fs = compile(gl, GL_FRAGMENT_SHADER, "viewer.frag", viewer_frag,
	                   ei))) {
		rc = BC_EGL;
		goto cleanup;
	}
	if (!(gl->prog = gl->f.CreateProgram())) {
		rc = bc_errinfo_set(ei, BC_EGL, "glCreateProgram failed");
		goto cleanup;
	}
	gl->f.AttachShader(gl->prog, vs);
	gl->f.AttachShader(gl->prog, fs);
	gl->f.BindAttribLocation(gl->prog, ATTR_POS, "a_pos");
	gl->f.BindAttribLocation(gl->prog, ATTR_UV, "a_uv");
	gl->f.LinkProgram(gl->prog);
	gl->f.GetProgramiv(gl->prog, GL_LINK_STATUS, &ok);
	if (!ok) {
		gl->f.GetProgramInfoLog(gl->prog, (GLsizei)sizeof(log), NULL,
		                        log);
		rc = bc_errinfo_set(ei, BC_EGL,
		                    "the viewer's shaders do not "
		                    "link: %s",
		                    log);
		goto cleanup;
	}
	gl->u_size = gl->f.GetUniformLocation(gl->prog, "u_size");
	gl->u_tex = gl->f.GetUniformLocation(gl->prog, "u_tex");
	gl->u_color = gl->f.GetUniformLocation(gl->prog, "u_color");
	gl->u_textured = gl->f.GetUniformLocation(gl->prog, "u_textured");
cleanup:
	/* Attached shaders live on in the program; deleting them now frees
	 * them with it. */
	if (vs) {
		gl->f.DeleteShader(vs);
	}
	if (fs) {
		gl->f.DeleteShader(fs);
	}
	return rc;
}

static void copy_string(struct bc_viewer_gl *gl, GLenum what, char *dst,
                        size_t n)
{
	const GLubyte *s = gl->f.GetString(what);
	snprintf(dst, n, "%s", s ? (const char *)s : "?");
}

int bc_viewer_gl_init(struct bc_viewer_gl *gl, bool gles, struct bc_errinfo *ei)
{
	int rc;
	memset(gl, 0, sizeof(*gl));
	gl->gles = gles;
	if ((rc = load_functions(gl, ei))) {
		return rc;
	}
	copy_string(gl, GL_RENDERER, gl->renderer, sizeof(gl->renderer));
	copy_string(gl, GL_VERSION, gl->version, sizeof(gl->version));
	if ((rc = build_program(gl, ei))) {
		return rc;
	}
	gl->f.GetIntegerv(GL_MAX_TEXTURE_SIZE, &gl->max_tex);
	gl->f.GenTextures(BC_VIEWER_TEX_COUNT - 1, &gl->tex[1]);
	for (int t = 1; t < BC_VIEWER_TEX_COUNT; t++) {
		gl->f.BindTexture(GL_TEXTURE_2D, gl->tex[t]);
		gl->f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
		                    GL_LINEAR);
		gl->f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER,
		                    GL_LINEAR);
		gl->f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S,
		                    GL_CLAMP_TO_EDGE);
		gl->f.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T,
		                    GL_CLAMP_TO_EDGE);
	}
	/* Rows of RGBA8 are always 4-byte aligned, but say so. */
	gl->f.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
	gl->f.PixelStorei(GL_PACK_ALIGNMENT, 1);
	gl->f.UseProgram(gl->prog);
	gl->f.Uniform1i(gl->u_tex, 0);
	gl->f.ActiveTexture(GL_TEXTURE0);
	gl->f.BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
	if (gl->f.GetError() != GL_NO_ERROR) {
		return bc_errinfo_set(ei, BC_EGL, "GL error while setting up");
	}
	return 0;
}

void bc_viewer_gl_finish(struct bc_viewer_gl *gl)
{
	if (!gl) {
		return;
	}
	if (gl->prog) {
		gl->f.DeleteProgram(gl->prog);
	}
	if (gl->tex[1]) {
		gl->f.DeleteTextures(BC_VIEWER_TEX_COUNT - 1, &gl->tex[1]);
	}
	bc_free(gl->stage);
	memset(gl, 0, sizeof(*gl));
}

int bc_viewer_gl_upload(struct bc_viewer_gl *gl, enum bc_viewer_tex tex,
                        const uint8_t *rgba, uint32_t w, uint32_t h,
                        const struct bc_viewer_update *up,
                        struct bc_errinfo *ei)
{
	GLenum err;
	if (tex <= BC_VIEWER_TEX_NONE || tex >= BC_VIEWER_TEX_COUNT || !rgba) {
		return bc_errinfo_set(ei, BC_EINVAL, "no texture to update");
	}
	if (w > (uint32_t)gl->max_tex || h > (uint32_t)gl->max_tex) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "a %ux%u frame is larger than this GL's "
		                      "%d-pixel textures",
		                      w, h, gl->max_tex);
	}
	gl->f.BindTexture(GL_TEXTURE_2D, gl->tex[tex]);
	if (up->resized || gl->tex_w[tex] != w || gl->tex_h[tex] != h) {
		gl->f.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA, (GLsizei)w,
		                 (GLsizei)h, 0, GL_RGBA, GL_UNSIGNED_BYTE,
		                 rgba);
		gl->tex_w[tex] = w;
		gl->tex_h[tex] = h;
	} else if (up->whole) {
		gl->f.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, (GLsizei)w,
		                    (GLsizei)h, GL_RGBA, GL_UNSIGNED_BYTE,
		                    rgba);
	} else {
		for (uint32_t i = 0; i < up->nrects; i++) {
			const struct bc_proto_rect *r = &up->rects[i];
			size_t need = (size_t)r->w * r->h * 4u;
			if (need > gl->stage_cap) {
				uint8_t *s = bc_realloc(gl->stage, need);
				if (!s) {
					return bc_errinfo_set(ei, BC_ENOMEM,
					                      "out of memory");
				}
				gl->stage = s;
				gl->stage_cap = need;
			}
			/* GLES 2 has no GL_UNPACK_ROW_LENGTH: pack the
			 * rectangle's rows first. */
			bc_viewer_copy_rect(rgba, w, r->x, r->y, r->w, r->h,
			                    gl->stage);
			gl->f.TexSubImage2D(GL_TEXTURE_2D, 0, r->x, r->y, r->w,
			                    r->h, GL_RGBA, GL_UNSIGNED_BYTE,
			                    gl->stage);
		}
	}
	if ((err = gl->f.GetError()) != GL_NO_ERROR) {
		return bc_errinfo_set(ei, BC_EGL,
		                      "texture upload failed (GL error 0x%x)",
		                      (unsigned)err);
	}
	return 0;
}

void bc_viewer_gl_begin(struct bc_viewer_gl *gl, uint32_t w, uint32_t h)
{
	gl->width = (float)(w ? w : 1);
	gl->height = (float)(h ? h : 1);
	gl->f.Viewport(0, 0, (GLsizei)w, (GLsizei)h);
	gl->f.ClearColor(0.08f, 0.09f, 0.10f, 1.0f);
	gl->f.Clear(GL_COLOR_BUFFER_BIT);
	gl->f.UseProgram(gl->prog);
	gl->f.Uniform2f(gl->u_size, gl->width, gl->height);
}

void bc_viewer_gl_image(struct bc_viewer_gl *gl, enum bc_viewer_tex tex,
                        float x0, float y0, float x1, float y1, float u1,
                        float v1)
{
	const float pos[12] = {x0, y0, x1, y0, x1, y1, x0, y0, x1, y1, x0, y1};
	const float uv[12] = {0.0f, 0.0f, u1, 0.0f, u1,   v1,
	                      0.0f, 0.0f, u1, v1,   0.0f, v1};
	if (tex <= BC_VIEWER_TEX_NONE || tex >= BC_VIEWER_TEX_COUNT ||
	    !gl->tex_w[tex]) {
		return;
	}
	gl->f.Disable(GL_BLEND);
	gl->f.BindTexture(GL_TEXTURE_2D, gl->tex[tex]);
	gl->f.Uniform1f(gl->u_textured, 1.0f);
	gl->f.Uniform4f(gl->u_color, 0.0f, 0.0f, 0.0f, 1.0f);
	gl->f.EnableVertexAttribArray(ATTR_POS);
	gl->f.EnableVertexAttribArray(ATTR_UV);
	gl->f.VertexAttribPointer(ATTR_POS, 2, GL_FLOAT, GL_FALSE, 0, pos);
	gl->f.VertexAttribPointer(ATTR_UV, 2, GL_FLOAT, GL_FALSE, 0, uv);
	gl->f.DrawArrays(GL_TRIANGLES, 0, 6);
	gl->f.DisableVertexAttribArray(ATTR_UV);
}

void bc_viewer_gl_draw(struct bc_viewer_gl *gl, GLenum mode, const float *xy,
                       size_t n, const float rgba[4])
{
	if (n == 0) {
		return;
	}
	gl->f.Enable(GL_BLEND);
	gl->f.Uniform1f(gl->u_textured, 0.0f);
	gl->f.Uniform4f(gl->u_color, rgba[0], rgba[1], rgba[2], rgba[3]);
	gl->f.EnableVertexAttribArray(ATTR_POS);
	gl->f.DisableVertexAttribArray(ATTR_UV);
	gl->f.VertexAttribPointer(ATTR_POS, 2, GL_FLOAT, GL_FALSE, 0, xy);
	gl->f.DrawArrays(mode, 0, (GLsizei)n);
}

int bc_viewer_gl_read(struct bc_viewer_gl *gl, uint32_t w, uint32_t h,
                      uint8_t *rgba, struct bc_errinfo *ei)
{
	size_t row = (size_t)w * 4u;
	GLenum err;
	uint8_t tmp[256];
	gl->f.ReadPixels(0, 0, (GLsizei)w, (GLsizei)h, GL_RGBA,
	                 GL_UNSIGNED_BYTE, rgba);
	if ((err = gl->f.GetError()) != GL_NO_ERROR) {
		return bc_errinfo_set(ei, BC_EGL,
		                      "glReadPixels failed (GL error 0x%x)",
		                      (unsigned)err);
	}
	/* GL's rows run bottom up; images run top down. Swap in place, a
	 * small piece at a time. */
	for (uint32_t y = 0; y < h / 2u; y++) {
		uint8_t *a = rgba + (size_t)y * row;
		uint8_t *b = rgba + (size_t)(h - 1u - y) * row;
		for (size_t off = 0; off < row; off += sizeof(tmp)) {
			size_t n =
			    row - off < sizeof(tmp) ? row - off : sizeof(tmp);
			memcpy(tmp, a + off, n);
			memcpy(a + off, b + off, n);
			memcpy(b + off, tmp, n);
		}
	}
	/* Blending the overlay leaves the buffer's alpha meaningless; the
	 * window shows it opaque, and so does its screenshot. */
	for (size_t i = 3; i < row * h; i += 4) {
		rgba[i] = 255;
	}
	return 0;
}
