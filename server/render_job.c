/*
 * What one render job does on the render thread (rthread.c runs it in
 * command order): a PICK's single ray, or a frame -- syncing the replica's
 * renderer, updating the view (views.c), choosing the rectangles to send
 * and encoding them, with a SNAPSHOT's depth and id planes -- whose result
 * goes back to the loop thread through the result queue.
 */
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/clock.h"
#include "blobcast/log.h"
#include "encode.h"
#include "rthread_impl.h"

/* One ray of the job's camera through pixel (x, y), sphere traced on the
 * full tree (a pick is one ray: no tiles to share). */
static void pick(struct replica *rp, struct bc_rjob *job, struct rresult *res)
{
	const struct bc_lin *l = rp->tree ? bc_tree_lin(rp->tree) : NULL;
	struct bc_view_rays vr;
	float d[3], t0 = 0.0f, t1 = INFINITY, eps;
	if (!l) {
		return;
	}
	bc_view_rays_init(&vr, &job->camera, job->width, job->height);
	bc_view_rays_dir(&vr, (float)job->pick_x + 0.5f,
	                 (float)job->pick_y + 0.5f, d);
	for (int i = 0; i < 3; i++) {
		float inv = 1.0f / d[i];
		float a = (l->lo[i] - vr.eye[i]) * inv;
		float b = (l->hi[i] - vr.eye[i]) * inv;
		if (d[i] == 0.0f) {
			if (vr.eye[i] < l->lo[i] || vr.eye[i] > l->hi[i]) {
				return;
			}
			continue;
		}
		t0 = fmaxf(t0, fminf(a, b));
		t1 = fminf(t1, fmaxf(a, b));
	}
	eps = 1e-4f * l->size;
	for (int step = 0; step < 100000 && t0 <= t1; step++) {
		float p[3] = {vr.eye[0] + t0 * d[0], vr.eye[1] + t0 * d[1],
		              vr.eye[2] + t0 * d[2]};
		uint32_t k;
		float f = bc_eval_full_id(l, p, &k);
		if (f < eps) {
			res->hit = k != BC_NONE;
			res->node = res->hit ? l->node_id[l->prim_slot[k]] : 0;
			memcpy(res->position, p, sizeof(p));
			res->depth = t0;
			return;
		}
		/* The compact operators compress the field: 1.45 bounds its
		 * Lipschitz constant (Zanni 2024, §7). */
		t0 += fmaxf(f / 1.45f, eps);
	}
}

/* A snapshot's depth (f32, +inf on a miss) or id (u32, 0 on a miss) plane
 * of v's level-0 frame as the wire carries it: 4 bytes a pixel,
 * little-endian whatever the host's order (PROTOCOL.md 7.17). Returns a
 * bc_malloc'ed buffer of width * height * 4 bytes, or NULL. */
static uint8_t *plane_bytes(const struct view *v, bool depth)
{
	size_t n = (size_t)v->width * v->height;
	uint8_t *out = bc_malloc(n * 4u);
	if (!out) {
		return NULL;
	}
	for (size_t i = 0; i < n; i++) {
		uint32_t u;
		if (depth) {
			memcpy(&u, &v->frame.depth[i], sizeof(u));
		} else {
			u = v->frame.ids[i];
		}
		bc_put_le32(out + 4u * i, u);
	}
	return out;
}

void bc__run_job(struct bc_rthread *rt, struct bc_rjob *job,
                 struct rresult *res)
{
	struct replica *rp = bc__replica_of(rt, job->session_id, false);
	struct bc_errinfo ei = {0};
	struct bc_proto_rect whole, *rects = &whole;
	/* A snapshot's colour rectangle and its planes (PROTOCOL.md 7.17). */
	struct bc_proto_rect snap[3];
	uint8_t *planes[2] = {NULL, NULL};
	uint32_t nplanes = 0;
	struct bc_encoded *enc = NULL;
	struct bc_msg m = {.type = BC_MSG_FRAME};
	struct bc_proto_buf b;
	struct view *v;
	const uint8_t *pix;
	uint32_t nrects = 1, iw, ih;
	bool incomplete = false, yielded = false, lossless, patch;
	int encoding, quality, rc;
	double t0, t1;
	res->job = job;
	if (!rp || !rp->tree || !bc_tree_lin(rp->tree)) {
		bc__push_result(rt, res);
		return;
	}
	if (job->pick) {
		pick(rp, job, res);
		bc__push_result(rt, res);
		return;
	}
	if (!rp->r && bc_renderer_create(&rp->r, rt->backend, &rt->opts, &ei)) {
		bc_log(BC_LOG_ERROR, "renderer: %s", ei.msg);
		bc__push_result(rt, res);
		return;
	}
	t0 = bc_clock_ms();
	if (rp->fresh) {
		struct bc_dirty ignored;
		bc_tree_take_dirty(rp->tree, &ignored);
		rp->fresh = false;
		if (bc_renderer_sync(rp->r, rp->tree, NULL, &ei)) {
			goto fail;
		}
	} else {
		struct bc_dirty dirty;
		bc_tree_take_dirty(rp->tree, &dirty);
		if (dirty.edits &&
		    bc_renderer_sync(rp->r, rp->tree, &dirty, &ei)) {
			goto fail;
		}
	}
	if (!(v = bc__view_of(rt, job))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for a %ux%u view",
		               job->width, job->height);
		goto fail;
	}
	if (bc__update_view(rt, rp, v, job, &incomplete, &yielded, &ei)) {
		v->level = -1;
		goto fail;
	}
	if (yielded) {
		/* Nothing new to show: the refinement waits behind newer
		 * work, and the targets stay owed a frame. */
		res->yielded = true;
		bc__push_result(rt, res);
		return;
	}
	t1 = bc_clock_ms();
	res->render_ms = t1 - t0;
	/* What to send: the tiles changed since the picture the targets
	 * hold, when they hold this view at level 0 and the frame keeps its
	 * kind (a still over a lossless base, or an interactive frame);
	 * else the whole picture at the view's level. */
	lossless = job->snapshot_seq || (job->final && v->level == 0);
	encoding = lossless ? job->encoding : job->encoding_interactive;
	quality = lossless ? job->quality_still : job->quality_interactive;
	patch = !job->snapshot_seq && v->level == 0 &&
	        job->shown.view == v->id && job->shown.level == 0 &&
	        (!lossless || job->shown.lossless);
	if (!(pix = bc__picture(rt, v, &iw, &ih))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for a picture");
		goto fail;
	}
	whole =
	    (struct bc_proto_rect){0, 0, (uint16_t)iw, (uint16_t)ih, {NULL, 0}};
	if (patch) {
		bool none;
		uint32_t n =
		    bc__changed_rects(rt, v, job->shown.version, &none);
		if (n > 0) {
			rects = rt->rects;
			nrects = n;
		} else if (none) {
			/* Nothing visible changed: the smallest frame still
			 * tells the order reached. */
			whole.w = (uint16_t)(iw < 16 ? iw : 16);
			whole.h = (uint16_t)(ih < 16 ? ih : 16);
		}
	}
	if (!(enc = bc_calloc(nrects, sizeof(*enc)))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for %u rectangles",
		               nrects);
		goto fail;
	}
	for (uint32_t i = 0; i < nrects; i++) {
		if (bc_encode_rect(rt->enc, pix, iw, rects[i].x, rects[i].y,
		                   rects[i].w, rects[i].h, encoding, quality,
		                   &enc[i])) {
			bc_errinfo_set(&ei, BC_ECODEC, "encoding failed");
			goto fail;
		}
		rects[i].data.ptr = enc[i].data;
		rects[i].data.len = (uint32_t)enc[i].len;
	}
	m.flags = bc_proto_flags_with_level(0, (unsigned)v->level);
	m.frame.nrects = (uint16_t)nrects;
	m.frame.rects = rects;
	if (job->snapshot_seq && v->level == 0) {
		/* The planes of the whole view at level 0, as its colour:
		 * depth first, then ids. */
		static const struct {
			uint8_t plane;
			uint16_t flag;
		} kinds[2] = {{BC_PROTO_PLANE_DEPTH, BC_PROTO_FLAG_DEPTH},
		              {BC_PROTO_PLANE_IDS, BC_PROTO_FLAG_IDS}};
		snap[0] = rects[0];
		for (uint32_t k = 0; k < 2; k++) {
			if (!(job->snapshot_planes & kinds[k].plane)) {
				continue;
			}
			if (!(planes[nplanes] = plane_bytes(v, k == 0))) {
				bc_errinfo_set(&ei, BC_ENOMEM,
				               "no memory for a %ux%u plane",
				               v->width, v->height);
				goto fail;
			}
			snap[1 + nplanes] = (struct bc_proto_rect){
			    0,
			    0,
			    (uint16_t)iw,
			    (uint16_t)ih,
			    {planes[nplanes], (uint32_t)iw * ih * 4u}};
			m.flags |= kinds[k].flag;
			nplanes++;
		}
		m.frame.nrects = (uint16_t)(1u + nplanes);
		m.frame.rects = snap;
	}
	if (job->snapshot_seq) {
		m.flags |= BC_PROTO_FLAG_SNAPSHOT | BC_PROTO_FLAG_STILL;
	} else if (lossless) {
		m.flags |= BC_PROTO_FLAG_STILL;
	}
	if (incomplete || v->stuck) {
		m.flags |= BC_PROTO_FLAG_INCOMPLETE;
		res->incomplete = true;
		bc_log(BC_LOG_WARN,
		       "session %u: frame %u refined only to level %d within "
		       "the %u ms budget",
		       job->session_id, job->frame_no, v->level, rt->budget_ms);
	}
	m.seq = job->snapshot_seq;
	m.frame.frame_no = job->frame_no;
	m.frame.order = job->order;
	m.frame.camera_seq = job->camera_seq;
	m.frame.encoding = (enum bc_proto_encoding)encoding;
	m.frame.width = (uint16_t)job->width;
	m.frame.height = (uint16_t)job->height;
	m.frame.image_width = (uint16_t)iw;
	m.frame.image_height = (uint16_t)ih;
	/* Encoded up to the protocol's limit: each target's own
	 * max_frame_bytes is checked when it is delivered (a frame over it is
	 * answered ERROR ELIMIT, PROTOCOL.md 7.15). */
	bc_proto_buf_init(&b,
	                  (size_t)BC_PROTO_MAX_PAYLOAD + BC_PROTO_HEADER_SIZE);
	rc = bc_proto_encode(&b, &m, &ei);
	res->too_big = rc == BC_ELIMIT || rc == BC_EPROTO_LENGTH;
	if (rc == 0 && !(res->frame = bc_shared_new(b.len))) {
		bc_errinfo_set(&ei, BC_ENOMEM, "no memory for a frame");
		res->oom = true;
	}
	if (res->frame) {
		memcpy(res->frame->data, b.data, b.len);
		res->shown = (struct bc_shown){
		    .view = v->id,
		    .version = v->version,
		    .level = (int8_t)v->level,
		    .lossless =
		        lossless && (patch ? job->shown.lossless : true),
		    .refining = v->level > 0 && !v->stuck,
		    .still = (m.flags & BC_PROTO_FLAG_STILL) != 0,
		};
	} else {
		bc_log(BC_LOG_WARN, "frame %u not sent: %s", job->frame_no,
		       ei.msg);
	}
	bc_proto_buf_finish(&b);
	res->encode_ms = bc_clock_ms() - t1;
	for (uint32_t i = 0; i < nrects; i++) {
		bc_free(enc[i].data);
		rects[i].data.ptr = NULL;
	}
	bc_free(enc);
	bc_free(planes[0]);
	bc_free(planes[1]);
	bc__push_result(rt, res);
	return;
fail:
	bc_log(BC_LOG_ERROR, "session %u: frame failed: %s", job->session_id,
	       ei.msg);
	res->oom = ei.code == BC_ENOMEM;
	if (enc) {
		for (uint32_t i = 0; i < nrects; i++) {
			bc_free(enc[i].data);
			rects[i].data.ptr = NULL;
		}
		bc_free(enc);
	}
	bc_free(planes[0]);
	bc_free(planes[1]);
	bc__push_result(rt, res);
}
