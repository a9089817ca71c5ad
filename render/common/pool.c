/*
 * The worker threads of the CPU backends and the scene scale (frame
 * timings use base's bc_clock_ms).
 *
 * The pool is process-wide and persistent: worker i (1 <= i < 64) is
 * started the first time a run asks for i + 1 shares and then kept,
 * blocked on a condition variable between runs. A run publishes (fn, ctx,
 * n) under the pool's lock, bumps a generation counter and wakes every
 * worker; those whose index is below n run their share and count down
 * `pending`, and the caller (share 0) waits for it to reach zero. Starting
 * threads per frame cost 50-100 us per thread and per call, several calls
 * per frame (the tiled backend runs four phases), which a 2 ms interactive
 * frame notices. Runs from several threads at once take `run_lock` in
 * turn: the pool has one set of workers. The workers are detached and never
 * stopped; they hold no heap memory, so leak checkers stay quiet at exit.
 */
#include "blobcast/render_common.h"

#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <unistd.h>

#include "blobcast/log.h"

struct pool {
	pthread_mutex_t run_lock; /* one run at a time */
	pthread_mutex_t lock;     /* guards everything below */
	pthread_cond_t wake;      /* generation changed */
	pthread_cond_t done;      /* pending reached 0 */
	uint32_t started;         /* workers 1..started are running */
	bool failed;              /* a start failed: do not retry each run */
	uint64_t generation;
	bc_pool_fn fn;
	void *ctx;
	uint32_t n;       /* shares of the current run */
	uint32_t pending; /* worker shares of it not finished */
};

static struct pool pool = {
    .run_lock = PTHREAD_MUTEX_INITIALIZER,
    .lock = PTHREAD_MUTEX_INITIALIZER,
    .wake = PTHREAD_COND_INITIALIZER,
    .done = PTHREAD_COND_INITIALIZER,
};

/* The worker's index travels in the pointer argument: nothing to free. */
static void *worker_main(void *arg)
{
	uint32_t index = (uint32_t)(uintptr_t)arg;
	uint64_t seen;
	pthread_mutex_lock(&pool.lock);
	/* A worker starts during the run that needed it: it takes part. */
	seen = pool.generation - 1;
	for (;;) {
		bc_pool_fn fn;
		void *ctx;
		while (pool.generation == seen) {
			pthread_cond_wait(&pool.wake, &pool.lock);
		}
		seen = pool.generation;
		if (index >= pool.n) {
			continue;
		}
		fn = pool.fn;
		ctx = pool.ctx;
		pthread_mutex_unlock(&pool.lock);
		fn(ctx, index);
		pthread_mutex_lock(&pool.lock);
		if (--pool.pending == 0) {
			pthread_cond_signal(&pool.done);
		}
	}
	return NULL;
}

/* Starts workers up to index n - 1 (called with pool.lock held, before the
 * run is published). Returns how many are running. */
static uint32_t start_workers(uint32_t n)
{
	while (!pool.failed && pool.started + 1 < n) {
		uint32_t index = pool.started + 1;
		pthread_attr_t attr;
		pthread_t tid;
		int rc = pthread_attr_init(&attr);
		if (rc == 0) {
			pthread_attr_setdetachstate(&attr,
			                            PTHREAD_CREATE_DETACHED);
			rc = pthread_create(&tid, &attr, worker_main,
			                    (void *)(uintptr_t)index);
			pthread_attr_destroy(&attr);
		}
		if (rc != 0) {
			bc_log(BC_LOG_WARN,
			       "render: cannot start worker %u, "
			       "continuing with %u",
			       index, pool.started + 1);
			pool.failed = true;
			break;
		}
		pool.started = index;
	}
	return pool.started;
}

void bc_pool_run(uint32_t n, bc_pool_fn fn, void *ctx)
{
	uint32_t running, shares;
	if (n > BC_POOL_MAX_THREADS) {
		n = BC_POOL_MAX_THREADS;
	}
	if (n <= 1) {
		fn(ctx, 0);
		return;
	}
	pthread_mutex_lock(&pool.run_lock);
	pthread_mutex_lock(&pool.lock);
	running = start_workers(n);
	shares = running + 1 < n ? running + 1 : n;
	pool.fn = fn;
	pool.ctx = ctx;
	pool.n = shares;
	pool.pending = shares - 1;
	pool.generation++;
	pthread_cond_broadcast(&pool.wake);
	pthread_mutex_unlock(&pool.lock);
	fn(ctx, 0);
	/* Shares without a worker run here, after the caller's own. */
	for (uint32_t i = shares; i < n; i++) {
		fn(ctx, i);
	}
	pthread_mutex_lock(&pool.lock);
	while (pool.pending > 0) {
		pthread_cond_wait(&pool.done, &pool.lock);
	}
	pool.fn = NULL;
	pool.ctx = NULL;
	pthread_mutex_unlock(&pool.lock);
	pthread_mutex_unlock(&pool.run_lock);
}

uint32_t bc_pool_default_threads(void)
{
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	if (n < 1) {
		return 1;
	}
	return n > (long)BC_POOL_MAX_THREADS ? BC_POOL_MAX_THREADS
	                                     : (uint32_t)n;
}

float bc_render_scale(const struct bc_lin *lin)
{
	if (!lin || !(lin->size > 0.0f) || !isfinite(lin->size)) {
		return 1.0f;
	}
	return exp2f(ceilf(log2f(lin->size)));
}
