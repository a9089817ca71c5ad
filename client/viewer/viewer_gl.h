/*
 * blobcast-view's drawing, on GL 2.1 or GLES 2: entry points loaded through
 * glfwGetProcAddress (the same code then serves a desktop and an ES
 * context, and no libGL/libGLESv2 is linked), one small shader program for
 * textured and flat 2-D triangles and lines, the frame textures updated
 * rectangle by rectangle, and reading the back buffer for screenshots.
 */
#ifndef BLOBCAST_VIEWER_GL_H
#define BLOBCAST_VIEWER_GL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <GL/gl.h>

#include "blobcast/error.h"
#include "viewer.h"

/* The GL entry points the viewer calls: GL 1.1 and the GL 2.0 shader
 * functions that GLES 2 also has. Loaded by name in bc_viewer_gl_init. */
struct bc_viewer_glfn {
	void(GLAPIENTRY *ActiveTexture)(GLenum);
	void(GLAPIENTRY *AttachShader)(GLuint, GLuint);
	void(GLAPIENTRY *BindAttribLocation)(GLuint, GLuint, const GLchar *);
	void(GLAPIENTRY *BindTexture)(GLenum, GLuint);
	void(GLAPIENTRY *BlendFunc)(GLenum, GLenum);
	void(GLAPIENTRY *Clear)(GLbitfield);
	void(GLAPIENTRY *ClearColor)(GLfloat, GLfloat, GLfloat, GLfloat);
	void(GLAPIENTRY *CompileShader)(GLuint);
	GLuint(GLAPIENTRY *CreateProgram)(void);
	GLuint(GLAPIENTRY *CreateShader)(GLenum);
	void(GLAPIENTRY *DeleteProgram)(GLuint);
	void(GLAPIENTRY *DeleteShader)(GLuint);
	void(GLAPIENTRY *DeleteTextures)(GLsizei, const GLuint *);
	void(GLAPIENTRY *Disable)(GLenum);
	void(GLAPIENTRY *DisableVertexAttribArray)(GLuint);
	void(GLAPIENTRY *DrawArrays)(GLenum, GLint, GLsizei);
	void(GLAPIENTRY *Enable)(GLenum);
	void(GLAPIENTRY *EnableVertexAttribArray)(GLuint);
	void(GLAPIENTRY *Finish)(void);
	void(GLAPIENTRY *GenTextures)(GLsizei, GLuint *);
	GLenum(GLAPIENTRY *GetError)(void);
	void(GLAPIENTRY *GetIntegerv)(GLenum, GLint *);
	void(GLAPIENTRY *GetProgramInfoLog)(GLuint, GLsizei, GLsizei *,
	                                    GLchar *);
	void(GLAPIENTRY *GetProgramiv)(GLuint, GLenum, GLint *);
	void(GLAPIENTRY *GetShaderInfoLog)(GLuint, GLsizei, GLsizei *,
	                                   GLchar *);
	void(GLAPIENTRY *GetShaderiv)(GLuint, GLenum, GLint *);
	const GLubyte *(GLAPIENTRY *GetString)(GLenum);
	GLint(GLAPIENTRY *GetUniformLocation)(GLuint, const GLchar *);
	void(GLAPIENTRY *LinkProgram)(GLuint);
	void(GLAPIENTRY *PixelStorei)(GLenum, GLint);
	void(GLAPIENTRY *ReadPixels)(GLint, GLint, GLsizei, GLsizei, GLenum,
	                             GLenum, void *);
	void(GLAPIENTRY *ShaderSource)(GLuint, GLsizei, const GLchar *const *,
	                               const GLint *);
	void(GLAPIENTRY *TexImage2D)(GLenum, GLint, GLint, GLsizei, GLsizei,
	                             GLint, GLenum, GLenum, const void *);
	void(GLAPIENTRY *TexParameteri)(GLenum, GLenum, GLint);
	void(GLAPIENTRY *TexSubImage2D)(GLenum, GLint, GLint, GLint, GLsizei,
	                                GLsizei, GLenum, GLenum, const void *);
	void(GLAPIENTRY *Uniform1f)(GLint, GLfloat);
	void(GLAPIENTRY *Uniform1i)(GLint, GLint);
	void(GLAPIENTRY *Uniform2f)(GLint, GLfloat, GLfloat);
	void(GLAPIENTRY *Uniform4f)(GLint, GLfloat, GLfloat, GLfloat, GLfloat);
	void(GLAPIENTRY *UseProgram)(GLuint);
	void(GLAPIENTRY *VertexAttribPointer)(GLuint, GLint, GLenum, GLboolean,
	                                      GLsizei, const void *);
	void(GLAPIENTRY *Viewport)(GLint, GLint, GLsizei, GLsizei);
};

struct bc_viewer_gl {
	struct bc_viewer_glfn f;
	bool gles;
	GLuint prog;
	GLint u_size, u_tex, u_color, u_textured;
	/* Textures by enum bc_viewer_tex (0 unused) and their sizes. */
	GLuint tex[BC_VIEWER_TEX_COUNT];
	uint32_t tex_w[BC_VIEWER_TEX_COUNT], tex_h[BC_VIEWER_TEX_COUNT];
	GLint max_tex; /* GL_MAX_TEXTURE_SIZE */
	/* Rectangles are packed here before glTexSubImage2D. */
	uint8_t *stage;
	size_t stage_cap;
	/* The window size the last bc_viewer_gl_begin() set, in pixels. */
	float width, height;
	char renderer[128], version[128];
};

/* With the window's context current: loads the entry points, builds the
 * program and creates the textures. Returns 0 or BC_EGL with the reason
 * (a missing function, a shader's info log) in ei. */
int bc_viewer_gl_init(struct bc_viewer_gl *gl, bool gles,
                      struct bc_errinfo *ei);
/* Frees the GL objects (context still current) and the staging memory;
 * accepts a zeroed object. */
void bc_viewer_gl_finish(struct bc_viewer_gl *gl);

/* Brings texture tex up to date with rgba (w x h, row 0 on top) as up
 * describes: a new size reallocates it, `whole` uploads everything,
 * otherwise only up's rectangles are sent with glTexSubImage2D. Returns 0,
 * BC_ELIMIT (larger than GL_MAX_TEXTURE_SIZE), BC_ENOMEM or BC_EGL. */
int bc_viewer_gl_upload(struct bc_viewer_gl *gl, enum bc_viewer_tex tex,
                        const uint8_t *rgba, uint32_t w, uint32_t h,
                        const struct bc_viewer_update *up,
                        struct bc_errinfo *ei);

/* Starts a frame in a window of w x h pixels: viewport, clear. */
void bc_viewer_gl_begin(struct bc_viewer_gl *gl, uint32_t w, uint32_t h);
/* Draws the top-left u1 x v1 fraction of texture tex (1, 1: all of it)
 * stretched over the window rectangle (x0, y0)-(x1, y1). */
void bc_viewer_gl_image(struct bc_viewer_gl *gl, enum bc_viewer_tex tex,
                        float x0, float y0, float x1, float y1, float u1,
                        float v1);
/* Draws n vertices (x, y pairs in window pixels) as GL_TRIANGLES or
 * GL_LINES in one colour; alpha blends. */
void bc_viewer_gl_draw(struct bc_viewer_gl *gl, GLenum mode, const float *xy,
                       size_t n, const float rgba[4]);
/* Reads the back buffer (w x h) into rgba, row 0 on top. Returns 0 or
 * BC_EGL. */
int bc_viewer_gl_read(struct bc_viewer_gl *gl, uint32_t w, uint32_t h,
                      uint8_t *rgba, struct bc_errinfo *ei);

#endif
