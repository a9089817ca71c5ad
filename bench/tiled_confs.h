/*
 * The four configurations of the tiled renderer that bench_simd and
 * bench_render --frames compare side by side: the scalar (opts.simd off)
 * and the vector path (auto), with one and two threads.
 */
#ifndef BLOBCAST_BENCH_TILED_CONFS_H
#define BLOBCAST_BENCH_TILED_CONFS_H

#include <stdint.h>

#include "blobcast/render.h"

enum { CONF_OFF1, CONF_AUTO1, CONF_OFF2, CONF_AUTO2, CONF_COUNT };

static const struct {
	const char *name;
	enum bc_simd simd;
	uint32_t threads;
} confs[CONF_COUNT] = {
    [CONF_OFF1] = {"off/1", BC_SIMD_OFF, 1},
    [CONF_AUTO1] = {"auto/1", BC_SIMD_AUTO, 1},
    [CONF_OFF2] = {"off/2", BC_SIMD_OFF, 2},
    [CONF_AUTO2] = {"auto/2", BC_SIMD_AUTO, 2},
};

#endif
