/*
 * The parts of a CPU renderer that do not depend on how it traces: the
 * renderer object and its ops (create, destroy, key), the pixels a region
 * asks of a tile.
 */
#include "cpu.h"

#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"

int bc__cpu_create(struct bc_renderer **out, enum bc__cpu_kind kind,
                   const struct bc_render_opts *opts, struct bc_errinfo *ei)
{
	struct bc__cpu *r;
	uint32_t threads;
	*out = NULL;
	r = bc_calloc(1, sizeof(*r));
	if (!r) {
		return bc_errinfo_set(ei, BC_ENOMEM, "render: out of memory");
	}
	r->kind = kind;
	threads = opts->threads ? opts->threads : bc_pool_default_threads();
	r->threads =
	    threads > BC_CPU_MAX_THREADS ? BC_CPU_MAX_THREADS : threads;
	*out = &r->base;
	return 0;
}

void bc__cpu_destroy(struct bc_renderer *base)
{
	struct bc__cpu *r = bc__cpu_of(base);
	if (!r) {
		return;
	}
	bc__tiled_free(r->tiled);
	bc_free(r);
}

uint64_t bc__region_mask(const struct bc_render_region *region, uint32_t tx,
                         uint32_t ty, uint32_t width, uint32_t height)
{
	uint64_t mask = 0;
	uint32_t x0 = tx * BC_CPU_TILE, y0 = ty * BC_CPU_TILE;
	if (region->tiles &&
	    !region->tiles[(size_t)ty * bc_render_tiles_x(width) + tx]) {
		return 0;
	}
	if (region->level == 0 && !region->refine) {
		/* Every pixel of the tile inside the frame (bc_render_level_has
		 * at level 0 without refinement): a full frame's every tile, so
		 * no loop over its pixels (2 % of a warm vector frame). */
		uint32_t w =
		    width - x0 < BC_CPU_TILE ? width - x0 : BC_CPU_TILE;
		uint32_t h =
		    height - y0 < BC_CPU_TILE ? height - y0 : BC_CPU_TILE;
		uint64_t row = (1ull << w) - 1u;
		for (uint32_t y = 0; y < h; y++) {
			mask |= row << (y * BC_CPU_TILE);
		}
		return mask;
	}
	for (uint32_t y = y0; y < y0 + BC_CPU_TILE && y < height; y++) {
		for (uint32_t x = x0; x < x0 + BC_CPU_TILE && x < width; x++) {
			if (bc_render_level_has(x, y, region->level,
			                        region->refine)) {
				mask |= 1ull
				        << ((y - y0) * BC_CPU_TILE + (x - x0));
			}
		}
	}
	return mask;
}
