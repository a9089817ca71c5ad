/*
 * H.264 frames (encoding 4) in libblobcast: bc_client_image_apply() on
 * access units made by the video module's encoder and wrapped in FRAMEs
 * (a chain that starts at a KEY frame, a delta frame with no chain, a
 * frame that does not decode, a PNG still inside the chain, odd sizes),
 * then against a real blobcastd: a stream of a 321x241 and a 320x240 view
 * decoded and compared by PSNR with raw snapshots of the same camera, a
 * moving frame, a delta frame refused by a fresh image, KEY after VIEW is
 * sent again, and FRAME_ACK.
 */
#include <math.h>

#include "blobcast/client.h"
#include "blobcast/video.h"
#include "test.h" /* before daemon.h: its test runner needs it */
/* Not every helper of daemon.h is used here. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include "daemon.h"
#pragma GCC diagnostic pop

static char base_dir[96];

/* PSNR floors (dB over RGB). A still is an IDR at quantizer 12 (about 45
 * dB on rendered frames, PROTOCOL.md 7.15); a moving frame is coded at
 * the stream's rate; a decoder that puts pixels in the wrong place, or
 * the wrong colours, stays far under both (about 10-15 dB). The daemon's
 * still of the default scene at 321x241 or 320x240 measures 37.6-37.8 dB
 * against its raw snapshot: in so small a picture the colour edges that
 * 4:2:0 halves weigh more (tests/server/test_h264.c, docs/video.md), so
 * its floor is lower; the PNG still (still_encoding) is exact. */
#define STILL_PSNR 38.0
#define DAEMON_STILL_PSNR 36.0
#define MOVING_PSNR 30.0

/* PSNR over the RGB channels of two RGBA pictures of w x h. */
static double rgba_psnr(const uint8_t *a, const uint8_t *b, uint32_t w,
                        uint32_t h)
{
	double se = 0.0;
	size_t n = (size_t)w * h;
	for (size_t i = 0; i < n; i++) {
		for (int k = 0; k < 3; k++) {
			double d = (double)a[i * 4 + k] - (double)b[i * 4 + k];
			se += d * d;
		}
	}
	se /= 3.0 * (double)n;
	return se == 0.0 ? 99.0 : 10.0 * log10(255.0 * 255.0 / se);
}

/* ---- access units from the encoder --------------------------------------- */

/* A smooth picture with edges, like a render: a shaded disc at (cx, cy) on
 * a gradient, RGBA. */
static void draw(uint8_t *px, uint32_t w, uint32_t h, double cx, double cy)
{
	for (uint32_t y = 0; y < h; y++) {
		for (uint32_t x = 0; x < w; x++) {
			uint8_t *p = px + ((size_t)y * w + x) * 4u;
			double dx = x - cx, dy = y - cy;
			double r = sqrt(dx * dx + dy * dy);
			bool in = r < h / 3.0;
			double s = in ? 1.0 - r / h : 0.0;
			p[0] =
			    (uint8_t)(in ? 60 + 180 * s : 30 + 100.0 * x / w);
			p[1] = (uint8_t)(in ? 40 + 120 * s : 40 + 80.0 * y / h);
			p[2] = (uint8_t)(in ? 200 * s : 90);
			p[3] = 255;
		}
	}
}

/* A FRAME of view w x h carrying bytes as its one rectangle. */
static void frame_msg(struct bc_msg *m, struct bc_proto_rect *r,
                      enum bc_proto_encoding enc, uint32_t no, uint16_t flags,
                      uint32_t w, uint32_t h, const uint8_t *bytes, size_t len)
{
	memset(m, 0, sizeof(*m));
	memset(r, 0, sizeof(*r));
	m->type = BC_MSG_FRAME;
	m->flags = flags;
	m->frame.frame_no = no;
	m->frame.encoding = enc;
	m->frame.width = m->frame.image_width = (uint16_t)w;
	m->frame.height = m->frame.image_height = (uint16_t)h;
	r->w = (uint16_t)w;
	r->h = (uint16_t)h;
	r->data.ptr = bytes;
	r->data.len = (uint32_t)len;
	m->frame.rects = r;
	m->frame.nrects = 1;
}

/* An encoded stream of n pictures of w x h, the disc moving: the first an
 * IDR at the still quantizer, the second an IDR too (the first moving frame
 * after a still is one, video.h), the others deltas. */
struct stream {
	uint32_t w, h, n;
	uint8_t *src[4]; /* the pictures, RGBA */
	uint8_t *au[4];
	size_t len[4];
	bool idr[4];
};

static bool stream_make(struct stream *s, uint32_t w, uint32_t h, uint32_t n)
{
	struct bc_video_opts o = {.backend = BC_VIDEO_BACKEND_X264,
	                          .pixfmt = BC_VIDEO_PIX_RGBA,
	                          .bitrate = 2000000};
	struct bc_video_encoder *enc = NULL;
	struct bc_errinfo ei = {0};
	bool ok = true;
	memset(s, 0, sizeof(*s));
	s->w = w;
	s->h = h;
	s->n = n;
	if (bc_video_encoder_open(w, h, &o, &enc, &ei)) {
		fprintf(stderr, "  encoder: %s\n", ei.msg);
		return false;
	}
	for (uint32_t i = 0; i < n && ok; i++) {
		struct bc_video_au au;
		s->src[i] = bc_malloc((size_t)w * h * 4u);
		ok = s->src[i] != NULL;
		if (ok) {
			draw(s->src[i], w, h, w / 2.0 + 6.0 * i,
			     h / 2.0 + 3.0 * i);
			ok = bc_video_encode(enc, s->src[i], (size_t)w * 4u,
			                     i == 0 ? BC_VIDEO_STILL : 0, &au,
			                     &ei) == 0;
		}
		if (ok && (s->au[i] = bc_malloc(au.len)) != NULL) {
			memcpy(s->au[i], au.data, au.len);
			s->len[i] = au.len;
			s->idr[i] = au.idr;
		} else {
			fprintf(stderr, "  encode %u: %s\n", i, ei.msg);
			ok = false;
		}
	}
	bc_video_encoder_destroy(enc);
	return ok;
}

static void stream_free(struct stream *s)
{
	for (uint32_t i = 0; i < 4; i++) {
		bc_free(s->src[i]);
		bc_free(s->au[i]);
	}
}

/* Applies picture i of s as frame no; returns bc_client_image_apply's. */
static int apply_au(struct bc_client_image *img, const struct stream *s,
                    uint32_t i, uint32_t no, struct bc_errinfo *ei)
{
	struct bc_msg m;
	struct bc_proto_rect r;
	frame_msg(&m, &r, BC_PROTO_ENC_H264, no,
	          s->idr[i] ? BC_PROTO_FLAG_KEY : 0, s->w, s->h, s->au[i],
	          s->len[i]);
	return bc_client_image_apply(img, &m, ei);
}

static void chain_decodes_from_key_at_odd_and_even_sizes(void)
{
	static const uint32_t sizes[2][2] = {{321, 241}, {320, 240}};
	for (int k = 0; k < 2; k++) {
		struct stream s;
		struct bc_client_image img;
		struct bc_errinfo ei = {0};
		bc_client_image_init(&img);
		REQUIRE(stream_make(&s, sizes[k][0], sizes[k][1], 4));
		CHECK(s.idr[0] && s.idr[1] && !s.idr[2] && !s.idr[3]);
		for (uint32_t i = 0; i < 4; i++) {
			double db;
			int rc = apply_au(&img, &s, i, i + 1, &ei);
			if (rc) {
				fprintf(stderr, "  frame %u: %s\n", i, ei.msg);
			}
			CHECK_EQ_INT(rc, 0);
			CHECK_EQ_INT(img.width, s.w);
			CHECK_EQ_INT(img.height, s.h);
			CHECK(img.complete);
			CHECK_EQ_INT(img.encoding, BC_PROTO_ENC_H264);
			CHECK_EQ_INT(img.frame_no, i + 1);
			db = rgba_psnr(img.rgba, s.src[i], s.w, s.h);
			printf("  %ux%u frame %u: PSNR %.2f dB\n", s.w, s.h, i,
			       db);
			CHECK(db >= (i == 0 ? STILL_PSNR : MOVING_PSNR));
			/* Alpha is opaque, as for every encoding. */
			CHECK_EQ_INT(img.rgba[3], 255);
		}
		stream_free(&s);
		bc_client_image_finish(&img);
	}
}

static void delta_without_key_is_refused_and_changes_nothing(void)
{
	struct stream s;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	uint8_t *before;
	bc_client_image_init(&img);
	REQUIRE(stream_make(&s, 161, 121, 3));
	/* Nothing decoded yet: the delta frame has nothing to build on. */
	CHECK_EQ_INT(apply_au(&img, &s, 2, 2, &ei), BC_ESTATE);
	CHECK(strstr(ei.msg, "send VIEW again") != NULL);
	CHECK(img.rgba == NULL && img.frame_no == 0 && !img.complete);
	/* A KEY frame starts the chain. */
	REQUIRE(apply_au(&img, &s, 1, 3, &ei) == 0);
	REQUIRE((before = bc_malloc((size_t)161 * 121 * 4u)) != NULL);
	memcpy(before, img.rgba, (size_t)161 * 121 * 4u);
	/* Bytes that are not H.264 end the chain; the picture stays. */
	{
		static const uint8_t junk[] = {
		    0, 0, 0, 1, 0x41, 0x9a, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66};
		struct bc_msg m;
		struct bc_proto_rect r;
		frame_msg(&m, &r, BC_PROTO_ENC_H264, 4, 0, 161, 121, junk,
		          sizeof(junk));
		memset(&ei, 0, sizeof(ei));
		CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
		CHECK(strstr(ei.msg, "send VIEW again") != NULL);
	}
	CHECK(memcmp(before, img.rgba, (size_t)161 * 121 * 4u) == 0);
	CHECK_EQ_INT(img.frame_no, 3);
	/* After the failure a good delta is refused too, until a KEY. */
	CHECK_EQ_INT(apply_au(&img, &s, 2, 5, &ei), BC_ESTATE);
	CHECK(memcmp(before, img.rgba, (size_t)161 * 121 * 4u) == 0);
	CHECK_EQ_INT(apply_au(&img, &s, 1, 6, &ei), 0);
	CHECK_EQ_INT(apply_au(&img, &s, 2, 7, &ei), 0);
	CHECK(rgba_psnr(img.rgba, s.src[2], s.w, s.h) >= MOVING_PSNR);
	bc_free(before);
	stream_free(&s);
	bc_client_image_finish(&img);
}

static void frame_shapes_that_are_not_a_view_are_refused(void)
{
	struct stream s;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	struct bc_proto_rect r;
	bc_client_image_init(&img);
	REQUIRE(stream_make(&s, 64, 48, 1));
	/* A rectangle smaller than the view. */
	frame_msg(&m, &r, BC_PROTO_ENC_H264, 1, BC_PROTO_FLAG_KEY, 64, 48,
	          s.au[0], s.len[0]);
	r.w = 32;
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ERANGE);
	/* An image smaller than the view (a coarse level is scaled up by
	 * the server before encoding). */
	frame_msg(&m, &r, BC_PROTO_ENC_H264, 1, BC_PROTO_FLAG_KEY, 64, 48,
	          s.au[0], s.len[0]);
	m.frame.width = 128;
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ERANGE);
	/* A view of another size than the stream codes. */
	frame_msg(&m, &r, BC_PROTO_ENC_H264, 1, BC_PROTO_FLAG_KEY, 80, 48,
	          s.au[0], s.len[0]);
	CHECK_EQ_INT(bc_client_image_apply(&img, &m, &ei), BC_ECODEC);
	CHECK(img.rgba == NULL);
	stream_free(&s);
	bc_client_image_finish(&img);
}

static void a_raw_still_leaves_the_chain_going(void)
{
	struct stream s;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	struct bc_proto_rect r;
	bc_client_image_init(&img);
	REQUIRE(stream_make(&s, 97, 65, 4));
	REQUIRE(apply_au(&img, &s, 1, 1, &ei) == 0);
	REQUIRE(apply_au(&img, &s, 2, 2, &ei) == 0);
	/* The still in raw (VIEW still_encoding): exact. */
	frame_msg(&m, &r, BC_PROTO_ENC_RAW, 3, BC_PROTO_FLAG_STILL, 97, 65,
	          s.src[2], (size_t)97 * 65 * 4u);
	REQUIRE(bc_client_image_apply(&img, &m, &ei) == 0);
	CHECK(memcmp(img.rgba, s.src[2], (size_t)97 * 65 * 4u) == 0);
	/* The next H.264 frame builds on frame 2, not on the still. */
	CHECK_EQ_INT(apply_au(&img, &s, 3, 4, &ei), 0);
	CHECK(rgba_psnr(img.rgba, s.src[3], s.w, s.h) >= MOVING_PSNR);
	stream_free(&s);
	bc_client_image_finish(&img);
}

/* Without its module a KEY frame is refused with ENOTSUP and a sentence
 * naming the module and the variable. The module is looked for once per
 * process, so the test runs itself again with BLOBCAST_H264_MODULE naming
 * no file. */
static void a_missing_module_is_named(void)
{
	static const char *const env = "BLOBCAST_H264_MODULE";
	struct stream s;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	int status = 0;
	pid_t pid;
	if (!getenv(env)) {
		fflush(NULL);
		REQUIRE((pid = fork()) >= 0);
		if (pid == 0) {
			setenv(env, "/nonexistent/bc_client_h264.so", 1);
			execl("/proc/self/exe", "test_client_video",
			      "a_missing_module_is_named", (char *)NULL);
			_exit(127);
		}
		waitpid(pid, &status, 0);
		CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
		return;
	}
	REQUIRE(stream_make(&s, 64, 48, 1));
	bc_client_image_init(&img);
	CHECK_EQ_INT(apply_au(&img, &s, 0, 1, &ei), BC_ENOTSUP);
	printf("  %s\n", ei.msg);
	CHECK(img.rgba == NULL);
	CHECK(strstr(ei.msg, "bc_client_h264.so") != NULL);
	CHECK(strstr(ei.msg, env) != NULL);
	bc_client_image_finish(&img);
	stream_free(&s);
}

/* ---- against blobcastd --------------------------------------------------- */

static int connect_video(const struct daemon *d, bool acks,
                         struct bc_client **c, struct bc_errinfo *ei)
{
	char addr[128];
	snprintf(addr, sizeof(addr), "unix:%s", d->sock);
	return bc_client_connect(
	    c,
	    &(struct bc_client_opts){.addr = addr,
	                             .name = "video",
	                             .encodings = BC_PROTO_ENCODINGS_ALL,
	                             .acks = acks},
	    ei);
}

/* Receives FRAMEs until one has all of flags (and, when seq, shows CAMERA
 * seq), applying each H.264 frame of the view to img (when not NULL) and
 * acknowledging each when ack; *first_flags receives the first frame's
 * flags, *copy (may be NULL; img's size) the picture of the last frame
 * without STILL. Returns 0 or the error. */
struct collect {
	uint16_t want;       /* flags the last frame must have */
	uint32_t camera_seq; /* 0: any */
	/* The encoding a still may come in besides H.264 (0: none). */
	enum bc_proto_encoding still_encoding;
	bool ack;
	uint32_t frames;
	uint16_t first_flags;
	uint16_t last_flags; /* the flags of the frame collect ended at */
	uint8_t *moving; /* the last moving picture, bc_malloc'ed, or NULL */
	uint32_t moving_no;
	/* A copy of the first delta frame (no KEY) that came. */
	struct bc_msg delta;
	struct bc_proto_rect delta_rect;
	uint8_t *delta_bytes;
	size_t delta_len;
};

static int collect(struct bc_client *c, struct bc_client_image *img,
                   struct collect *k, struct bc_errinfo *ei)
{
	struct bc_msg m;
	int64_t until = t_now_ms() + 15000;
	while (t_now_ms() < until) {
		int rc = bc_client_recv(c, &m, 200);
		if (rc < 0) {
			return bc_client_error(c, ei);
		}
		if (rc == 0) {
			continue;
		}
		if (m.type == BC_MSG_ERROR) {
			return bc_errinfo_set(
			    ei, -(int)m.error.code, "server: %.*s",
			    (int)m.error.text.len, m.error.text.ptr);
		}
		if (m.type != BC_MSG_FRAME) {
			continue;
		}
		if (k->frames++ == 0) {
			k->first_flags = m.flags;
		}
		if (m.frame.encoding != BC_PROTO_ENC_H264 &&
		    !((m.flags & BC_PROTO_FLAG_STILL) &&
		      m.frame.encoding == k->still_encoding)) {
			return bc_errinfo_set(
			    ei, BC_EENUM, "frame %u in %s", m.frame.frame_no,
			    bc_proto_encoding_name(m.frame.encoding));
		}
		if ((rc = bc_client_image_apply(img, &m, ei))) {
			return rc;
		}
		if (k->ack &&
		    (rc = bc_client_frame_ack(c, m.frame.frame_no, ei))) {
			return rc;
		}
		if (!(m.flags & BC_PROTO_FLAG_KEY) && !k->delta_bytes &&
		    (k->delta_bytes = bc_malloc(m.frame.rects[0].data.len))) {
			k->delta = m;
			k->delta_rect = m.frame.rects[0];
			k->delta_len = m.frame.rects[0].data.len;
			memcpy(k->delta_bytes, m.frame.rects[0].data.ptr,
			       k->delta_len);
			k->delta_rect.data.ptr = k->delta_bytes;
			k->delta.frame.rects = &k->delta_rect;
		}
		if (!(m.flags & BC_PROTO_FLAG_STILL) &&
		    (!k->camera_seq || m.frame.camera_seq == k->camera_seq)) {
			size_t n = (size_t)img->width * img->height * 4u;
			bc_free(k->moving);
			if ((k->moving = bc_malloc(n))) {
				memcpy(k->moving, img->rgba, n);
				k->moving_no = m.frame.frame_no;
			}
		}
		if ((m.flags & k->want) == k->want &&
		    (!k->camera_seq || m.frame.camera_seq == k->camera_seq)) {
			k->last_flags = m.flags;
			return 0;
		}
	}
	return bc_errinfo_set(ei, BC_ETIMEOUT, "no frame with flags 0x%x",
	                      k->want);
}

/* rc, after saying what failed (a view of w x h, at what) when it is an
 * error. */
static int said(int rc, uint16_t w, uint16_t h, const char *what,
                const struct bc_errinfo *ei)
{
	if (rc) {
		fprintf(stderr, "  %ux%u%s: %s (%s)\n", w, h, what, ei->msg,
		        bc_err_name(rc));
	}
	return rc;
}

/* Moves the camera (interacting) at least moves times, and on until the
 * first frame of the camera last sent is a moving frame, collecting each:
 * on a busy machine the daemon may draw a camera's still as its first
 * frame, the interaction having gone idle while the frame was drawn, and a
 * test that wants a moving frame of that camera asks again. */
static int drag_until_moving(struct bc_client *c, struct bc_camera *cam,
                             float step, int moves, struct bc_client_image *img,
                             struct collect *k, struct bc_errinfo *ei)
{
	for (int i = 0; i < 40; i++) {
		uint32_t seq = 0;
		int rc;
		/* The extra moves go back and forth around the last. */
		bool back = i >= moves && (i - moves) % 2 == 0;
		cam->eye[1] += back ? -step : step;
		if ((rc = bc_client_camera(c, cam, true, &seq, ei))) {
			return rc;
		}
		k->camera_seq = seq;
		k->want = 0;
		if ((rc = collect(c, img, k, ei))) {
			return rc;
		}
		if (i + 1 >= moves && !(k->last_flags & BC_PROTO_FLAG_STILL)) {
			return 0;
		}
	}
	return bc_errinfo_set(ei, BC_ETIMEOUT,
	                      "the first frame of each of 40 camera moves "
	                      "was the still");
}

static void collect_free(struct collect *k)
{
	bc_free(k->moving);
	bc_free(k->delta_bytes);
	memset(k, 0, sizeof(*k));
}

/* The raw snapshot of the current camera, compared with img. */
static double snapshot_psnr(struct bc_client *c,
                            const struct bc_client_image *img,
                            const uint8_t *px)
{
	struct bc_client_image shot;
	struct bc_errinfo ei = {0};
	double db = 0.0;
	bc_client_image_init(&shot);
	if (bc_client_snapshot(c, BC_PROTO_ENC_RAW, &shot, &ei)) {
		fprintf(stderr, "  snapshot: %s\n", ei.msg);
	} else if (shot.width == img->width && shot.height == img->height) {
		db = rgba_psnr(shot.rgba, px, shot.width, shot.height);
	}
	bc_client_image_finish(&shot);
	return db;
}

/* One view of w x h against the daemon: the still, a moving frame, a
 * delta frame in a fresh image, KEY after VIEW again, a PNG still. */
static void view_against_daemon(const struct daemon *d, uint16_t w, uint16_t h,
                                bool acks)
{
	struct bc_client *c = NULL;
	struct bc_client_image img, fresh;
	struct bc_errinfo ei = {0};
	struct collect k = {.want = BC_PROTO_FLAG_STILL};
	struct bc_msg_view view = {.width = w,
	                           .height = h,
	                           .encoding = BC_PROTO_ENC_H264,
	                           .downscale = 1};
	struct bc_camera cam;
	double db;
	int rc;
	bc_client_image_init(&img);
	bc_client_image_init(&fresh);
	REQUIRE(connect_video(d, acks, &c, &ei) == 0);
	if (acks) {
		CHECK(bc_client_info(c)->features & BC_PROTO_FEATURE_ACKS);
	} else {
		CHECK_EQ_INT(bc_client_frame_ack(c, 1, &ei), BC_ENOTSUP);
	}
	REQUIRE(bc_client_join(c, "default", BC_PROTO_ROLE_VIEWER,
	                       BC_CLIENT_JOIN_EXISTING, &ei) == 0);
	REQUIRE(bc_client_scene(c, &cam) != NULL);
	cam.eye[0] += 0.3f;
	REQUIRE(bc_client_camera(c, &cam, false, NULL, &ei) == 0);
	REQUIRE(bc_client_view(c, &view, NULL, &ei) == 0);
	k.ack = acks;
	REQUIRE(said(collect(c, &img, &k, &ei), w, h, "", &ei) == 0);
	/* The first frame after VIEW is KEY, and so is the still. */
	CHECK(k.first_flags & BC_PROTO_FLAG_KEY);
	CHECK(img.flags & BC_PROTO_FLAG_KEY);
	CHECK(img.width == w && img.height == h && img.complete);
	db = snapshot_psnr(c, &img, img.rgba);
	printf("  %ux%u still: PSNR %.2f dB against a raw snapshot\n", w, h,
	       db);
	CHECK(db >= DAEMON_STILL_PSNR);
	collect_free(&k);

	/* A drag: a frame for each camera while interacting (the first
	 * after the still is KEY, those after it build on it), then the
	 * still. */
	k = (struct collect){.ack = acks};
	rc = drag_until_moving(c, &cam, 0.15f, 3, &img, &k, &ei);
	if (rc == 0) {
		k.want = BC_PROTO_FLAG_STILL;
		rc = collect(c, &img, &k, &ei);
	}
	REQUIRE(said(rc, w, h, " drag", &ei) == 0);
	REQUIRE(k.moving != NULL);
	db = snapshot_psnr(c, &img, k.moving);
	printf("  %ux%u moving frame %u: PSNR %.2f dB against a raw "
	       "snapshot\n",
	       w, h, k.moving_no, db);
	CHECK(db >= MOVING_PSNR);
	/* A delta frame of the stream, fed to an image with no chain. */
	REQUIRE(k.delta_bytes != NULL);
	CHECK_EQ_INT(bc_client_image_apply(&fresh, &k.delta, &ei), BC_ESTATE);
	CHECK(fresh.rgba == NULL);
	collect_free(&k);

	/* VIEW again: the stream starts over at a KEY frame. */
	REQUIRE(bc_client_view(c, &view, NULL, &ei) == 0);
	k = (struct collect){.want = 0, .ack = acks};
	REQUIRE(collect(c, &fresh, &k, &ei) == 0);
	CHECK(k.first_flags & BC_PROTO_FLAG_KEY);
	CHECK(fresh.complete);
	collect_free(&k);

	/* The still in PNG (still_encoding): exact; the H.264 frames of the
	 * next move decode around it. */
	view.still_encoding = BC_PROTO_ENC_PNG;
	REQUIRE(bc_client_view(c, &view, NULL, &ei) == 0);
	k = (struct collect){.want = BC_PROTO_FLAG_STILL,
	                     .ack = acks,
	                     .still_encoding = BC_PROTO_ENC_PNG};
	REQUIRE(collect(c, &img, &k, &ei) == 0);
	CHECK_EQ_INT(img.encoding, BC_PROTO_ENC_PNG);
	db = snapshot_psnr(c, &img, img.rgba);
	printf("  %ux%u PNG still: PSNR %.2f dB against a raw snapshot\n", w, h,
	       db);
	CHECK(db == 99.0);
	REQUIRE(said(drag_until_moving(c, &cam, -0.2f, 1, &img, &k, &ei), w, h,
	             " move after the PNG still", &ei) == 0);
	CHECK_EQ_INT(img.encoding, BC_PROTO_ENC_H264);
	CHECK(img.complete);
	collect_free(&k);
	bc_client_image_finish(&img);
	bc_client_image_finish(&fresh);
	bc_client_destroy(c);
}

static void daemon_stream_decodes(void)
{
	struct daemon d = {0};
	char dir[160];
	snprintf(dir, sizeof(dir), "%s/stream", base_dir);
	REQUIRE(daemon_start_with(
	            &d, dir, (const char *const[]){"--backend", "cpu", NULL}) ==
	        0);
	view_against_daemon(&d, 321, 241, false);
	view_against_daemon(&d, 320, 240, true);
	CHECK(WIFEXITED(daemon_stop(&d, SIGTERM)));
}

static const struct bc_test tests[] = {
    {"chain_decodes_from_key_at_odd_and_even_sizes",
     chain_decodes_from_key_at_odd_and_even_sizes},
    {"delta_without_key_is_refused_and_changes_nothing",
     delta_without_key_is_refused_and_changes_nothing},
    {"frame_shapes_that_are_not_a_view_are_refused",
     frame_shapes_that_are_not_a_view_are_refused},
    {"a_raw_still_leaves_the_chain_going", a_raw_still_leaves_the_chain_going},
    {"a_missing_module_is_named", a_missing_module_is_named},
    {"daemon_stream_decodes", daemon_stream_decodes},
};

int main(int argc, char **argv)
{
	return daemon_tests_run("client-video", base_dir, sizeof(base_dir),
	                        tests, sizeof(tests) / sizeof(tests[0]), argc,
	                        argv);
}
