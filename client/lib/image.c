/*
 * The client-side framebuffer: FRAME rectangles decoded in place (JPEG with
 * TurboJPEG, PNG with libpng, raw RGBA copied, H.264 access units through
 * the video module's libavcodec decoder, in a module opened on first use:
 * h264_module.h) into one RGBA image, with a
 * record of which pixels have arrived so that a viewer knows when the
 * picture is whole. Rectangle bytes come from the network: each one's
 * position is checked against the image and its decoded size against the
 * rectangle before a pixel is written.
 */
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <string.h>
#include <turbojpeg.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "client_impl.h"
#include "h264_module.h"

void bc_client_image_init(struct bc_client_image *img)
{
	memset(img, 0, sizeof(*img));
}

/* Ends the H.264 chain: the next frame must be a KEY frame. */
static void video_lost(struct bc_client_image *img)
{
	const struct bc_h264_ops *ops = NULL;
	if (img->video && bc__client_h264(&ops, NULL) == 0) {
		ops->destroy(img->video);
	}
	img->video = NULL;
}

void bc_client_image_finish(struct bc_client_image *img)
{
	if (!img) {
		return;
	}
	if (img->tj) {
		tjDestroy(img->tj);
	}
	video_lost(img);
	bc_free(img->rgba);
	bc_free(img->seen);
	bc_free(img->depth);
	bc_free(img->ids);
	memset(img, 0, sizeof(*img));
}

/* ---- coverage ------------------------------------------------------------ */

/* Counts the pixels of a rectangle as arrived. The bitmap exists only while
 * the image is incomplete and a frame did not cover it in one rectangle. */
static int mark_seen(struct bc_client_image *img, const struct bc_proto_rect *r)
{
	uint64_t total = (uint64_t)img->width * img->height;
	if (img->complete) {
		return 0;
	}
	if (r->x == 0 && r->y == 0 && r->w == img->width &&
	    r->h == img->height) {
		img->complete = true;
	} else {
		if (!img->seen &&
		    !(img->seen = bc_calloc((size_t)((total + 7u) / 8u), 1))) {
			return BC_ENOMEM;
		}
		for (uint32_t y = r->y; y < (uint32_t)r->y + r->h; y++) {
			uint64_t i = (uint64_t)y * img->width + r->x;
			for (uint32_t x = 0; x < r->w; x++, i++) {
				uint8_t bit = (uint8_t)(1u << (i & 7u));
				if (!(img->seen[i >> 3] & bit)) {
					img->seen[i >> 3] |= bit;
					img->nseen++;
				}
			}
		}
		img->complete = img->nseen == total;
	}
	if (img->complete) {
		bc_free(img->seen);
		img->seen = NULL;
		img->nseen = 0;
	}
	return 0;
}

/* Pixels of a failed rectangle are in an unknown state: forget what we knew
 * about coverage, so the image counts as incomplete until a frame covers it
 * whole again. */
static void mark_damaged(struct bc_client_image *img)
{
	img->complete = false;
	bc_free(img->seen);
	img->seen = NULL;
	img->nseen = 0;
}

/* ---- decoders ------------------------------------------------------------ */

static int decode_raw(struct bc_client_image *img,
                      const struct bc_proto_rect *r, struct bc_errinfo *ei)
{
	size_t row = (size_t)r->w * 4u;
	if ((uint64_t)r->data.len != (uint64_t)row * r->h) {
		return bc_errinfo_set(ei, BC_ECODEC,
		                      "raw rectangle %ux%u has %u bytes, not "
		                      "%zu",
		                      r->w, r->h, r->data.len, row * r->h);
	}
	for (uint32_t y = 0; y < r->h; y++) {
		memcpy(img->rgba +
		           (((size_t)r->y + y) * img->width + r->x) * 4u,
		       r->data.ptr + row * y, row);
	}
	return 0;
}

static int decode_jpeg(struct bc_client_image *img,
                       const struct bc_proto_rect *r, struct bc_errinfo *ei)
{
	int w = 0, h = 0, subsamp = 0, colorspace = 0;
	unsigned char *dst;
	if (!img->tj && !(img->tj = tjInitDecompress())) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "cannot start a JPEG decoder");
	}
	if (r->data.len == 0 ||
	    tjDecompressHeader3(img->tj, r->data.ptr, r->data.len, &w, &h,
	                        &subsamp, &colorspace) != 0) {
		return bc_errinfo_set(ei, BC_ECODEC, "JPEG header: %s",
		                      r->data.len ? tjGetErrorStr2(img->tj)
		                                  : "no bytes");
	}
	if (w != (int)r->w || h != (int)r->h) {
		return bc_errinfo_set(ei, BC_ECODEC,
		                      "JPEG of %dx%d in a %ux%u rectangle", w,
		                      h, r->w, r->h);
	}
	dst = img->rgba + ((size_t)r->y * img->width + r->x) * 4u;
	/* Warnings (a truncated stream) count as errors: the pixels they
	 * leave are not the ones the server rendered. */
	if (tjDecompress2(img->tj, r->data.ptr, r->data.len, dst, w,
	                  (int)(img->width * 4u), h, TJPF_RGBA,
	                  TJFLAG_STOPONWARNING) != 0) {
		return bc_errinfo_set(ei, BC_ECODEC, "JPEG: %s",
		                      tjGetErrorStr2(img->tj));
	}
	return 0;
}

/* libpng reads from memory through this cursor and reports through it. */
struct png_src {
	const uint8_t *data;
	size_t len, pos;
	char why[128];
};

static void png_read_mem(png_structp png, png_bytep out, png_size_t n)
{
	struct png_src *s = png_get_io_ptr(png);
	if (n > s->len - s->pos) {
		png_error(png, "truncated PNG");
	}
	memcpy(out, s->data + s->pos, n);
	s->pos += n;
}

static void png_fail(png_structp png, png_const_charp msg)
{
	struct png_src *s = png_get_error_ptr(png);
	snprintf(s->why, sizeof(s->why), "%s", msg);
	png_longjmp(png, 1);
}

static void png_warn(png_structp png, png_const_charp msg)
{
	(void)png;
	(void)msg;
}

/* Through our allocator, so that allocation-failure tests reach libpng. */
static png_voidp png_alloc(png_structp png, png_alloc_size_t n)
{
	(void)png;
	return bc_malloc(n);
}

static void png_dealloc(png_structp png, png_voidp p)
{
	(void)png;
	bc_free(p);
}

static int decode_png(struct bc_client_image *img,
                      const struct bc_proto_rect *r, struct bc_errinfo *ei)
{
	struct png_src src = {.data = r->data.ptr, .len = r->data.len};
	png_structp png;
	png_infop info = NULL;
	png_bytep *volatile rows = NULL;
	png_uint_32 w, h;
	int depth, color, rc = BC_ECODEC;
	if (r->data.len < 8 || png_sig_cmp(r->data.ptr, 0, 8) != 0) {
		return bc_errinfo_set(ei, BC_ECODEC, "not a PNG");
	}
	png = png_create_read_struct_2(PNG_LIBPNG_VER_STRING, &src, png_fail,
	                               png_warn, NULL, png_alloc, png_dealloc);
	if (!png || !(info = png_create_info_struct(png))) {
		png_destroy_read_struct(&png, NULL, NULL);
		return bc_errinfo_set(ei, BC_ENOMEM, "cannot start libpng");
	}
	if (setjmp(png_jmpbuf(png))) {
		rc = bc_errinfo_set(ei, BC_ECODEC, "PNG: %s", src.why);
		goto out;
	}
	/* Nothing bigger than the rectangle is ever decoded. */
	png_set_user_limits(png, r->w, r->h);
	png_set_read_fn(png, &src, png_read_mem);
	png_read_info(png, info);
	png_get_IHDR(png, info, &w, &h, &depth, &color, NULL, NULL, NULL);
	if (w != r->w || h != r->h) {
		rc = bc_errinfo_set(ei, BC_ECODEC,
		                    "PNG of %ux%u in a %ux%u rectangle",
		                    (unsigned)w, (unsigned)h, r->w, r->h);
		goto out;
	}
	/* Whatever the server chose to store, we want 8-bit RGBA. */
	png_set_expand(png);
	png_set_strip_16(png);
	png_set_gray_to_rgb(png);
	if (!(color & PNG_COLOR_MASK_ALPHA) &&
	    !png_get_valid(png, info, PNG_INFO_tRNS)) {
		png_set_add_alpha(png, 0xff, PNG_FILLER_AFTER);
	}
	png_set_interlace_handling(png);
	png_read_update_info(png, info);
	if (png_get_rowbytes(png, info) != (size_t)r->w * 4u) {
		rc = bc_errinfo_set(
		    ei, BC_ECODEC, "PNG rows of %zu bytes, expected %u",
		    (size_t)png_get_rowbytes(png, info), r->w * 4u);
		goto out;
	}
	if (!(rows = bc_calloc(r->h, sizeof(*rows)))) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
		goto out;
	}
	for (uint32_t y = 0; y < r->h; y++) {
		rows[y] =
		    img->rgba + (((size_t)r->y + y) * img->width + r->x) * 4u;
	}
	png_read_image(png, rows);
	png_read_end(png, NULL);
	rc = 0;
out:
	png_destroy_read_struct(&png, &info, NULL);
	bc_free(rows);
	return rc;
}

/* ---- frames ----------------------------------------------------------------
 */

/* Reads the plane rectangle r (4 little-endian bytes a pixel covering the
 * w x h image) into a new array: f32 when depth, else u32. */
static void *read_plane(const struct bc_proto_rect *r, uint32_t w, uint32_t h,
                        bool depth)
{
	size_t n = (size_t)w * h;
	uint32_t *out = bc_malloc(n * 4u);
	if (!out) {
		return NULL;
	}
	for (size_t k = 0; k < n; k++) {
		const uint8_t *p = r->data.ptr + 4u * k;
		if (depth) {
			((float *)(void *)out)[k] = bc_get_f32(p);
		} else {
			out[k] = bc_get_le32(p);
		}
	}
	return out;
}

/* Gives img the size of frame f: a new size is a new, empty picture. */
static int fit(struct bc_client_image *img, const struct bc_msg_frame *f,
               struct bc_errinfo *ei)
{
	size_t bytes;
	if (f->image_width == 0 || f->image_height == 0 ||
	    f->image_width > BC_PROTO_MAX_DIM ||
	    f->image_height > BC_PROTO_MAX_DIM) {
		return bc_errinfo_set(ei, BC_ERANGE, "frame image %ux%u",
		                      f->image_width, f->image_height);
	}
	if (img->rgba && img->width == f->image_width &&
	    img->height == f->image_height) {
		return 0;
	}
	bytes = (size_t)f->image_width * f->image_height * 4u;
	bc_free(img->rgba);
	mark_damaged(img);
	img->width = img->height = 0;
	if (!(img->rgba = bc_calloc(bytes, 1))) {
		return bc_errinfo_set(ei, BC_ENOMEM,
		                      "no memory for a %ux%u image",
		                      f->image_width, f->image_height);
	}
	img->width = f->image_width;
	img->height = f->image_height;
	return 0;
}

/* Records frame m as the last one applied (planes aside). */
static void take_header(struct bc_client_image *img, const struct bc_msg *m,
                        uint32_t ncolour)
{
	const struct bc_msg_frame *f = &m->frame;
	img->view_width = f->width;
	img->view_height = f->height;
	img->frame_no = f->frame_no;
	img->camera_seq = f->camera_seq;
	img->seq = m->seq;
	img->order = f->order;
	img->flags = m->flags;
	img->level = (uint8_t)bc_proto_flags_level(m->flags);
	img->refining = img->level > 0 || (m->flags & BC_PROTO_FLAG_INCOMPLETE);
	img->encoding = f->encoding;
	img->nrects = ncolour;
}

/* An H.264 frame (PROTOCOL.md 7.15, "Encoding 4"): one access unit in one
 * rectangle covering the image, which is the view's size. The access unit
 * is decoded before img changes, so a frame refused leaves the picture as
 * it was. */
static int apply_h264(struct bc_client_image *img, const struct bc_msg *m,
                      struct bc_errinfo *ei)
{
	const struct bc_msg_frame *f = &m->frame;
	const struct bc_proto_rect *r = &f->rects[0];
	const struct bc_h264_ops *ops = NULL;
	struct bc_errinfo why = {0};
	const uint8_t *px;
	size_t stride;
	int rc;
	if (f->nrects != 1 || r->x != 0 || r->y != 0 ||
	    r->w != f->image_width || r->h != f->image_height ||
	    f->image_width != f->width || f->image_height != f->height) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "H.264 frame %u is not one rectangle "
		                      "covering its %ux%u view",
		                      f->frame_no, f->width, f->height);
	}
	if ((m->flags & BC_PROTO_FLAG_KEY) && !img->video &&
	    ((rc = bc__client_h264(&ops, ei)) ||
	     (rc = ops->open(&img->video, ei)))) {
		return rc;
	}
	if (!img->video) {
		return bc_errinfo_set(
		    ei, BC_ESTATE,
		    "H.264 frame %u builds on frames this "
		    "image did not decode (no KEY frame since "
		    "the start or since a frame that failed); "
		    "send VIEW again to get a KEY frame",
		    f->frame_no);
	}
	/* A decoder exists: the module is loaded. */
	bc__client_h264(&ops, NULL);
	if ((rc = ops->decode(img->video, r->data.ptr, r->data.len,
	                      f->image_width, f->image_height, &px, &stride,
	                      &why))) {
		video_lost(img);
		return bc_errinfo_set(ei, rc == BC_ENOMEM ? rc : BC_ECODEC,
		                      "H.264 frame %u does not decode (%s); "
		                      "send VIEW again to get a KEY frame",
		                      f->frame_no, why.msg);
	}
	if ((rc = fit(img, f, ei))) {
		return rc;
	}
	for (uint32_t y = 0; y < img->height; y++) {
		memcpy(img->rgba + (size_t)y * img->width * 4u,
		       px + (size_t)y * stride, (size_t)img->width * 4u);
	}
	bc_free(img->depth);
	bc_free(img->ids);
	img->depth = NULL;
	img->ids = NULL;
	take_header(img, m, 1);
	/* Covers the image: cannot fail. */
	return mark_seen(img, r);
}

int bc_client_image_apply(struct bc_client_image *img, const struct bc_msg *m,
                          struct bc_errinfo *ei)
{
	const struct bc_msg_frame *f = &m->frame;
	/* A snapshot's planes follow its colour rectangle (PROTOCOL.md
	 * 7.15); the colour is the rectangles before them. */
	uint32_t nplanes, ncolour;
	void *plane[2] = {NULL, NULL};
	int rc;
	if (m->type != BC_MSG_FRAME) {
		return bc_errinfo_set(ei, BC_EINVAL, "not a FRAME");
	}
	if (f->encoding == BC_PROTO_ENC_H264 &&
	    !(m->flags & BC_PROTO_FLAG_SNAPSHOT)) {
		return apply_h264(img, m, ei);
	}
	nplanes = (m->flags & BC_PROTO_FLAG_SNAPSHOT)
	              ? bc_proto_flags_nplanes(m->flags)
	              : 0u;
	if (f->nrects <= nplanes) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "%u rectangles for %u planes", f->nrects,
		                      nplanes);
	}
	ncolour = f->nrects - nplanes;
	if ((rc = fit(img, f, ei))) {
		return rc;
	}
	/* Check every rectangle before writing any, so a frame with one bad
	 * rectangle leaves the picture as it was. */
	for (uint32_t i = 0; i < f->nrects; i++) {
		const struct bc_proto_rect *r = &f->rects[i];
		if (r->w == 0 || r->h == 0 ||
		    (uint32_t)r->x + r->w > img->width ||
		    (uint32_t)r->y + r->h > img->height) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "rectangle %u (%u,%u %ux%u) is "
			                      "outside the %ux%u image",
			                      i, r->x, r->y, r->w, r->h,
			                      img->width, img->height);
		}
		if (i >= ncolour &&
		    (r->x != 0 || r->y != 0 || r->w != img->width ||
		     r->h != img->height ||
		     r->data.len != (uint64_t)r->w * r->h * 4u)) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "plane rectangle %u is not the "
			                      "whole %ux%u image at 4 bytes a "
			                      "pixel",
			                      i, img->width, img->height);
		}
	}
	if (f->encoding <= BC_PROTO_ENC_INVALID ||
	    f->encoding >= BC_PROTO_ENC_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM, "frame encoding %d",
		                      (int)f->encoding);
	}
	for (uint32_t k = 0; k < nplanes; k++) {
		bool depth = k == 0 && (m->flags & BC_PROTO_FLAG_DEPTH);
		if (!(plane[k] = read_plane(&f->rects[ncolour + k], img->width,
		                            img->height, depth))) {
			bc_free(plane[0]);
			return bc_errinfo_set(ei, BC_ENOMEM,
			                      "no memory for a plane");
		}
	}
	/* The planes belong to the frame that carried them. */
	bc_free(img->depth);
	bc_free(img->ids);
	img->depth = NULL;
	img->ids = NULL;
	for (uint32_t k = 0; k < nplanes; k++) {
		if (k == 0 && (m->flags & BC_PROTO_FLAG_DEPTH)) {
			img->depth = plane[k];
		} else {
			img->ids = plane[k];
		}
	}
	take_header(img, m, ncolour);
	for (uint32_t i = 0; i < ncolour; i++) {
		const struct bc_proto_rect *r = &f->rects[i];
		switch (f->encoding) {
		case BC_PROTO_ENC_JPEG:
			rc = decode_jpeg(img, r, ei);
			break;
		case BC_PROTO_ENC_PNG:
			rc = decode_png(img, r, ei);
			break;
		case BC_PROTO_ENC_RAW:
			rc = decode_raw(img, r, ei);
			break;
		default:
			/* H.264 in a SNAPSHOT's answer (the codec refuses
			 * it; a message built by hand may not). */
			rc = bc_errinfo_set(ei, BC_ECODEC,
			                    "a snapshot in H.264");
			break;
		}
		if (!rc && (rc = mark_seen(img, r))) {
			bc_errinfo_set(ei, rc, "out of memory");
		}
		if (rc) {
			mark_damaged(img);
			return rc;
		}
	}
	return 0;
}
