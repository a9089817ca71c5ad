/*
 * The one OSMesa entry point an EGL-only gl backend still names: the GL
 * loader in render/gl/context.c calls bc__osmesa_proc for an OSMesa
 * context without asking whether OSMesa was built in. Without OSMesa no
 * context is ever OSMesa's (context.c opens that platform only when it is
 * built in), so this is never called; it lets the GPU kit's build — EGL
 * alone, since a GPU host has no Mesa — link. bench/CMakeLists.txt adds it
 * only to builds without OSMesa.
 */
#include <stddef.h>

#include "gl_platform.h"

bc__gl_fn bc__osmesa_proc(const char *name)
{
	(void)name;
	return NULL;
}
