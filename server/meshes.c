/*
 * MESH (PROTOCOL.md 7.28): a session's solid as a mesh file, made by the
 * daemon for a client that cannot mesh (the browser page). The file is
 * the one `blobcast mesh` writes of the same scene with the same options
 * (blobtree's mesher and writers, docs/mesh.md).
 *
 * Meshing takes seconds, so it stays off the loop and out of the render
 * workers' way:
 *  1. the handler takes a slot (at most BC_SRV_MESHES in the daemon, one
 *     a client) and copies the session's tree on a task (the session busy
 *     meanwhile, as for a render copy), so the mesh is of the scene as
 *     the MESH found it;
 *  2. one meshing thread, at the lowest scheduling priority (nice 19),
 *     lays the copy out, meshes it and writes the file behind room for
 *     the MESH_DATA's head, so the message is the file without a copy;
 *  3. the loop, woken, sends it (or the ERROR) to the connection, if it
 *     is still open.
 * Later requests of the client do not wait for it (PROTOCOL.md 5). The
 * daemon's stop asks a mesh under way to stop and waits for the thread.
 */
#define _GNU_SOURCE
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "blobcast/mesh.h"
#include "sessions_impl.h"

/* The meshing thread's nice value: the lowest priority, behind the loop
 * and the render workers. */
#define MESH_NICE 19

/* One MESH, from its request to its answer. */
struct mesh_job {
	struct bc_task t; /* the copy */
	struct mesh_job *next;
	struct bc_meshes *ms;
	struct bc_conn_ref to;
	uint32_t seq;
	uint32_t max_payload;       /* the client's max_frame_bytes */
	struct bc_msg_mesh_data md; /* the answer's fields (file: unset) */
	struct bc_tree *tree;       /* the copy, bare */
	/* Made by the thread. */
	struct bc_shared *msg;
	int rc;
	struct bc_errinfo ei;
};

struct bc_meshes {
	struct bc_sessions *ss;
	uv_async_t wake; /* the thread finished a job */
	pthread_t thread;
	bool started;
	pthread_mutex_t mu;
	pthread_cond_t cv;
	/* Under mu: jobs waiting for the thread, and jobs it finished. */
	struct mesh_job *todo, *done;
	bool quit;
	atomic_bool stop; /* the mesh under way stops */
	/* On the loop: the jobs in the daemon, from handler to answer;
	 * copies on libuv's pool, which end after the daemon's stop asked
	 * the meshes to go (the last one frees them then). */
	struct mesh_job *slots[BC_SRV_MESHES];
	uint32_t copying;
	bool closed;
};

/* ---- the meshing thread --------------------------------------------------- */

static bool stop_asked(void *ctx)
{
	struct bc_meshes *ms = ctx;
	return atomic_load(&ms->stop);
}

/* The job's file as a MESH_DATA, in j->msg, or j->rc and j->ei. */
static void mesh_one(struct bc_meshes *ms, struct mesh_job *j)
{
	const size_t head = BC_SHARED_HEAD + BC_PROTO_MESH_DATA_HEAD;
	struct bc_mesh_opts o = {.resolution = j->md.resolution,
	                         .raw =
	                             (j->md.options & BC_PROTO_MESH_RAW) != 0,
	                         .stop = stop_asked,
	                         .ctx = ms};
	struct bc_tree *laid = bc_tree_create();
	struct bc_mesh mesh;
	uint8_t *bytes = NULL;
	size_t len = 0;
	memset(&mesh, 0, sizeof(mesh));
	if (!laid) {
		j->rc = bc_errinfo_set(&j->ei, BC_ENOMEM, "out of memory");
	} else if (!(j->rc = bc_tree_copy(laid, j->tree, &j->ei)) &&
	           !(j->rc = bc_mesh_build(&mesh, laid, &o, &j->ei)) &&
	           !(j->rc = bc_mesh_write_mem(
	                 &mesh, (enum bc_mesh_format)j->md.format, head, &bytes,
	                 &len, &j->ei))) {
		size_t file = len - head;
		j->md.vertices = mesh.nverts;
		j->md.triangles = mesh.ntris;
		j->md.file.len = (uint32_t)file;
		if (BC_PROTO_MESH_DATA_FIXED + (uint64_t)file >
		    j->max_payload) {
			j->rc = bc_errinfo_set(
			    &j->ei, BC_ELIMIT,
			    "the mesh's file of %zu bytes (%u triangles) "
			    "passes "
			    "the client's max_frame_bytes of %u: ask for a "
			    "resolution under %u, or mesh on the client "
			    "(blobcast mesh --session)",
			    file, mesh.ntris, j->max_payload,
			    (unsigned)j->md.resolution);
			bc_free(bytes);
		} else {
			j->msg = bc_shared_adopt(bytes, len);
			bc_proto_mesh_data_head(j->msg->data, j->seq, &j->md);
		}
	}
	bc_mesh_finish(&mesh);
	bc_tree_destroy(laid);
	bc_tree_destroy(j->tree);
	j->tree = NULL;
}

static void *mesh_main(void *arg)
{
	struct bc_meshes *ms = arg;
	/* Renders first: this thread gets what CPU they leave (a nice 19
	 * thread against a busy one at 0: about 1.5 %, never none). */
	if (setpriority(PRIO_PROCESS, (id_t)gettid(), MESH_NICE) != 0) {
		bc_log(BC_LOG_WARN, "the meshing thread keeps its priority");
	}
	pthread_mutex_lock(&ms->mu);
	for (;;) {
		struct mesh_job *j;
		while (!ms->todo && !ms->quit) {
			pthread_cond_wait(&ms->cv, &ms->mu);
		}
		if (ms->quit) {
			break;
		}
		j = ms->todo;
		ms->todo = j->next;
		pthread_mutex_unlock(&ms->mu);
		mesh_one(ms, j);
		pthread_mutex_lock(&ms->mu);
		j->next = ms->done;
		ms->done = j;
		uv_async_send(&ms->wake);
	}
	pthread_mutex_unlock(&ms->mu);
	return NULL;
}

/* ---- the loop's side ------------------------------------------------------- */

static void job_free(struct mesh_job *j)
{
	struct bc_meshes *ms = j->ms;
	for (uint32_t i = 0; i < BC_SRV_MESHES; i++) {
		if (ms->slots[i] == j) {
			ms->slots[i] = NULL;
		}
	}
	bc_tree_destroy(j->tree);
	if (j->msg) {
		bc_shared_unref(j->msg);
	}
	bc_free(j);
}

/* The answer: MESH_DATA, or the ERROR; nothing when the connection went
 * (the link ignores a stale handle). */
static void answer(struct mesh_job *j)
{
	const struct bc_link *l = j->ms->ss->link;
	if (j->msg) {
		l->send_shared(l->ud, j->to, j->msg);
	} else {
		bc_link_error(l, j->to, j->seq, j->rc, false, "%s", j->ei.msg);
	}
	job_free(j);
}

static void woken(uv_async_t *h)
{
	struct bc_meshes *ms = h->data;
	struct mesh_job *j;
	pthread_mutex_lock(&ms->mu);
	j = ms->done;
	ms->done = NULL;
	pthread_mutex_unlock(&ms->mu);
	while (j) {
		struct mesh_job *next = j->next;
		answer(j);
		j = next;
	}
}

/* The meshes of ss, made at the first MESH; NULL when out of memory. */
static struct bc_meshes *meshes_of(struct bc_sessions *ss)
{
	struct bc_meshes *ms = ss->meshes;
	if (ms) {
		return ms;
	}
	if (!(ms = bc_calloc(1, sizeof(*ms)))) {
		return NULL;
	}
	ms->ss = ss;
	pthread_mutex_init(&ms->mu, NULL);
	pthread_cond_init(&ms->cv, NULL);
	if (uv_async_init(ss->loop, &ms->wake, woken) != 0) {
		pthread_cond_destroy(&ms->cv);
		pthread_mutex_destroy(&ms->mu);
		bc_free(ms);
		return NULL;
	}
	ms->wake.data = ms;
	ss->meshes = ms;
	return ms;
}

/* The copy, on libuv's pool: the session is busy, its tree does not
 * change. */
static void copy_run(struct bc_task *t)
{
	struct mesh_job *j = (struct mesh_job *)t;
	if (!(j->tree = bc__copy_tree()) ||
	    bc_tree_copy(j->tree, t->s->tree, NULL)) {
		j->rc = bc_errinfo_set(&j->ei, BC_ENOMEM,
		                       "no memory to copy the scene for its "
		                       "mesh; try again later");
	}
}

static void meshes_gone(struct bc_meshes *ms)
{
	pthread_cond_destroy(&ms->cv);
	pthread_mutex_destroy(&ms->mu);
	bc_free(ms);
}

static void copy_done(struct bc_task *t)
{
	struct mesh_job *j = (struct mesh_job *)t;
	struct bc_meshes *ms = j->ms;
	ms->copying--;
	if (ms->quit) {
		/* The daemon stops: nothing more is meshed. */
		job_free(j);
		if (ms->closed && !ms->copying) {
			meshes_gone(ms);
		}
		return;
	}
	if (!j->rc && !ms->started) {
		ms->started =
		    pthread_create(&ms->thread, NULL, mesh_main, ms) == 0;
		if (!ms->started) {
			j->rc = bc_errinfo_set(&j->ei, BC_ENOMEM,
			                       "no thread to mesh on; try "
			                       "again later");
		}
	}
	if (j->rc) {
		answer(j);
		return;
	}
	pthread_mutex_lock(&ms->mu);
	struct mesh_job **at = &ms->todo;
	while (*at) {
		at = &(*at)->next;
	}
	*at = j;
	pthread_cond_signal(&ms->cv);
	pthread_mutex_unlock(&ms->mu);
}

/* A free slot for m's MESH, or -1 (answered EBUSY): m has one already,
 * or the daemon meshes as many as it allows. */
static int take_slot(struct bc_meshes *ms, struct bc_member *m, uint32_t seq)
{
	int free_slot = -1;
	for (int i = 0; i < (int)BC_SRV_MESHES; i++) {
		if (!ms->slots[i]) {
			free_slot = free_slot < 0 ? i : free_slot;
		} else if (bc_conn_ref_eq(ms->slots[i]->to, m->peer->ref)) {
			bc__send_error(
			    m, seq, BC_EBUSY,
			    "your previous MESH is still being made; "
			    "wait for its answer");
			return -1;
		}
	}
	if (free_slot < 0) {
		bc__send_error(m, seq, BC_EBUSY,
		               "the daemon is making %u meshes already; try "
		               "again in a few seconds",
		               BC_SRV_MESHES);
	}
	return free_slot;
}

int bc_handle_mesh(struct bc_member *m, const struct bc_msg *msg)
{
	const struct bc_msg_mesh *q = &msg->mesh;
	struct bc_session *s = m->session;
	uint32_t res =
	    q->resolution ? q->resolution : BC_PROTO_MESH_DEFAULT_RESOLUTION;
	struct bc_meshes *ms;
	struct mesh_job *j;
	int slot;
	if (!(m->peer->features & BC_PROTO_FEATURE_MESH)) {
		bc__send_error(m, msg->seq, BC_ENOTSUP,
		               "MESH needs the feature MESH, which the "
		               "client's HELLO did not announce");
		return 0;
	}
	if (res > BC_SRV_MESH_MAX_RESOLUTION) {
		bc__send_error(m, msg->seq, BC_ELIMIT,
		               "resolution %u: this daemon meshes up to %u "
		               "cells along the scene's longest side; mesh "
		               "finer on the client (blobcast mesh --session)",
		               res, BC_SRV_MESH_MAX_RESOLUTION);
		return 0;
	}
	/* A load or big edit under way: the mesh is of the scene after it. */
	if (s->busy || !s->tree) {
		return bc__park(s, m, msg->seq);
	}
	if (!(ms = meshes_of(m->ss)) ||
	    (slot = take_slot(ms, m, msg->seq)) < 0) {
		if (!ms) {
			bc__send_error(m, msg->seq, BC_ENOMEM,
			               "the server is out of memory");
		}
		return 0;
	}
	if (!(j = bc_calloc(1, sizeof(*j)))) {
		bc__send_error(m, msg->seq, BC_ENOMEM,
		               "the server is out of memory");
		return 0;
	}
	j->ms = ms;
	j->to = m->peer->ref;
	j->seq = msg->seq;
	j->max_payload = m->peer->max_frame_bytes;
	j->md.format = q->format;
	j->md.options = q->options;
	j->md.resolution = (uint16_t)res;
	j->md.order = s->order;
	j->t.run = copy_run;
	j->t.done = copy_done;
	j->t.holds_order = true;
	ms->slots[slot] = j;
	ms->copying++;
	bc__task_start(s, &j->t);
	return 0;
}

static void meshes_closed(uv_handle_t *h)
{
	struct bc_meshes *ms = h->data;
	ms->closed = true;
	if (!ms->copying) {
		meshes_gone(ms);
	}
}

void bc__meshes_free(struct bc_sessions *ss)
{
	struct bc_meshes *ms = ss->meshes;
	struct mesh_job *j;
	if (!ms) {
		return;
	}
	ss->meshes = NULL;
	atomic_store(&ms->stop, true);
	pthread_mutex_lock(&ms->mu);
	ms->quit = true;
	pthread_cond_signal(&ms->cv);
	pthread_mutex_unlock(&ms->mu);
	if (ms->started) {
		pthread_join(ms->thread, NULL);
	}
	/* What waited or was made goes unsent; copies on the pool go when
	 * their tasks end (copy_done). */
	for (int pass = 0; pass < 2; pass++) {
		j = pass ? ms->done : ms->todo;
		while (j) {
			struct mesh_job *next = j->next;
			job_free(j);
			j = next;
		}
	}
	uv_close((uv_handle_t *)&ms->wake, meshes_closed);
}
