/*
 * The interface between bc_image (image.c, linked into every program that
 * reads or writes image files) and bc_image_oiio, the module that holds the
 * OpenImageIO code (image.cpp). OpenImageIO and its ~260 shared libraries
 * are loaded with dlopen() the first time a file is read or written, so a
 * program that never touches an image file (`blobcast --help`, the client
 * commands) starts without them. The module exports one function,
 * BC_IMAGE_MODULE_ENTRY; everything else in it is hidden.
 */
#ifndef BLOBCAST_IMAGE_MODULE_H
#define BLOBCAST_IMAGE_MODULE_H

#include <stddef.h>

#include "blobcast/image.h"

#define BC_IMAGE_MODULE_ENTRY "bc_image_module_open"
/* Bumped whenever the structs below change: a module from another build is
 * refused rather than called with the wrong layout. */
#define BC_IMAGE_MODULE_ABI 1u

/* What the program lends the module: its allocator, so that pixels the
 * module allocates are freed by bc_image_finish() (and counted by the
 * allocation hook of the tests), and bc_image_ext_supports(), which holds
 * the lists of formats that store float and uint32 samples exactly. */
struct bc_image_host {
	void *(*calloc)(size_t n, size_t size);
	void (*free)(void *ptr);
	bool (*ext_supports)(const char *path, enum bc_image_type type);
};

/* The module's functions: as in blobcast/image.h, arguments already
 * checked by image.c for the cheap cases. */
struct bc_image_ops {
	unsigned abi;
	bool (*ext_supports_u8)(const char *path);
	int (*write)(const char *path, const struct bc_image *img,
	             struct bc_errinfo *ei);
	int (*read)(const char *path, enum bc_image_type type,
	            struct bc_image *out, struct bc_errinfo *ei);
};

typedef const struct bc_image_ops *(*bc_image_module_open_fn)(
    const struct bc_image_host *host);

#endif
