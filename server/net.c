/*
 * Connections (loop thread): reading (TLS or plain) into the protocol's
 * push reader, whole messages handed to dispatch, timeouts, and output
 * queues (listen.c accepts connections, admit.c decides who gets a slot).
 * Messages are written in the order they come, each a piece of at most
 * BC_SRV_WRITE_PIECE bytes per loop turn (sealed piece by piece on TLS), so
 * no message, however big, holds the loop while the kernel copies it;
 * FRAMEs are written one at a time per client and a newer frame replaces
 * one not yet started (frame spoiling), so a slow client gets fewer frames,
 * never a growing backlog. A client whose queue still passes
 * BC_SRV_MAX_CLIENT_QUEUE (--client-queue) is dropped alone.
 *
 * A message that must wait for its session (dispatch answers PARK) stays
 * where the reader decoded it: the connection reads nothing more and the
 * reader is not touched until the sessions layer resumes it through the
 * link; then, in a later turn of the loop, the message is dispatched
 * again and reading goes on. A connection's messages so keep their order
 * without a copy, and a waiting client holds one message, not a queue.
 *
 * This file also implements the link (link.h): the callbacks the layers
 * below send through. Clients are freed from their close callback, never
 * inside a callback that still uses them.
 */
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <linux/sockios.h>
#include <linux/tcp.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/log.h"
#include "blobcast/proto.h"
#include "net_impl.h"
#include "tls.h"

/* Reads land in a buffer of this size before being fed to the reader. */
#define READ_CHUNK (64u * 1024u)

/* A FRAME's header and frame_no, order and camera_seq (PROTOCOL.md 7.15):
 * the part written per client. */
#define FRAME_PREFIX (BC_PROTO_HEADER_SIZE + 16u)
#define FRAME_CAMERA_SEQ (BC_PROTO_HEADER_SIZE + 12u)
/* The header's flags (PROTOCOL.md 3). */
#define HEADER_FLAGS 6u

/* A message in a connection's output queue (or, with no buffers, a turn
 * to write what the TLS state holds), written a piece at a time. */
struct write_req {
	uv_write_t req;
	struct bc_conn *c; /* valid until its stream's close callback */
	struct write_req *next;
	struct bc_shared *shared; /* a frame or a whole message, or NULL */
	bool frame;               /* shared is a frame */
	uint8_t *owned;           /* a message's bytes, or NULL */
	uint8_t *cipher;          /* the piece in flight on a TLS connection */
	bool close_notify;        /* TLS: say close_notify at its turn */
	bool answer;              /* the frame is a SNAPSHOT's answer */
	uv_buf_t buf[2];          /* the plaintext */
	unsigned int nbufs;
	size_t len;         /* plaintext bytes, counted in the queue */
	size_t done, piece; /* of them written, and in flight */
};

/* A SNAPSHOT's answer waiting for the frame slot. */
struct bc_answer {
	struct bc_shared *frame;
	uint32_t camera_seq;
	struct bc_answer *next;
};

static uint64_t now_ms(const struct bc_net *n)
{
	return uv_now(n->loop);
}

struct bc_conn *bc__conn_get(struct bc_net *n, struct bc_conn_ref ref)
{
	struct bc_conn *c;
	if (ref.slot >= BC_SRV_MAX_CONNECTIONS) {
		return NULL;
	}
	c = n->clients[ref.slot];
	return (c && c->gen == ref.gen && !c->closing) ? c : NULL;
}

static struct bc_conn_ref ref_of(const struct bc_conn *c)
{
	return (struct bc_conn_ref){c->slot, c->gen};
}

static void write_req_free(struct write_req *w);
static void drop_answers(struct bc_conn *c);
static void pump(struct bc_conn *c);
static void queue_tls_turn(struct bc_conn *c, bool close_notify);

void bc__net_handle_closed(uv_handle_t *h)
{
	struct bc_conn *c = h->data;
	bool trim;
	if (--c->handles_open > 0) {
		return;
	}
	trim = c->queued >= BC_SRV_TRIM_AFTER_BYTES;
	/* The piece in flight was cancelled before this last close callback;
	 * the messages behind it never started. */
	while (c->out_head) {
		struct write_req *w = c->out_head;
		c->out_head = w->next;
		write_req_free(w);
	}
	drop_answers(c);
	bc_proto_reader_finish(&c->reader);
	bc_shared_unref(c->frame_next);
	bc_tls_free(c->tls);
	bc_free(c);
	if (trim) {
		bc_heap_give_back();
	}
}

/* Takes c out of the resume queue. */
static void unqueue_resume(struct bc_conn *c)
{
	struct bc_net *n = c->net;
	struct bc_conn **p;
	if (!c->resume_queued) {
		return;
	}
	for (p = &n->resume_head; *p; p = &(*p)->resume_next) {
		if (*p == c) {
			*p = c->resume_next;
			break;
		}
	}
	n->resume_tail = NULL;
	for (struct bc_conn *q = n->resume_head; q; q = q->resume_next) {
		n->resume_tail = q;
	}
	c->resume_queued = false;
	c->resume_next = NULL;
}

/* The layers below forget c: its member leaves, its jobs go. */
static void forget(struct bc_conn *c)
{
	if (c->slot < BC_SRV_MAX_CONNECTIONS && c->net->clients[c->slot] == c &&
	    c->net->d) {
		bc_dispatch_closed(c->net->d, ref_of(c));
	}
	unqueue_resume(c);
}

/* Takes c off the list of connections to close. */
static void undoom(struct bc_conn *c)
{
	for (struct bc_conn **p = &c->net->doomed; *p; p = &(*p)->doomed_next) {
		if (*p == c) {
			*p = c->doomed_next;
			break;
		}
	}
	c->doomed_next = NULL;
}

void bc__conn_close(struct bc_conn *c, const char *why)
{
	struct bc_net *n = c->net;
	if (c->closing) {
		return;
	}
	bc_log(BC_LOG_INFO, "connection %u (%s) closed: %s", c->gen, c->name,
	       why);
	if (c->doomed) {
		undoom(c);
		forget(c);
	} else if (!c->draining) {
		forget(c);
	}
	c->closing = true;
	if (n->clients[c->slot] == c) {
		n->clients[c->slot] = NULL;
		n->nclients--;
	}
	c->handles_open = 2;
	uv_close(&c->h.handle, bc__net_handle_closed);
	uv_close((uv_handle_t *)&c->hello_timer, bc__net_handle_closed);
}

static void close_doomed(uv_idle_t *idle)
{
	struct bc_net *n = idle->data;
	uv_idle_stop(idle);
	while (n->doomed) {
		struct bc_conn *c = n->doomed;
		n->doomed = c->doomed_next;
		c->doomed_next = NULL;
		bc__conn_close(c, c->drain_why);
	}
}

/* Closes c at the loop's next turn. A send that finds its client gone
 * (its queue over the cap, out of memory) runs inside the sessions
 * layer's work -- a join sending its scene goes on to the member's other
 * answers -- and closing now would take the member out of its session
 * under that work. Meanwhile c is draining: it takes no more output and
 * reads nothing. */
static void close_soon(struct bc_conn *c, const char *why)
{
	struct bc_net *n = c->net;
	if (c->closing || c->doomed) {
		return;
	}
	c->doomed = true;
	c->draining = true;
	c->drain_why = why;
	uv_read_stop(&c->h.stream);
	c->doomed_next = n->doomed;
	n->doomed = c;
	uv_idle_start(&n->doomer, close_doomed);
}

static void shutdown_done(uv_shutdown_t *req, int status)
{
	struct bc_conn *c = req->data;
	(void)status;
	bc__conn_close(c, c->drain_why);
}

void bc__conn_close_after_flush(struct bc_conn *c, const char *why)
{
	if (c->closing || c->draining) {
		return;
	}
	forget(c);
	c->draining = true;
	c->drain_why = why;
	uv_read_stop(&c->h.stream);
	if (c->tls) {
		/* close_notify goes out after the queued messages, at its
		 * turn: nothing can be sealed after it. */
		queue_tls_turn(c, true);
		if (c->closing) {
			return;
		}
	}
	c->shutdown_due = true;
	pump(c);
}

static void send_frame(struct bc_conn *c, struct bc_shared *frame,
                       uint32_t camera_seq);

static void write_req_free(struct write_req *w)
{
	bc_shared_unref(w->shared);
	bc_free(w->owned);
	bc_free(w->cipher);
	bc_free(w);
}

/* After a frame: the next answer, the newest frame rendered meanwhile, or
 * the layer told that c may be sent another. */
static void next_frame(struct bc_conn *c)
{
	c->frame_writing = false;
	if (c->answers_head) {
		struct bc_answer *a = c->answers_head;
		c->answers_head = a->next;
		c->answers_tail = a->next ? c->answers_tail : NULL;
		send_frame(c, a->frame, a->camera_seq);
		bc_shared_unref(a->frame);
		bc_free(a);
	} else if (c->frame_next) {
		struct bc_shared *next = c->frame_next;
		c->frame_next = NULL;
		send_frame(c, next, c->frame_next_camera_seq);
		bc_shared_unref(next);
	} else if (!c->draining) {
		bc_dispatch_writable(c->net->d, ref_of(c));
	}
}

/* ---- pacing: frames wait for the link, not in its buffers ----------------- */

/* Bytes the kernel still holds for TCP connection c: written but not yet
 * acknowledged by the peer, or not yet sent (SIOCOUTQ); 0 when unknown. */
static size_t kernel_backlog(struct bc_conn *c)
{
	uv_os_fd_t fd;
	int n = 0;
	if (uv_fileno(&c->h.handle, &fd) != 0 || ioctl(fd, SIOCOUTQ, &n) < 0 ||
	    n < 0) {
		return 0;
	}
	return (size_t)n;
}

/* Whether c's link still holds more than one frame of len bytes (at least
 * BC_SRV_PACE_MIN_BYTES). libuv finishes a write once the kernel took the
 * bytes, and the kernel's send buffer grows to megabytes: on a link slower
 * than the renderer, frames would queue there, each older than the next,
 * and a camera move would wait seconds behind them. Held back here
 * instead, the newest frame rendered meanwhile replaces the one waiting
 * (send_frame's frame_next), so at most two frames are in flight. */
static bool backlog_full(struct bc_conn *c, size_t len)
{
	size_t allow =
	    len > BC_SRV_PACE_MIN_BYTES ? len : BC_SRV_PACE_MIN_BYTES;
	return c->is_tcp && !c->net->cfg->no_pace && kernel_backlog(c) > allow;
}

/* Whether c's next frame waits: its link holds a frame (backlog_full),
 * or, for a client granted ACKS, BC_PROTO_ACK_WINDOW frames wait for its
 * acknowledgement (acks.c). */
static bool link_full(struct bc_conn *c, size_t len)
{
	return (!c->net->cfg->no_pace && bc__acks_full(&c->acks)) ||
	       backlog_full(c, len);
}

static void pace_tick(uv_timer_t *t)
{
	struct bc_conn *c = t->data;
	size_t backlog = c->is_tcp ? kernel_backlog(c) : 0;
	/* Bytes leaving the kernel are progress: the stall clock restarts
	 * (a frame of megabytes drains slowly through a slow link). */
	if (backlog < c->paced_backlog) {
		c->frame_started_ms = now_ms(c->net);
	}
	c->paced_backlog = backlog;
	if (c->closing || link_full(c, c->paced_len)) {
		return;
	}
	uv_timer_stop(&c->hello_timer);
	c->pacing = false;
	next_frame(c);
}

/* Holds c's next frame while its link is full (the timer, idle once HELLO
 * is done, looks again every BC_SRV_PACE_TICK_MS). Returns true when it
 * holds: c stays frame_writing, so newer frames replace frame_next. */
static bool pace(struct bc_conn *c, size_t len)
{
	if (c->draining || !link_full(c, len)) {
		return false;
	}
	c->pacing = true;
	c->paced_len = len;
	c->paced_backlog = SIZE_MAX;
	/* Counted as the link's doing (the sessions layer then codes
	 * coarser, smaller frames) when bytes queue: in the socket, or,
	 * behind a proxy, as acknowledgements that come late. A window
	 * full on a fast, far path is the round trip's doing. */
	if (backlog_full(c, len) || bc__acks_congested(&c->acks)) {
		c->counters.frames_paced++;
	}
	uv_timer_start(&c->hello_timer, pace_tick, BC_SRV_PACE_TICK_MS,
	               BC_SRV_PACE_TICK_MS);
	return true;
}

/* The bookkeeping of a message that left (status 0) or never will: the
 * queue's count, the next frame, the layer told it may send again. */
static void finish(struct bc_conn *c, struct write_req *w, int status)
{
	c->out_head = w->next;
	if (!c->out_head) {
		c->out_tail = NULL;
	}
	if (!c->closing) {
		c->queued -= w->len;
		c->frame_bytes -= w->frame ? w->len : 0;
		c->shared_bytes -= w->shared && !w->frame ? w->len : 0;
		if (status < 0) {
			bc__conn_close(c, uv_strerror(status));
		} else if (w->frame) {
			c->counters.frames_sent++;
			c->counters.bytes_sent += w->len;
			if (w->answer) {
				bc_dispatch_answered(c->net->d, ref_of(c));
			} else if (c->acks.on) {
				bc__acks_written(
				    &c->acks,
				    bc_get_le32(w->owned +
				                BC_PROTO_HEADER_SIZE),
				    w->len, uv_hrtime() / 1000u);
			}
			if (!pace(c, w->len)) {
				next_frame(c);
			}
		} else {
			c->counters.bytes_sent += w->len;
		}
	}
	write_req_free(w);
}

/* The next piece of w's plaintext, at most BC_SRV_WRITE_PIECE bytes, in
 * part; on a TLS connection sealed into w->cipher (with whatever records
 * the TLS state held before them), which part then holds. Returns the
 * count of buffers (0: nothing to write), or -1 when TLS fails. */
static int next_piece(struct bc_conn *c, struct write_req *w, uv_buf_t *part)
{
	size_t skip = w->done, room = BC_SRV_WRITE_PIECE, n;
	int nparts = 0;
	for (unsigned int i = 0; i < w->nbufs && room > 0; i++) {
		size_t len = w->buf[i].len, take;
		if (skip >= len) {
			skip -= len;
			continue;
		}
		take = len - skip < room ? len - skip : room;
		part[nparts++] =
		    uv_buf_init(w->buf[i].base + skip, (unsigned int)take);
		skip = 0;
		room -= take;
	}
	w->piece = BC_SRV_WRITE_PIECE - room;
	if (!c->tls) {
		return nparts;
	}
	if (w->close_notify) {
		bc_tls_close_notify(c->tls);
	}
	for (int i = 0; i < nparts; i++) {
		if (bc_tls_write(c->tls, part[i].base, part[i].len)) {
			return -1;
		}
	}
	bc_free(w->cipher);
	if (bc_tls_take_output(c->tls, &w->cipher, &n)) {
		return -1;
	}
	part[0] = uv_buf_init((char *)w->cipher, (unsigned int)n);
	return n > 0 ? 1 : 0;
}

static void write_done(uv_write_t *req, int status);

/* Writes the next piece of the message at the head of c's output queue,
 * or finishes those with nothing left; once the queue is empty, a
 * draining connection is shut down. One piece per connection is with the
 * kernel at a time, and the next goes from write_done, in a later turn
 * of the loop: a big message (a snapshot with its planes) is copied and
 * sealed a piece per turn, never all in one, and no message is cut by
 * another. */
static void pump(struct bc_conn *c)
{
	struct write_req *w;
	uv_buf_t part[2];
	int n;
	while (!c->closing && !c->writing && (w = c->out_head)) {
		if ((n = next_piece(c, w, part)) < 0) {
			bc__conn_close(c, "TLS failure");
			return;
		}
		if (n == 0) {
			finish(c, w, 0);
			continue;
		}
		if ((n = uv_write(&w->req, &c->h.stream, part, (unsigned int)n,
		                  write_done)) < 0) {
			bc__conn_close(c, uv_strerror(n));
			return;
		}
		c->writing = true;
	}
	if (!c->closing && !c->writing && c->draining && c->shutdown_due) {
		c->shutdown_due = false;
		c->shutdown.data = c;
		if (uv_shutdown(&c->shutdown, &c->h.stream, shutdown_done)) {
			bc__conn_close(c, c->drain_why);
		}
	}
}

/* A piece went out (or was cancelled: c is closing, its stream's close
 * callback, which frees c, comes after this one). */
static void write_done(uv_write_t *req, int status)
{
	struct write_req *w = (struct write_req *)req;
	struct bc_conn *c = w->c;
	c->writing = false;
	bc_free(w->cipher);
	w->cipher = NULL;
	if (status == 0 && !c->closing) {
		/* The stall clock runs from the last piece the kernel took:
		 * a snapshot of megabytes on a slow link moves, a client
		 * that stopped reading does not. */
		if (c->frame_writing) {
			c->frame_started_ms = now_ms(c->net);
		}
		w->done += w->piece;
		if (w->done < w->len) {
			pump(c);
			return;
		}
	}
	finish(c, w, status);
	pump(c);
}

/* Appends w to c's output queue and starts writing when it is idle. */
static void enqueue(struct bc_conn *c, struct write_req *w)
{
	w->c = c;
	if (c->out_tail) {
		c->out_tail->next = w;
	} else {
		c->out_head = w;
	}
	c->out_tail = w;
	pump(c);
}

/* Queues a write of the records c's TLS state holds when its turn comes
 * (handshake records, alerts, close_notify): taken then, they keep their
 * order with the records sealed for the messages queued before. Those
 * bytes count for no message. */
static void queue_tls_turn(struct bc_conn *c, bool close_notify)
{
	struct write_req *w;
	if (c->closing) {
		return;
	}
	if (!(w = bc_calloc(1, sizeof(*w)))) {
		bc__conn_close(c, "out of memory");
		return;
	}
	w->close_notify = close_notify;
	enqueue(c, w);
}

void bc__net_tls_flush(struct bc_conn *c)
{
	queue_tls_turn(c, false);
}

/* The buffers of a FRAME shared by a view group: frame_no counts this
 * client's frames and camera_seq is this client's last CAMERA (PROTOCOL.md
 * 7.15, 5), so the header up to camera_seq goes out from a private copy,
 * the rest shared. Returns false when out of memory. */
static bool frame_bufs(struct bc_conn *c, struct write_req *w,
                       struct bc_shared *shared, uint32_t camera_seq)
{
	if (!(w->owned = bc_malloc(FRAME_PREFIX))) {
		return false;
	}
	memcpy(w->owned, shared->data, FRAME_PREFIX);
	bc_put_le32(w->owned + BC_PROTO_HEADER_SIZE, ++c->frame_no);
	bc_put_le32(w->owned + FRAME_CAMERA_SEQ, camera_seq);
	w->buf[0] = uv_buf_init((char *)w->owned, FRAME_PREFIX);
	w->buf[1] = uv_buf_init((char *)shared->data + FRAME_PREFIX,
	                        (unsigned int)(shared->len - FRAME_PREFIX));
	w->nbufs = 2;
	shared->refs++;
	w->shared = shared;
	w->frame = true;
	return true;
}

/* Whether c's queue takes len more bytes: its cap is 32 MiB
 * (--client-queue), or frame (the large frame and shared message it may
 * hold) and a little beside it. A client past it stopped reading: it is closed
 * (at the loop's next turn: close_soon). */
static bool room_for(struct bc_conn *c, size_t frame, size_t len)
{
	size_t most = c->net->cfg->client_queue_mib
	                  ? (size_t)c->net->cfg->client_queue_mib << 20
	                  : BC_SRV_MAX_CLIENT_QUEUE;
	size_t cap = frame + BC_SRV_QUEUE_BESIDE_FRAME > most
	                 ? frame + BC_SRV_QUEUE_BESIDE_FRAME
	                 : most;
	if (c->queued + len <= cap) {
		return true;
	}
	bc_log(BC_LOG_WARN,
	       "dropping client %u (%s): %zu bytes queued and %zu more to "
	       "send, over %zu: it stopped reading",
	       c->gen, c->name, c->queued, len, cap);
	close_soon(c, "output queue over its limit");
	return false;
}

/* What room_for lets beside the frame: the shared whole message queued
 * (one: a second, before the first has gone, passes the cap), or the
 * one of len bytes now queued when there is none. The messages after it
 * (a join's answers behind its scene) are then the few bytes beside. */
static size_t shared_room(const struct bc_conn *c, size_t len)
{
	return c->shared_bytes ? c->shared_bytes : len;
}

/* What queue_bytes queues. */
enum out_kind {
	OUT_MESSAGE, /* bytes, or a shared whole message */
	OUT_FRAME,   /* a shared FRAME in the frame slot */
	OUT_ANSWER,  /* a shared FRAME answering a SNAPSHOT, in the slot */
};

/* Queues bytes (taking owned), or a reference to a shared frame (with
 * this client's camera_seq) or whole message. */
static void queue_bytes(struct bc_conn *c, uint8_t *owned,
                        struct bc_shared *shared, size_t len,
                        enum out_kind kind, uint32_t camera_seq)
{
	bool is_frame = kind != OUT_MESSAGE;
	struct write_req *w;
	size_t frame;
	if (c->tls && !bc_tls_ready(c->tls)) {
		/* Nothing can be said before the handshake (an ERROR for a
		 * HELLO timeout): the connection is closed without it. */
		bc_free(owned);
		return;
	}
	/* The queue's cap holds a frame of any size the protocol allows (a
	 * snapshot with its planes may pass the cap alone) with a little
	 * room beside it; frames go one at a time, a newer one spoiling the
	 * one waiting, so only a client that stopped reading fills it. A
	 * whole message shared by many clients (a large scene's SCENE_STATE,
	 * one buffer for all) may come beside them, once: a second one
	 * before the first has gone passes the cap. */
	frame = (is_frame ? len : c->frame_bytes) +
	        shared_room(c, shared && !is_frame ? len : 0u);
	if (!room_for(c, frame, len)) {
		bc_free(owned);
		return;
	}
	if (!(w = bc_calloc(1, sizeof(*w)))) {
		bc_free(owned);
		close_soon(c, "out of memory");
		return;
	}
	w->owned = owned;
	w->len = len;
	w->buf[0] = uv_buf_init((char *)owned, (unsigned int)len);
	w->nbufs = 1;
	if (shared && !is_frame) {
		w->buf[0] =
		    uv_buf_init((char *)shared->data, (unsigned int)len);
		shared->refs++;
		w->shared = shared;
	}
	if (is_frame && !frame_bufs(c, w, shared, camera_seq)) {
		write_req_free(w);
		close_soon(c, "out of memory");
		return;
	}
	w->answer = kind == OUT_ANSWER;
	c->queued += len;
	c->frame_bytes += is_frame ? len : 0;
	c->shared_bytes += shared && !is_frame ? len : 0;
	enqueue(c, w);
}

static void send_msg(struct bc_conn *c, const struct bc_msg *m)
{
	struct bc_proto_buf b;
	struct bc_errinfo ei = {0};
	if (c->closing || c->draining) {
		return;
	}
	bc_proto_buf_init(&b, 0);
	if (bc_proto_encode(&b, m, &ei)) {
		bc_log(BC_LOG_ERROR, "cannot encode %s for client %u: %s",
		       bc_proto_type_name(m->type), c->gen, ei.msg);
		bc_proto_buf_finish(&b);
		return;
	}
	queue_bytes(c, b.data, NULL, b.len, OUT_MESSAGE, 0);
}

/* A FRAME for c, in its frame slot: one at a time; a newer frame spoils
 * the one waiting, but a SNAPSHOT's answer (header flag SNAPSHOT) is
 * neither spoiled nor spoils: answers wait in order and go first. */
static void send_frame(struct bc_conn *c, struct bc_shared *frame,
                       uint32_t camera_seq)
{
	uint64_t now = now_ms(c->net);
	bool answer = (bc_get_le16(frame->data + HEADER_FLAGS) &
	               BC_PROTO_FLAG_SNAPSHOT) != 0;
	if (c->closing || c->draining) {
		return;
	}
	if (c->frame_writing && now - c->frame_started_ms > BC_SRV_STALL_MS) {
		bc_log(BC_LOG_WARN,
		       "dropping client %u (%s): a frame has waited %u ms, it "
		       "stopped reading",
		       c->gen, c->name, BC_SRV_STALL_MS);
		close_soon(c, "stopped reading");
		return;
	}
	if (c->frame_writing && answer) {
		/* A SNAPSHOT's answer waits its turn, never spoiled. */
		struct bc_answer *a = bc_calloc(1, sizeof(*a));
		if (!a) {
			close_soon(c, "out of memory");
			return;
		}
		frame->refs++;
		a->frame = frame;
		a->camera_seq = camera_seq;
		if (c->answers_tail) {
			c->answers_tail->next = a;
		} else {
			c->answers_head = a;
		}
		c->answers_tail = a;
		return;
	}
	if (c->frame_writing) {
		/* Spoil the unsent frame: the newer one supersedes it. */
		if (c->frame_next) {
			c->frames_spoiled++;
			bc_shared_unref(c->frame_next);
		}
		frame->refs++;
		c->frame_next = frame;
		c->frame_next_camera_seq = camera_seq;
		return;
	}
	c->frame_writing = true;
	c->frame_started_ms = now;
	if (!c->counters.first_frame_ms) {
		c->counters.first_frame_ms = now;
	}
	queue_bytes(c, NULL, frame, frame->len, answer ? OUT_ANSWER : OUT_FRAME,
	            camera_seq);
}

/* ---- the link ------------------------------------------------------------- */

static void link_send(void *ud, struct bc_conn_ref to, const struct bc_msg *m)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c) {
		send_msg(c, m);
	}
}

static void link_send_frame(void *ud, struct bc_conn_ref to,
                            struct bc_shared *frame, uint32_t camera_seq)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c) {
		send_frame(c, frame, camera_seq);
	}
}

/* Frees c's waiting answers. */
static void drop_answers(struct bc_conn *c)
{
	while (c->answers_head) {
		struct bc_answer *a = c->answers_head;
		c->answers_head = a->next;
		bc_shared_unref(a->frame);
		bc_free(a);
	}
	c->answers_tail = NULL;
}

static void link_info(void *ud, struct bc_conn_ref to,
                      struct bc_proto_link *out)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	struct tcp_info ti;
	socklen_t len = sizeof(ti);
	uv_os_fd_t fd;
	memset(out, 0, sizeof(*out));
	if (!c) {
		return;
	}
	out->frames_paced = (uint32_t)c->counters.frames_paced;
	out->frames_spoiled = c->frames_spoiled;
	if (!c->is_tcp || uv_fileno(&c->h.handle, &fd) != 0) {
		bc__acks_info(&c->acks, out);
		return;
	}
	out->unacked_bytes = (uint32_t)kernel_backlog(c);
	memset(&ti, 0, sizeof(ti));
	if (getsockopt(fd, IPPROTO_TCP, TCP_INFO, &ti, &len) == 0) {
		out->rtt_us = ti.tcpi_rtt;
		/* Fields of later kernels are there when len reached them. */
		if (len >= offsetof(struct tcp_info, tcpi_min_rtt) +
		               sizeof(ti.tcpi_min_rtt)) {
			out->min_rtt_us = ti.tcpi_min_rtt;
		}
		if (len >= offsetof(struct tcp_info, tcpi_delivery_rate) +
		               sizeof(ti.tcpi_delivery_rate)) {
			out->delivery_bps = ti.tcpi_delivery_rate;
		}
	}
	bc__acks_info(&c->acks, out);
}

static void link_acks_on(void *ud, struct bc_conn_ref to)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c) {
		c->acks.on = true;
	}
}

static int link_frame_ack(void *ud, struct bc_conn_ref from, uint32_t no,
                          struct bc_errinfo *ei)
{
	struct bc_conn *c = bc__conn_get(ud, from);
	int rc;
	if (!c || c->closing) {
		return 0;
	}
	if ((rc = bc__acks_take(&c->acks, no, c->frame_no, uv_hrtime() / 1000u,
	                        ei))) {
		return rc;
	}
	/* The frame held for the window goes now, or the layer hears it
	 * may render the next. */
	if (c->pacing && !link_full(c, c->paced_len)) {
		uv_timer_stop(&c->hello_timer);
		c->pacing = false;
		next_frame(c);
	}
	return 0;
}

static void link_forget_frames(void *ud, struct bc_conn_ref to)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c) {
		bc_shared_unref(c->frame_next);
		c->frame_next = NULL;
		drop_answers(c);
	}
}

static void *link_detach(void *ud, struct bc_conn_ref from)
{
	struct bc_conn *c = bc__conn_get(ud, from);
	return c ? bc_proto_reader_detach(&c->reader) : NULL;
}

static void link_send_shared(void *ud, struct bc_conn_ref to,
                             struct bc_shared *msg)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c && !c->closing && !c->draining) {
		queue_bytes(c, NULL, msg, msg->len, OUT_MESSAGE, 0);
	}
}

/* msg (a SCENE_STATE's head and scene, members.c) in parts of at most
 * part_max payload bytes: each a head of its own and a slice of msg. The
 * queue's cap counts the parts as the one shared message they are. */
static void queue_parts(struct bc_conn *c, struct bc_shared *msg,
                        uint32_t part_max)
{
	const uint8_t *head = msg->data;
	const uint8_t *scene = msg->data + BC_PROTO_SCENE_PART_HEAD;
	size_t len = msg->len - BC_PROTO_SCENE_PART_HEAD, at = 0;
	size_t piece_max = part_max - BC_PROTO_SCENE_STATE_FIXED;
	size_t nparts = (len + piece_max - 1) / piece_max;
	size_t total = msg->len + (nparts - 1) * BC_PROTO_SCENE_PART_HEAD;
	uint64_t order = bc_get_le64(head + BC_PROTO_HEADER_SIZE);
	uint32_t author = bc_get_le32(head + BC_PROTO_HEADER_SIZE + 8);
	uint32_t author_seq = bc_get_le32(head + BC_PROTO_HEADER_SIZE + 12);
	if ((c->tls && !bc_tls_ready(c->tls)) ||
	    !room_for(c, c->frame_bytes + shared_room(c, total), total)) {
		return;
	}
	for (size_t i = 0; i < nparts; i++) {
		size_t piece = len - at < piece_max ? len - at : piece_max;
		uint16_t flags =
		    (uint16_t)((i > 0 ? BC_PROTO_FLAG_CONT : 0u) |
		               (i + 1 < nparts ? BC_PROTO_FLAG_MORE : 0u));
		struct write_req *w = bc_calloc(1, sizeof(*w));
		if (!w || !(w->owned = bc_malloc(BC_PROTO_SCENE_PART_HEAD))) {
			bc_free(w);
			close_soon(c, "out of memory");
			return;
		}
		bc_proto_scene_state_head(w->owned, flags, order, author,
		                          author_seq, (uint32_t)piece);
		w->buf[0] =
		    uv_buf_init((char *)w->owned, BC_PROTO_SCENE_PART_HEAD);
		w->buf[1] =
		    uv_buf_init((char *)scene + at, (unsigned int)piece);
		w->nbufs = 2;
		w->len = BC_PROTO_SCENE_PART_HEAD + piece;
		msg->refs++;
		w->shared = msg;
		c->queued += w->len;
		c->shared_bytes += w->len;
		at += piece;
		enqueue(c, w);
	}
}

static void link_send_parts(void *ud, struct bc_conn_ref to,
                            struct bc_shared *msg, uint32_t part_max)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c && !c->closing && !c->draining &&
	    part_max > BC_PROTO_SCENE_STATE_FIXED &&
	    msg->len > BC_PROTO_SCENE_PART_HEAD) {
		queue_parts(c, msg, part_max);
	}
}

static void link_close(void *ud, struct bc_conn_ref to, const char *why,
                       bool flush)
{
	struct bc_conn *c = bc__conn_get(ud, to);
	if (c && flush) {
		bc__conn_close_after_flush(c, why);
	} else if (c) {
		bc__conn_close(c, why);
	}
}

static void resume_due(uv_idle_t *idle);

static void link_resume(void *ud, struct bc_conn_ref to, bool again)
{
	struct bc_net *n = ud;
	struct bc_conn *c = bc__conn_get(n, to);
	if (!c || !c->parked || c->resume_queued) {
		return;
	}
	c->resume_again = again;
	c->resume_queued = true;
	c->resume_next = NULL;
	if (n->resume_tail) {
		n->resume_tail->resume_next = c;
	} else {
		n->resume_head = c;
		uv_idle_start(&n->resumer, resume_due);
	}
	n->resume_tail = c;
}

/* ---- reading --------------------------------------------------------------- */

static void on_alloc(uv_handle_t *h, size_t suggested, uv_buf_t *buf)
{
	static char chunk[READ_CHUNK];
	(void)h;
	(void)suggested;
	/* One loop thread: a static chunk is fed to the reader (which copies)
	 * before the next read can happen. */
	*buf = uv_buf_init(chunk, sizeof(chunk));
}

/* Hands m to dispatch. Returns false when c may read nothing more now. */
static bool deliver(struct bc_conn *c, const struct bc_msg *m)
{
	switch (bc_dispatch_message(c->net->d, ref_of(c), m)) {
	case BC_DISPATCH_PARK:
		c->parked = true;
		c->parked_msg = *m;
		uv_read_stop(&c->h.stream);
		return false;
	case BC_DISPATCH_HELLO:
		/* The name it gave, for the log. */
		snprintf(c->name, sizeof(c->name), "%.*s",
		         (int)m->hello.client_name.len,
		         m->hello.client_name.ptr);
		c->authed = true;
		uv_timer_stop(&c->hello_timer);
		bc_proto_reader_hello_done(&c->reader);
		return true;
	default:
		return !c->closing && !c->draining;
	}
}

/* c has had its share of this loop turn: it reads nothing more until its
 * turn comes again (the resume queue, next turn), so that a client
 * sending many costly requests at once (EDITs of 1024 SETs) delays
 * another's PING by one request, not by all of them. */
static void yield_turn(struct bc_conn *c)
{
	c->parked = true;
	uv_read_stop(&c->h.stream);
	link_resume(c->net, ref_of(c), false);
}

/* Dispatches the whole messages the reader holds, until one parks or the
 * connection has used its share of the turn. */
static void drain_reader(struct bc_conn *c)
{
	struct bc_msg m;
	uint64_t t0 = uv_hrtime();
	int rc = 0;
	while (!c->closing && !c->draining && !c->parked) {
		rc = bc_proto_reader_next(&c->reader, &m);
		if (rc != 1) {
			break;
		}
		c->msg_started_ms = 0;
		rc = 0;
		if (!deliver(c, &m)) {
			break;
		}
		if (uv_hrtime() - t0 > BC_SRV_READ_SHARE_MS * 1000000u &&
		    bc_proto_reader_pending(&c->reader) > 0) {
			yield_turn(c);
			break;
		}
	}
	/* Bytes left over start a message that must complete within the
	 * message timeout (check_timeouts), counted from its first byte. */
	if (bc_proto_reader_pending(&c->reader) == 0) {
		c->msg_started_ms = 0;
	} else if (c->msg_started_ms == 0) {
		c->msg_started_ms = c->last_read_ms;
	}
	if (rc < 0 && !c->closing && !c->draining) {
		/* The stream cannot be resynchronized: say why, then close. */
		bc_link_error(&c->net->link, ref_of(c), 0, rc, true, "%s",
		              c->reader.errstr);
		bc__conn_close_after_flush(c, "protocol error");
	}
}

/* Plaintext bytes from the peer: fed to the protocol reader, and every
 * whole message dispatched. */
static void on_bytes(struct bc_conn *c, const char *bytes, size_t n)
{
	int rc;
	c->last_read_ms = now_ms(c->net);
	if ((rc = bc_proto_reader_feed(&c->reader, bytes, n)) < 0) {
		bc_link_error(&c->net->link, ref_of(c), 0, rc, true, "%s",
		              c->reader.errstr);
		bc__conn_close_after_flush(c, "protocol error");
		return;
	}
	drain_reader(c);
}

/* Decrypted bytes of a TLS connection, fed while it reads (a parked one
 * leaves the rest in its TLS state until resumed). Returns what the last
 * read said: > 0 bytes, 0 more needed, or an error with why. */
static long tls_pump(struct bc_conn *c, char *why, size_t whylen)
{
	static char plain[READ_CHUNK];
	long got = 0;
	while (!c->closing && !c->draining && !c->parked) {
		bool was_ready = bc_tls_ready(c->tls);
		got = bc_tls_read(c->tls, plain, sizeof(plain), why, whylen);
		if (!was_ready && bc_tls_ready(c->tls)) {
			char desc[128];
			bc_log(BC_LOG_INFO, "connection %u: TLS (%s)", c->gen,
			       bc_tls_describe(c->tls, desc, sizeof(desc)));
		}
		if (got <= 0) {
			break;
		}
		on_bytes(c, plain, (size_t)got);
	}
	return got;
}

/* Ciphertext from the peer of a TLS connection: the handshake advanced,
 * records decrypted and their bytes handled, whatever TLS has to say
 * written. A peer that speaks the plain protocol to this port hears why
 * it is refused, in the plain protocol. */
static void on_tls_bytes(struct bc_conn *c, const char *bytes, size_t n)
{
	char why[256] = "";
	long got;
	if (!bc_tls_started(c->tls) &&
	    (uint8_t)bytes[0] != 0x16 /* TLS handshake record */) {
		bc_tls_free(c->tls);
		c->tls = NULL;
		bc_log(BC_LOG_INFO,
		       "connection %u: plain protocol on the TLS port, refused",
		       c->gen);
		bc_link_error(&c->net->link, ref_of(c), 0, BC_ENOTSUP, true,
		              "this port speaks TLS: connect with "
		              "tls://HOST:PORT");
		bc__conn_close_after_flush(c, "not TLS");
		return;
	}
	if (bc_tls_feed(c->tls, bytes, n)) {
		bc__conn_close(c, "out of memory");
		return;
	}
	got = tls_pump(c, why, sizeof(why));
	if (c->closing) {
		return;
	}
	bc__net_tls_flush(c);
	if (got < 0 && !c->closing && !c->draining) {
		if (got == BC_ECLOSED) {
			bc__conn_close(c, "peer closed");
		} else {
			bc_log(BC_LOG_INFO, "connection %u: TLS: %s", c->gen,
			       why);
			bc__conn_close(c, bc_tls_ready(c->tls)
			                      ? "TLS error"
			                      : "TLS handshake failed");
		}
	}
}

static void on_read(uv_stream_t *s, ssize_t n, const uv_buf_t *buf)
{
	struct bc_conn *c = s->data;
	if (c->closing || c->draining) {
		return;
	}
	if (n < 0) {
		int eof = bc_proto_reader_eof(&c->reader);
		if (eof < 0 && n == UV_EOF) {
			/* The stream ended inside a message (PROTOCOL.md 3.1):
			 * a peer that only shut down its sending side still
			 * hears why. */
			bc_link_error(&c->net->link, ref_of(c), 0, eof, true,
			              "%s", c->reader.errstr);
			bc__conn_close_after_flush(c, "stream ended inside a "
			                              "message");
			return;
		}
		if (eof < 0) {
			bc_log(BC_LOG_INFO, "client %u: %s", c->gen,
			       c->reader.errstr);
		}
		bc__conn_close(c, n == UV_EOF ? "peer closed"
		                              : uv_strerror((int)n));
		return;
	}
	if (n == 0) {
		return;
	}
	if (c->tls) {
		on_tls_bytes(c, buf->base, (size_t)n);
	} else {
		on_bytes(c, buf->base, (size_t)n);
	}
}

/* A parked connection goes on: its message again (or dropped, answered
 * meanwhile), the rest of what the reader and TLS hold, then reading. */
static void resume_one(struct bc_conn *c)
{
	char why[256];
	c->parked = false;
	if (c->resume_again && !deliver(c, &c->parked_msg)) {
		return;
	}
	drain_reader(c);
	if (c->tls && !c->parked && !c->closing && !c->draining) {
		tls_pump(c, why, sizeof(why));
		bc__net_tls_flush(c);
	}
	if (!c->parked && !c->closing && !c->draining) {
		uv_read_start(&c->h.stream, on_alloc, on_read);
	}
}

static void resume_due(uv_idle_t *idle)
{
	struct bc_net *n = idle->data;
	struct bc_conn *c;
	uv_idle_stop(idle);
	/* Those queued meanwhile wait for the next turn. */
	while ((c = n->resume_head)) {
		n->resume_head = c->resume_next;
		if (!n->resume_head) {
			n->resume_tail = NULL;
		}
		c->resume_queued = false;
		c->resume_next = NULL;
		resume_one(c);
	}
}

/* ---- timeouts ---------------------------------------------------------------- */

static void hello_timeout(uv_timer_t *t)
{
	struct bc_conn *c = t->data;
	bc_link_error(&c->net->link, ref_of(c), 0, BC_ETIMEOUT, true,
	              "no HELLO within %u ms", BC_SRV_HELLO_TIMEOUT_MS);
	bc__conn_close_after_flush(c, "HELLO timeout");
}

/* After HELLO: a message must complete within the message timeout of its
 * first byte, and a client in no session may not stay silent past the idle
 * timeout. (Before HELLO the HELLO timeout covers both; a parked message
 * is whole, and waits for its session.) */
static void check_timeouts(struct bc_net *n, struct bc_conn *c, uint64_t now)
{
	const struct bc_srv_config *cfg = n->cfg;
	uint64_t msg_ms = cfg->message_timeout_ms ? cfg->message_timeout_ms
	                                          : BC_SRV_MESSAGE_TIMEOUT_MS;
	uint64_t idle_ms = cfg->idle_timeout_ms ? cfg->idle_timeout_ms
	                                        : BC_SRV_IDLE_TIMEOUT_MS;
	if (c->closing || c->draining || !c->authed || c->parked) {
		return;
	}
	if (c->msg_started_ms && now - c->msg_started_ms > msg_ms) {
		bc_link_error(&n->link, ref_of(c), 0, BC_ETIMEOUT, true,
		              "a message did not complete within %" PRIu64
		              " ms of its first byte",
		              msg_ms);
		bc__conn_close_after_flush(c, "message timeout");
	} else if (bc_dispatch_idle(n->d, ref_of(c)) &&
	           now - c->last_read_ms > idle_ms) {
		bc_link_error(&n->link, ref_of(c), 0, BC_ETIMEOUT, true,
		              "idle for %" PRIu64 " ms in no session", idle_ms);
		bc__conn_close_after_flush(c, "idle timeout");
	}
}

void bc__net_check_stalls(uv_timer_t *t)
{
	struct bc_net *n = t->data;
	uint64_t now = now_ms(n);
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		struct bc_conn *c = n->clients[i];
		if (c) {
			check_timeouts(n, c, now);
		}
		if (c && !c->closing && c->frame_writing &&
		    now - c->frame_started_ms > BC_SRV_STALL_MS) {
			bc_log(BC_LOG_WARN,
			       "dropping client %u (%s): a frame has waited "
			       "%llu ms, it stopped reading",
			       c->gen, c->name,
			       (unsigned long long)(now - c->frame_started_ms));
			bc__conn_close(c, "stopped reading");
		}
	}
}

/* ---- connections and the layer ---------------------------------------------- */

void bc__conn_start(struct bc_conn *c, uint32_t slot)
{
	struct bc_net *n = c->net;
	c->slot = slot;
	c->gen = ++n->gens[slot] * BC_SRV_MAX_CONNECTIONS + slot;
	n->clients[slot] = c;
	n->nclients++;
	snprintf(c->name, sizeof(c->name), "?");
	bc_proto_reader_init(&c->reader, &(struct bc_proto_reader_opts){
	                                     .side = BC_PROTO_SIDE_SERVER,
	                                     .await_hello = true,
	                                 });
	if (bc_dispatch_open(n->d, ref_of(c), c->trusted, c->is_tcp,
	                     &c->counters)) {
		bc__conn_close(c, "out of memory");
		return;
	}
	c->hello_timer.data = c;
	uv_timer_start(&c->hello_timer, hello_timeout, BC_SRV_HELLO_TIMEOUT_MS,
	               0);
	uv_read_start(&c->h.stream, on_alloc, on_read);
}

int bc_net_new(struct bc_net **out, uv_loop_t *loop,
               const struct bc_srv_config *cfg)
{
	struct bc_net *n = bc_calloc(1, sizeof(*n));
	*out = NULL;
	if (!n) {
		return BC_ENOMEM;
	}
	n->loop = loop;
	n->cfg = cfg;
	n->link = (struct bc_link){
	    .ud = n,
	    .send = link_send,
	    .send_frame = link_send_frame,
	    .send_shared = link_send_shared,
	    .send_parts = link_send_parts,
	    .forget_frames = link_forget_frames,
	    .acks_on = link_acks_on,
	    .frame_ack = link_frame_ack,
	    .detach = link_detach,
	    .close = link_close,
	    .resume = link_resume,
	    .link_info = link_info,
	};
	uv_idle_init(loop, &n->resumer);
	n->resumer.data = n;
	uv_idle_init(loop, &n->doomer);
	n->doomer.data = n;
	uv_timer_init(loop, &n->stall_timer);
	n->stall_timer.data = n;
	*out = n;
	return 0;
}

const struct bc_link *bc_net_link(struct bc_net *n)
{
	return &n->link;
}

void bc_net_set_dispatch(struct bc_net *n, struct bc_dispatch *d)
{
	n->d = d;
}

void bc_net_close_all(struct bc_net *n)
{
	n->stopping = true;
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		if (n->clients[i]) {
			bc__conn_close(n->clients[i], "server stopping");
		}
	}
	uv_close((uv_handle_t *)&n->stall_timer, NULL);
	uv_close((uv_handle_t *)&n->resumer, NULL);
	uv_close((uv_handle_t *)&n->doomer, NULL);
	if (n->has_tcp) {
		uv_close((uv_handle_t *)&n->tcp_listener, NULL);
	}
	if (n->has_unix) {
		uv_close((uv_handle_t *)&n->unix_listener, NULL);
		unlink(n->cfg->unix_path);
	}
}

void bc_net_free(struct bc_net *n)
{
	if (n) {
		bc_tls_ctx_free(n->tls);
		bc_free(n);
	}
}
