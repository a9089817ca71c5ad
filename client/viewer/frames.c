/*
 * FRAME messages turned into what the viewer's two textures hold.
 *
 * The server sends three kinds of frames: coarse ones after a change, a
 * whole picture at refinement level n > 0 (one pixel per 2^n block of the
 * view, PROTOCOL.md 7.15) or, from servers without levels, a level-0
 * image at 1/downscale of the view; frames at the view size (level 0),
 * whole or -- after a parameter edit -- only the blocks the edit damaged,
 * the last of them the still; and snapshots, which the caller keeps apart.
 * Full-size frames are decoded into one bc_client_image and their
 * rectangles copied into `comp`, the view-size picture the full texture
 * mirrors, so only those rectangles are uploaded. Smaller frames are
 * decoded into a second image and uploaded whole to a small texture that
 * the GPU stretches over the window: a level image by 2^n from the
 * top-left (small_u, small_v say how much of it spans the view), a
 * downscaled one over the whole window.
 *
 * A partial still that follows interactive frames is laid over the last
 * interactive image scaled up, never over the still from before the
 * gesture: the gesture may have changed anything outside the rectangles
 * (a dragged shape's old place). The server's damage covers only the last
 * change, so the caller is told to ask for a whole still (want_refresh).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "viewer.h"

void bc_viewer_frames_init(struct bc_viewer_frames *f)
{
	memset(f, 0, sizeof(*f));
	bc_client_image_init(&f->full);
	bc_client_image_init(&f->small);
}

void bc_viewer_frames_finish(struct bc_viewer_frames *f)
{
	if (!f) {
		return;
	}
	bc_client_image_finish(&f->full);
	bc_client_image_finish(&f->small);
	bc_free(f->comp);
	memset(f, 0, sizeof(*f));
}

void bc_viewer_copy_rect(const uint8_t *src, uint32_t stride, uint32_t x,
                         uint32_t y, uint32_t w, uint32_t h, uint8_t *dst)
{
	for (uint32_t j = 0; j < h; j++) {
		memcpy(dst + (size_t)j * w * 4u,
		       src + ((size_t)(y + j) * stride + x) * 4u,
		       (size_t)w * 4u);
	}
}

/* Source coordinate of destination pixel centre i when the first span of
 * n source pixels (span <= n) stretches over m: the two neighbours and the
 * weight of the second. */
static void sample_at(uint32_t i, uint32_t n, float span, uint32_t m,
                      uint32_t *a, uint32_t *b, float *t)
{
	float s = ((float)i + 0.5f) * span / (float)m - 0.5f;
	float fl;
	if (s < 0.0f) {
		s = 0.0f;
	}
	fl = floorf(s);
	*a = (uint32_t)fl;
	if (*a >= n - 1u) {
		*a = n - 1u;
		*b = n - 1u;
		*t = 0.0f;
		return;
	}
	*b = *a + 1u;
	*t = s - fl;
}

void bc_viewer_upscale(const uint8_t *src, uint32_t sw, uint32_t sh,
                       uint8_t *dst, uint32_t dw, uint32_t dh)
{
	bc_viewer_upscale_part(src, sw, sh, 1.0f, 1.0f, dst, dw, dh);
}

void bc_viewer_upscale_part(const uint8_t *src, uint32_t sw, uint32_t sh,
                            float su, float sv, uint8_t *dst, uint32_t dw,
                            uint32_t dh)
{
	float spanx = su * (float)sw, spany = sv * (float)sh;
	for (uint32_t y = 0; y < dh; y++) {
		uint32_t y0, y1;
		float ty;
		sample_at(y, sh, spany, dh, &y0, &y1, &ty);
		for (uint32_t x = 0; x < dw; x++) {
			uint32_t x0, x1;
			float tx;
			const uint8_t *p00, *p01, *p10, *p11;
			uint8_t *d = dst + ((size_t)y * dw + x) * 4u;
			sample_at(x, sw, spanx, dw, &x0, &x1, &tx);
			p00 = src + ((size_t)y0 * sw + x0) * 4u;
			p01 = src + ((size_t)y0 * sw + x1) * 4u;
			p10 = src + ((size_t)y1 * sw + x0) * 4u;
			p11 = src + ((size_t)y1 * sw + x1) * 4u;
			for (int c = 0; c < 4; c++) {
				float top = (float)p00[c] +
				            tx * (float)(p01[c] - p00[c]);
				float bot = (float)p10[c] +
				            tx * (float)(p11[c] - p10[c]);
				d[c] = (uint8_t)(top + ty * (bot - top) + 0.5f);
			}
		}
	}
}

/* Whether the rectangles of a frame cover its whole image. Rectangles of a
 * frame do not overlap (the server cuts damage into disjoint runs), so the
 * areas add up. */
static bool covers_all(const struct bc_msg_frame *fr)
{
	uint64_t area = 0;
	for (uint32_t i = 0; i < fr->nrects; i++) {
		const struct bc_proto_rect *r = &fr->rects[i];
		if (r->x == 0 && r->y == 0 && r->w == fr->image_width &&
		    r->h == fr->image_height) {
			return true;
		}
		area += (uint64_t)r->w * r->h;
	}
	return area >= (uint64_t)fr->image_width * fr->image_height;
}

const char *bc_viewer_refining_text(uint16_t flags, char *out, size_t n)
{
	unsigned level = bc_proto_flags_level(flags);
	if (flags & BC_PROTO_FLAG_INCOMPLETE) {
		/* The server's time budget cut this picture short. */
		snprintf(out, n, "refining (level %u, cut by budget)", level);
	} else if (level > 0) {
		snprintf(out, n, "refining (level %u)", level);
	} else if (n > 0) {
		out[0] = '\0';
	}
	return out;
}

/* Remembers what the last frame says about refinement. */
static void note_level(struct bc_viewer_frames *f, const struct bc_msg *m)
{
	f->level = (uint8_t)bc_proto_flags_level(m->flags);
	f->refining =
	    f->level > 0 || (m->flags & BC_PROTO_FLAG_INCOMPLETE) != 0;
}

static int apply_small(struct bc_viewer_frames *f, const struct bc_msg *m,
                       struct bc_viewer_update *up, struct bc_errinfo *ei)
{
	const struct bc_msg_frame *fr = &m->frame;
	uint32_t w = f->small.width, h = f->small.height;
	unsigned level = bc_proto_flags_level(m->flags);
	int rc = bc_client_image_apply(&f->small, m, ei);
	if (rc) {
		return rc;
	}
	/* A level image's pixels are 2^n blocks from the top-left, so its
	 * last column and row may stand partly outside the view. */
	f->small_u = 1.0f;
	f->small_v = 1.0f;
	if (level > 0) {
		f->small_u = (float)fr->width /
		             (float)((uint32_t)fr->image_width << level);
		f->small_v = (float)fr->height /
		             (float)((uint32_t)fr->image_height << level);
	}
	note_level(f, m);
	up->tex = BC_VIEWER_TEX_SMALL;
	up->resized = f->small.width != w || f->small.height != h;
	up->whole = up->resized;
	up->rects = fr->rects;
	up->nrects = fr->nrects;
	f->showing_small = true;
	f->comp_stale = true;
	f->last_still = (m->flags & BC_PROTO_FLAG_STILL) != 0;
	return 0;
}

int bc_viewer_frames_apply(struct bc_viewer_frames *f, const struct bc_msg *m,
                           struct bc_viewer_update *up, struct bc_errinfo *ei)
{
	const struct bc_msg_frame *fr = &m->frame;
	bool covers, still = (m->flags & BC_PROTO_FLAG_STILL) != 0;
	int rc;
	memset(up, 0, sizeof(*up));
	if (m->type != BC_MSG_FRAME) {
		return bc_errinfo_set(ei, BC_EINVAL, "not a FRAME");
	}
	if (fr->image_width != fr->width || fr->image_height != fr->height) {
		return apply_small(f, m, up, ei);
	}
	covers = covers_all(fr);
	if (fr->width != f->width || fr->height != f->height || !f->comp) {
		/* The decoder bounds both sizes by BC_PROTO_MAX_DIM, so
		 * the product cannot overflow. */
		size_t bytes = (size_t)fr->width * fr->height * 4u;
		uint8_t *comp = bc_calloc(bytes, 1);
		if (!comp) {
			return bc_errinfo_set(ei, BC_ENOMEM,
			                      "no memory for a %ux%u picture",
			                      fr->width, fr->height);
		}
		bc_free(f->comp);
		f->comp = comp;
		f->width = fr->width;
		f->height = fr->height;
		f->have_full = false;
		up->resized = true;
		up->whole = true;
	}
	if ((rc = bc_client_image_apply(&f->full, m, ei))) {
		return rc;
	}
	if (!covers) {
		if (f->comp_stale && f->small.rgba &&
		    f->small.view_width == f->width &&
		    f->small.view_height == f->height) {
			bc_viewer_upscale_part(f->small.rgba, f->small.width,
			                       f->small.height, f->small_u,
			                       f->small_v, f->comp, f->width,
			                       f->height);
			up->whole = true;
		}
		/* The rectangles are relative to a base this picture may not
		 * have: none at all, or an older one than the server thinks
		 * (it counts damage since its last frame, interactive ones
		 * included). */
		up->want_refresh =
		    still && (!f->have_full || !f->last_still || f->comp_stale);
	}
	for (uint32_t i = 0; i < fr->nrects; i++) {
		const struct bc_proto_rect *r = &fr->rects[i];
		for (uint32_t j = 0; j < r->h; j++) {
			size_t at = ((size_t)(r->y + j) * f->width + r->x) * 4u;
			memcpy(f->comp + at, f->full.rgba + at,
			       (size_t)r->w * 4u);
		}
	}
	up->tex = BC_VIEWER_TEX_FULL;
	up->rects = fr->rects;
	up->nrects = fr->nrects;
	f->have_full = true;
	f->comp_stale = false;
	f->showing_small = false;
	f->last_still = still;
	note_level(f, m);
	return 0;
}
