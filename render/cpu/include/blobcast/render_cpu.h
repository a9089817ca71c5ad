/*
 * The CPU renderers: `naive` (sphere tracing of the full tree per pixel, the
 * tests' oracle) and `tiled` (Zanni 2024 §6 on CPU threads: an A-buffer of
 * primitive ABVs per 8x8 tile, depth ranges walked per tile, a pruned tree
 * view per range). Both sit behind the front of blobcast/render.h
 * (bc_renderer_create with BC_BACKEND_NAIVE or _TILED). This header adds
 * what only the CPU backends offer: a progress report for long frames.
 */
#ifndef BLOBCAST_RENDER_CPU_H
#define BLOBCAST_RENDER_CPU_H

#include <stdint.h>

#include "blobcast/render.h"

/* Called from the rendering thread while a frame is drawn: `done` of
 * `total` work items (tiles for tiled, rows for naive) are finished. Calls
 * are at least a quarter of a second apart, and there is none for frames
 * that take less. */
typedef void (*bc_render_progress_fn)(void *user, uint32_t done,
                                      uint32_t total);

/* Installs (or, with fn NULL, removes) the progress callback of r, which
 * must come from bc_backend_naive_ops or bc_backend_tiled_ops. */
void bc_render_cpu_set_progress(struct bc_renderer *r, bc_render_progress_fn fn,
                                void *user);

#endif
