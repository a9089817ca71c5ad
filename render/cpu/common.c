/*
 * The parts of a CPU renderer that do not depend on how it traces: the
 * renderer object and its ops (create, destroy, sync), the worker threads,
 * the clock and progress reports.
 */
#include "cpu.h"

#include <pthread.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"

int bc__cpu_create(struct bc_renderer **out, enum bc__cpu_kind kind,
		   const struct bc_render_opts *opts, struct bc_errinfo *ei)
{
	struct bc_renderer *r;
	uint32_t threads;
	*out = NULL;
	if (opts && (unsigned)opts->debug >= BC_DEBUG_COUNT) {
		return bc_errinfo_set(ei, BC_EENUM, "render: debug mode %d "
				      "out of range", (int)opts->debug);
	}
	r = bc_calloc(1, sizeof(*r));
	if (!r) {
		return bc_errinfo_set(ei, BC_ENOMEM, "render: out of memory");
	}
	r->kind = kind;
	if (opts) {
		r->opts = *opts;
	}
	/* Options pointing at caller strings are not kept: the CPU
	 * backends do not read them. */
	r->opts.gl_platform = NULL;
	threads = r->opts.threads;
	if (threads == 0) {
		long n = sysconf(_SC_NPROCESSORS_ONLN);
		threads = n > 0 ? (uint32_t)n : 1;
	}
	r->threads = threads > BC_CPU_MAX_THREADS ? BC_CPU_MAX_THREADS
						  : threads;
	*out = r;
	return 0;
}

void bc__cpu_destroy(struct bc_renderer *r)
{
	if (!r) {
		return;
	}
	bc__tiled_free(r->tiled);
	bc_free(r);
}

int bc__cpu_sync(struct bc_renderer *r, const struct bc_tree *t,
		 const struct bc_dirty *dirty, struct bc_errinfo *ei)
{
	(void)dirty; /* every frame reads the linearized tree afresh */
	if (!r || !t) {
		return bc_errinfo_set(ei, BC_EINVAL, "render: no tree to sync");
	}
	r->tree = t;
	return 0;
}

void bc_render_cpu_set_progress(struct bc_renderer *r, bc_render_progress_fn fn,
				void *user)
{
	if (r) {
		r->progress = fn;
		r->progress_user = user;
	}
}

/* ---- threads ------------------------------------------------------------ */

struct job {
	bc__work_fn fn;
	void *ctx;
	uint32_t index;
};

static void *job_main(void *arg)
{
	struct job *j = arg;
	j->fn(j->ctx, j->index);
	return NULL;
}

void bc__parallel(uint32_t n, bc__work_fn fn, void *ctx)
{
	pthread_t tid[BC_CPU_MAX_THREADS];
	struct job jobs[BC_CPU_MAX_THREADS];
	bool started[BC_CPU_MAX_THREADS] = {false};
	if (n > BC_CPU_MAX_THREADS) {
		n = BC_CPU_MAX_THREADS;
	}
	for (uint32_t i = 1; i < n; i++) {
		jobs[i] = (struct job){fn, ctx, i};
		started[i] = pthread_create(&tid[i], NULL, job_main,
					    &jobs[i]) == 0;
		if (!started[i]) {
			bc_log(BC_LOG_WARN, "render: cannot start worker %u, "
			       "continuing with fewer", i);
		}
	}
	fn(ctx, 0);
	for (uint32_t i = 1; i < n; i++) {
		if (started[i]) {
			pthread_join(tid[i], NULL);
		}
	}
}

double bc__now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

void bc__progress_init(struct bc__progress *p, const struct bc_renderer *r,
		       uint32_t total)
{
	p->fn = r->progress;
	p->user = r->progress_user;
	p->total = total;
	p->start = bc__now_ms();
	p->last = p->start;
}

void bc__progress_tick(struct bc__progress *p, uint32_t done)
{
	double now;
	if (!p->fn) {
		return;
	}
	now = bc__now_ms();
	/* Short frames stay quiet; long ones report four times a second. */
	if (now - p->start < 1000.0 || now - p->last < 250.0) {
		return;
	}
	p->last = now;
	p->fn(p->user, done > p->total ? p->total : done, p->total);
}
