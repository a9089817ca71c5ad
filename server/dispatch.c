/*
 * Dispatch (loop thread): every whole message of every connection comes
 * here from the transport. One table says, per message type, who handles
 * it; the protocol's state machine (stage and role, PROTOCOL.md 5) is
 * checked once before any handler runs. HELLO (version, token, what the
 * client accepts), PING and GET_STATS are answered here; the rest goes to
 * the sessions layer's handlers.
 *
 * It also times the event loop: each request's handler, and each turn of
 * the loop (the time between two waits for input, from libuv's idle-time
 * metric), keeping the longest of each for STATS's load section. The goal
 * is that no request and no turn takes more than a few milliseconds:
 * whatever could take longer runs on a thread.
 */
#include "dispatch.h"

#include <stdio.h>
#include <time.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "config.h"
#include "srv_limits.h"
#include "vstream.h"

struct bc_dispatch;
struct client;

/* Where a message goes: a member handler of the sessions layer, or one of
 * dispatch's own. */
struct route {
	int (*member)(struct bc_member *m, const struct bc_msg *msg);
	enum bc_dispatch_result (*own)(struct bc_dispatch *d, struct client *c,
	                               const struct bc_msg *msg);
};

/* One client: what it said in HELLO and its member state. */
struct client {
	bool open;
	bool trusted, is_tcp;
	struct bc_peer peer;
	struct bc_member member;
	const struct bc_conn_counters *counters;
};

struct bc_dispatch {
	uv_loop_t *loop;
	const struct bc_link *link;
	struct bc_sessions *ss;
	struct bc_work *work;
	const struct bc_srv_config *cfg;
	uint64_t started_ms;
	struct client clients[BC_SRV_MAX_CONNECTIONS];
	/* The loop's timing (see the file comment), nanoseconds. */
	uv_prepare_t turn;
	uint64_t turn_t, turn_idle, turn_cpu;
	uint64_t turn_max_ns, request_max_ns;
	bool metrics;
	uint64_t tls_not_after_ms; /* the certificate's end, or 0 */
};

static enum bc_dispatch_result hello(struct bc_dispatch *d, struct client *c,
                                     const struct bc_msg *m);
static enum bc_dispatch_result stats(struct bc_dispatch *d, struct client *c,
                                     const struct bc_msg *m);
static enum bc_dispatch_result
frame_ack(struct bc_dispatch *d, struct client *c, const struct bc_msg *m);

/* What the server does with each message a client may send (the state
 * machine has been checked). Adding a request: its codec in protocol/, a
 * line here, its handler. */
static const struct route routes[BC_MSG_COUNT] = {
    [BC_MSG_HELLO] = {NULL, hello},
    [BC_MSG_SESSION_CREATE] = {bc_handle_session, NULL},
    [BC_MSG_SESSION_JOIN] = {bc_handle_session, NULL},
    [BC_MSG_SESSION_LEAVE] = {bc_handle_leave, NULL},
    [BC_MSG_SCENE_LOAD] = {bc_handle_scene_load, NULL},
    [BC_MSG_EDIT] = {bc_handle_edit, NULL},
    [BC_MSG_CAMERA] = {bc_handle_camera, NULL},
    [BC_MSG_VIEW] = {bc_handle_view, NULL},
    [BC_MSG_PICK] = {bc_handle_pick, NULL},
    [BC_MSG_SNAPSHOT] = {bc_handle_snapshot, NULL},
    [BC_MSG_GET_STATS] = {NULL, stats},
    [BC_MSG_SESSION_DELETE] = {bc_handle_session_delete, NULL},
    [BC_MSG_UNDO] = {bc_handle_undo, NULL},
    [BC_MSG_REDO] = {bc_handle_undo, NULL},
    [BC_MSG_SESSION_LIST] = {bc_handle_session_list, NULL},
    [BC_MSG_PRESENT] = {bc_handle_present, NULL},
    [BC_MSG_FOLLOW] = {bc_handle_follow, NULL},
    [BC_MSG_SESSION_CAMERA] = {bc_handle_session_camera, NULL},
    [BC_MSG_HISTORY_GET] = {bc_handle_history, NULL},
    [BC_MSG_FRAME_ACK] = {NULL, frame_ack},
    [BC_MSG_MESH] = {bc_handle_mesh, NULL},
};

static struct client *client_of(struct bc_dispatch *d, struct bc_conn_ref ref)
{
	struct client *c;
	if (ref.slot >= BC_SRV_MAX_CONNECTIONS) {
		return NULL;
	}
	c = &d->clients[ref.slot];
	return c->open && bc_conn_ref_eq(c->peer.ref, ref) ? c : NULL;
}

static void refuse(struct bc_dispatch *d, struct client *c, uint32_t seq,
                   int code, bool fatal, const char *text)
{
	bc_link_error(d->link, c->peer.ref, seq, code, fatal, "%s", text);
	if (fatal) {
		d->link->close(d->link->ud, c->peer.ref, text, true);
	}
}

/* ---- loop timing ---------------------------------------------------------- */

/* CPU time of the calling thread. */
static uint64_t thread_cpu_ns(void)
{
	struct timespec ts;
	if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts)) {
		return 0;
	}
	return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static void on_turn(uv_prepare_t *p)
{
	struct bc_dispatch *d = p->data;
	uint64_t now = uv_hrtime(), idle = uv_metrics_idle_time(d->loop);
	uint64_t cpu = thread_cpu_ns();
	if (d->turn_t) {
		uint64_t wall = now - d->turn_t, waited = idle - d->turn_idle;
		uint64_t busy = wall > waited ? wall - waited : 0;
		d->turn_max_ns = busy > d->turn_max_ns ? busy : d->turn_max_ns;
		/* A long turn that used little of the CPU waited for it (other
		 * processes, or workers on every core): the log tells which. */
		if (busy > BC_SRV_SLOW_TURN_MS * 1000000u) {
			bc_log(BC_LOG_INFO,
			       "a loop turn took %.1f ms, %.1f ms of it on the "
			       "CPU",
			       (double)busy / 1e6,
			       (double)(cpu - d->turn_cpu) / 1e6);
		}
	}
	d->turn_t = now;
	d->turn_idle = idle;
	d->turn_cpu = cpu;
}

/* ---- HELLO, STATS ---------------------------------------------------------- */

static enum bc_proto_role token_role(const struct bc_dispatch *d,
                                     const struct client *c,
                                     struct bc_proto_str tok)
{
	const struct bc_srv_config *cfg = d->cfg;
	for (uint32_t i = 0; i < cfg->ntokens; i++) {
		const char *t = cfg->tokens[i].token;
		if (strlen(t) == tok.len && memcmp(t, tok.ptr, tok.len) == 0) {
			return cfg->tokens[i].role;
		}
	}
	/* No token: only trusted peers, and only when no token is configured
	 * or they come over the Unix socket (filesystem permissions). */
	if (tok.len == 0 && c->trusted && (cfg->ntokens == 0 || !c->is_tcp)) {
		return BC_PROTO_ROLE_EDITOR;
	}
	return BC_PROTO_ROLE_INVALID;
}

static enum bc_dispatch_result hello(struct bc_dispatch *d, struct client *c,
                                     const struct bc_msg *m)
{
	const struct bc_msg_hello *h = &m->hello;
	struct bc_msg w = {.type = BC_MSG_WELCOME, .seq = m->seq};
	if (h->version_min > BC_PROTO_VERSION ||
	    h->version_max < BC_PROTO_VERSION) {
		char why[80];
		snprintf(why, sizeof(why), "this server speaks version %u only",
		         BC_PROTO_VERSION);
		refuse(d, c, m->seq, BC_EPROTO_VERSION, true, why);
		return BC_DISPATCH_OK;
	}
	c->peer.max_role = token_role(d, c, h->token);
	if (c->peer.max_role == BC_PROTO_ROLE_INVALID) {
		refuse(d, c, m->seq, BC_EAUTH, true,
		       "a valid token is required");
		return BC_DISPATCH_OK;
	}
	if (h->client_name.len) {
		memcpy(c->peer.name, h->client_name.ptr, h->client_name.len);
	}
	c->peer.name[h->client_name.len] = '\0';
	/* 0: the client wants no frames; its VIEWs are refused (EINVAL). */
	c->peer.encodings = h->encodings;
	if (h->encodings & (1u << (BC_PROTO_ENC_H264 - 1))) {
		/* FFmpeg's libraries load while the client joins. */
		bc_vstream_preload();
	}
	/* No frame is larger than the protocol's payload limit, whatever the
	 * client accepts. */
	c->peer.max_frame_bytes =
	    h->max_frame_bytes && h->max_frame_bytes < BC_PROTO_MAX_PAYLOAD
	        ? h->max_frame_bytes
	        : BC_PROTO_MAX_PAYLOAD;
	c->peer.stage = BC_PROTO_STAGE_READY;
	/* Features: those announced that this server has (PROTOCOL.md 4);
	 * an earlier client's HELLO has none, and its WELCOME no field. */
	c->peer.announced = h->has_features;
	c->peer.features = h->features & BC_SRV_FEATURES;
	c->peer.knows_present =
	    (c->peer.features & BC_PROTO_FEATURE_PRESENT) != 0;
	if (c->peer.features & BC_PROTO_FEATURE_ACKS) {
		d->link->acks_on(d->link->ud, c->peer.ref);
	}
	w.welcome.has_features = h->has_features;
	w.welcome.features = c->peer.features;
	w.welcome.version = BC_PROTO_VERSION;
	w.welcome.connection_id = c->peer.ref.gen;
	w.welcome.max_payload = BC_PROTO_MAX_PAYLOAD;
	w.welcome.max_frame_bytes = c->peer.max_frame_bytes;
	w.welcome.max_nodes = BC_SRV_MAX_NODES;
	w.welcome.max_dim = BC_SRV_MAX_DIM;
	w.welcome.max_members = BC_PROTO_MAX_MEMBERS;
	w.welcome.max_edit_ops = BC_PROTO_MAX_EDIT_OPS;
	w.welcome.server_id.ptr = d->cfg->server_id;
	w.welcome.server_id.len = (uint32_t)strlen(d->cfg->server_id);
	d->link->send(d->link->ud, c->peer.ref, &w);
	return BC_DISPATCH_HELLO;
}

static void load_section(struct bc_dispatch *d, const struct bc_member *m,
                         struct bc_proto_load *l)
{
	struct bc_work_stats ws;
	uint32_t sid = bc_member_session_id(m);
	bc_work_stats(d->work, &ws);
	l->loop_turn_max_ms = (float)((double)d->turn_max_ns / 1e6);
	l->loop_request_max_ms = (float)((double)d->request_max_ns / 1e6);
	l->render_workers = ws.workers;
	l->jobs_queued = ws.queued;
	l->jobs_running = ws.running;
	l->view_bytes = ws.view_bytes;
	l->view_cap = ws.view_cap;
	l->session_render_us = sid ? bc_work_session_us(d->work, sid) : 0;
}

void bc_dispatch_set_tls_expiry(struct bc_dispatch *d, uint64_t not_after_ms)
{
	d->tls_not_after_ms = not_after_ms;
}

static enum bc_dispatch_result stats(struct bc_dispatch *d, struct client *c,
                                     const struct bc_msg *msg)
{
	const struct bc_conn_counters *k = c->counters;
	struct bc_msg st = {.type = BC_MSG_STATS, .seq = msg->seq};
	struct bc_sessions_stats ss;
	uint64_t now = uv_now(d->loop);
	double secs =
	    k->first_frame_ms ? (double)(now - k->first_frame_ms) / 1e3 : 0.0;
	bc_sessions_stats(d->ss, &ss);
	st.stats.uptime_ms = now - d->started_ms;
	st.stats.frames = k->frames_sent;
	st.stats.bytes = k->bytes_sent;
	st.stats.order = bc_member_order(&c->member);
	st.stats.sessions = ss.sessions;
	st.stats.clients = 0;
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		st.stats.clients += d->clients[i].open ? 1u : 0u;
	}
	st.stats.render_ms_last = (float)ss.render_ms_last;
	st.stats.render_ms_avg = (float)ss.render_ms_avg;
	st.stats.encode_ms_last = (float)ss.encode_ms_last;
	st.stats.encode_ms_avg = (float)ss.encode_ms_avg;
	st.stats.edit_ms_avg = (float)bc_member_edit_ms(&c->member);
	st.stats.fps =
	    secs > 0.0 ? (float)((double)k->frames_sent / secs) : 0.0f;
	if (msg->get_stats.parts & BC_PROTO_STATS_LOAD) {
		st.stats.has_load = true;
		load_section(d, &c->member, &st.stats.load);
	}
	if (msg->get_stats.parts & BC_PROTO_STATS_TLS) {
		uint64_t warn_ms =
		    (uint64_t)BC_SRV_TLS_WARN_DAYS * 24u * 3600u * 1000u;
		struct timespec ts;
		uint64_t unix_ms;
		clock_gettime(CLOCK_REALTIME, &ts);
		unix_ms = (uint64_t)ts.tv_sec * 1000u +
		          (uint64_t)ts.tv_nsec / 1000000u;
		st.stats.has_tls = true;
		st.stats.tls_not_after_ms = d->tls_not_after_ms;
		st.stats.tls_expiring = d->tls_not_after_ms &&
		                        d->tls_not_after_ms < unix_ms + warn_ms;
	}
	if (msg->get_stats.parts & BC_PROTO_STATS_LINK) {
		st.stats.has_link = true;
		d->link->link_info(d->link->ud, c->peer.ref, &st.stats.link);
	}
	if (msg->get_stats.parts & BC_PROTO_STATS_MEMORY) {
		st.stats.has_memory = true;
		st.stats.memory.scene_nodes = ss.nodes_held;
		st.stats.memory.scene_nodes_cap = ss.nodes_cap;
		st.stats.memory.session_nodes =
		    bc_member_session_nodes(&c->member);
		st.stats.memory.sessions_loaded = ss.sessions;
	}
	d->link->send(d->link->ud, c->peer.ref, &st);
	if (msg->get_stats.parts & BC_PROTO_STATS_RESET) {
		d->turn_max_ns = d->request_max_ns = 0;
	}
	return BC_DISPATCH_OK;
}

/* ---- messages --------------------------------------------------------------- */

enum bc_dispatch_result bc_dispatch_message(struct bc_dispatch *d,
                                            struct bc_conn_ref ref,
                                            const struct bc_msg *m)
{
	struct client *c = client_of(d, ref);
	const struct route *r;
	enum bc_dispatch_result res;
	uint64_t t0;
	int rc;
	if (!c) {
		return BC_DISPATCH_OK;
	}
	if (m->type == BC_MSG_PING) {
		struct bc_msg pong = {.type = BC_MSG_PONG, .seq = m->seq};
		pong.ping.stamp = m->ping.stamp;
		d->link->send(d->link->ud, ref, &pong);
		return BC_DISPATCH_OK;
	}
	if (m->type == BC_MSG_PONG || m->type == BC_MSG_ERROR) {
		return BC_DISPATCH_OK;
	}
	/* An earlier client (a HELLO without features) that sends a type of
	 * the presentation messages knows those the server sends (PROTOCOL.md
	 * 4), refused or not. */
	if (m->type >= BC_MSG_PRESENT && !c->peer.announced) {
		c->peer.knows_present = true;
	}
	if ((rc = bc_proto_client_may_send(c->peer.stage, c->peer.role,
	                                   m->type))) {
		char why[120];
		snprintf(why, sizeof(why), "%s is not allowed %s",
		         bc_proto_type_name(m->type),
		         rc == BC_EPERM ? "for a viewer" : "at this point");
		refuse(d, c, m->seq, rc, false, why);
		return BC_DISPATCH_OK;
	}
	r = (unsigned)m->type < BC_MSG_COUNT ? &routes[m->type] : NULL;
	if (!r || (!r->member && !r->own)) {
		char why[80];
		snprintf(why, sizeof(why), "%s is not a request",
		         bc_proto_type_name(m->type));
		refuse(d, c, m->seq, BC_EPROTO_TYPE, false, why);
		return BC_DISPATCH_OK;
	}
	t0 = uv_hrtime();
	if (r->own) {
		res = r->own(d, c, m);
	} else {
		/* Parked or held, the connection waits for its session. */
		res = r->member(&c->member, m) ? BC_DISPATCH_PARK
		                               : BC_DISPATCH_OK;
	}
	t0 = uv_hrtime() - t0;
	d->request_max_ns = t0 > d->request_max_ns ? t0 : d->request_max_ns;
	if (t0 > (uint64_t)BC_SRV_SLOW_REQUEST_MS * 1000000u) {
		bc_log(BC_LOG_WARN,
		       "%s from client %u took %.1f ms on the loop",
		       bc_proto_type_name(m->type), ref.gen, (double)t0 / 1e6);
	}
	return res;
}

/* ---- connections ------------------------------------------------------------ */

int bc_dispatch_open(struct bc_dispatch *d, struct bc_conn_ref ref,
                     bool trusted, bool is_tcp,
                     const struct bc_conn_counters *counters)
{
	struct client *c;
	if (ref.slot >= BC_SRV_MAX_CONNECTIONS) {
		return BC_EINVAL;
	}
	c = &d->clients[ref.slot];
	memset(c, 0, sizeof(*c));
	c->open = true;
	c->trusted = trusted;
	c->is_tcp = is_tcp;
	c->counters = counters;
	c->peer.ref = ref;
	c->peer.stage = BC_PROTO_STAGE_HELLO;
	snprintf(c->peer.name, sizeof(c->peer.name), "?");
	bc_member_init(&c->member, d->ss, &c->peer);
	return 0;
}

/* FRAME_ACK: the transport paces the client's frames by it (PROTOCOL.md
 * 7.27); only from a client granted ACKS. */
static enum bc_dispatch_result
frame_ack(struct bc_dispatch *d, struct client *c, const struct bc_msg *m)
{
	struct bc_errinfo ei = {0};
	if (!(c->peer.features & BC_PROTO_FEATURE_ACKS)) {
		refuse(d, c, m->seq, BC_ENOTSUP, false,
		       "FRAME_ACK needs the feature ACKS, which the "
		       "client's HELLO did not announce");
	} else if (d->link->frame_ack(d->link->ud, c->peer.ref,
	                              m->frame_ack.frame_no, &ei)) {
		refuse(d, c, m->seq, ei.code, false, ei.msg);
	}
	return BC_DISPATCH_OK;
}

void bc_dispatch_writable(struct bc_dispatch *d, struct bc_conn_ref ref)
{
	struct client *c = client_of(d, ref);
	if (c) {
		bc_member_writable(&c->member);
	}
}

void bc_dispatch_answered(struct bc_dispatch *d, struct bc_conn_ref ref)
{
	struct client *c = client_of(d, ref);
	if (c) {
		bc_member_answered(&c->member);
	}
}

void bc_dispatch_closed(struct bc_dispatch *d, struct bc_conn_ref ref)
{
	struct client *c = client_of(d, ref);
	if (c) {
		bc_member_finish(&c->member);
		c->open = false;
	}
}

bool bc_dispatch_idle(const struct bc_dispatch *d, struct bc_conn_ref ref)
{
	const struct client *c;
	if (ref.slot >= BC_SRV_MAX_CONNECTIONS) {
		return false;
	}
	c = &d->clients[ref.slot];
	return c->open && bc_conn_ref_eq(c->peer.ref, ref) &&
	       c->peer.stage == BC_PROTO_STAGE_READY;
}

int bc_dispatch_new(struct bc_dispatch **out,
                    const struct bc_dispatch_opts *opts, struct bc_errinfo *ei)
{
	struct bc_dispatch *d = bc_calloc(1, sizeof(*d));
	*out = NULL;
	if (!d) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	d->loop = opts->loop;
	d->link = opts->link;
	d->ss = opts->sessions;
	d->work = opts->work;
	d->cfg = opts->cfg;
	d->started_ms = uv_now(d->loop);
	uv_prepare_init(d->loop, &d->turn);
	d->turn.data = d;
	uv_prepare_start(&d->turn, on_turn);
	/* The prepare handle alone must not keep the loop running. */
	uv_unref((uv_handle_t *)&d->turn);
	*out = d;
	return 0;
}

static void turn_closed(uv_handle_t *h)
{
	bc_free(h->data);
}

void bc_dispatch_free(struct bc_dispatch *d)
{
	if (!d) {
		return;
	}
	for (uint32_t i = 0; i < BC_SRV_MAX_CONNECTIONS; i++) {
		if (d->clients[i].open) {
			bc_member_finish(&d->clients[i].member);
			d->clients[i].open = false;
		}
	}
	uv_close((uv_handle_t *)&d->turn, turn_closed);
}
