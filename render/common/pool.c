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
 *
 * Waking a sleeping thread costs tens to hundreds of microseconds (more on
 * a virtual machine, whose idle cores halt), once per run to start a
 * worker and once more when the caller sleeps for the last worker. A
 * frame of the tiled backend is two to four runs a few microseconds
 * apart. So both sides wait for the other by polling first, for at most
 * SPIN_NS: a worker that took part in a run polls the generation for the
 * next one (the next phase of the same frame), and the caller polls
 * `pending` before sleeping on `done`. Either then sleeps as before;
 * the counters they poll are atomics, changed under the lock as well, so
 * no wake-up is lost to a sleeper that checked them under it.
 */
#include "blobcast/render_common.h"

#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/log.h"
#include "blobcast/render_backend.h"

struct pool {
	pthread_mutex_t run_lock; /* one run at a time */
	pthread_mutex_t lock;     /* guards everything below */
	pthread_cond_t wake;      /* generation changed */
	pthread_cond_t done;      /* pending reached 0 */
	uint32_t started;         /* workers 1..started are running */
	bool failed;              /* a start failed: do not retry each run */
	bc_pool_fn fn;
	void *ctx;
	uint32_t n; /* shares of the current run */
	/* Changed under the lock, polled without it, each on a line of its
	 * own: the run's number, and its worker shares not finished. */
	_Alignas(64) _Atomic uint64_t generation;
	_Alignas(64) atomic_uint pending;
};

static struct pool pool = {
    .run_lock = PTHREAD_MUTEX_INITIALIZER,
    .lock = PTHREAD_MUTEX_INITIALIZER,
    .wake = PTHREAD_COND_INITIALIZER,
    .done = PTHREAD_COND_INITIALIZER,
};

/* How long a side polls before it sleeps (see above): longer than the
 * gaps between the phases of one frame, short enough that a worker with
 * nothing more to do soon leaves the core to others. */
#define SPIN_NS 200000

static int64_t now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* Lets another runnable thread have the core (the one polled for, when
 * the machine has fewer cores free than threads), else returns at once. */
static inline void cpu_relax(void)
{
	sched_yield();
}

/* Polls until *gen differs from seen or SPIN_NS pass; true if it did. */
static bool spin_generation(uint64_t seen)
{
	int64_t start = now_ns();
	for (uint32_t i = 0;; i++) {
		if (atomic_load_explicit(&pool.generation,
		                         memory_order_acquire) != seen) {
			return true;
		}
		cpu_relax();
		if ((i & 7u) == 7u && now_ns() - start > SPIN_NS) {
			return false;
		}
	}
}

/* Polls until no worker share is pending or SPIN_NS pass. */
static bool spin_pending(void)
{
	int64_t start = now_ns();
	for (uint32_t i = 0;; i++) {
		if (atomic_load_explicit(&pool.pending, memory_order_acquire) ==
		    0) {
			return true;
		}
		cpu_relax();
		if ((i & 7u) == 7u && now_ns() - start > SPIN_NS) {
			return false;
		}
	}
}

/* The worker's index travels in the pointer argument: nothing to free. */
static void *worker_main(void *arg)
{
	uint32_t index = (uint32_t)(uintptr_t)arg;
	uint64_t seen;
	bool took_part = false;
	pthread_mutex_lock(&pool.lock);
	/* A worker starts during the run that needed it: it takes part. */
	seen = atomic_load(&pool.generation) - 1;
	for (;;) {
		bc_pool_fn fn;
		void *ctx;
		if (took_part) {
			/* The next phase of the frame is likely near. */
			pthread_mutex_unlock(&pool.lock);
			spin_generation(seen);
			pthread_mutex_lock(&pool.lock);
		}
		while (atomic_load(&pool.generation) == seen) {
			pthread_cond_wait(&pool.wake, &pool.lock);
		}
		seen = atomic_load(&pool.generation);
		took_part = index < pool.n;
		if (!took_part) {
			continue;
		}
		fn = pool.fn;
		ctx = pool.ctx;
		pthread_mutex_unlock(&pool.lock);
		fn(ctx, index);
		if (atomic_fetch_sub(&pool.pending, 1u) == 1u) {
			/* The last share: wake the caller if it sleeps. */
			pthread_mutex_lock(&pool.lock);
			pthread_cond_signal(&pool.done);
		} else {
			pthread_mutex_lock(&pool.lock);
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
	atomic_store(&pool.pending, shares - 1);
	atomic_fetch_add_explicit(&pool.generation, 1u, memory_order_release);
	pthread_cond_broadcast(&pool.wake);
	pthread_mutex_unlock(&pool.lock);
	fn(ctx, 0);
	/* Shares without a worker run here, after the caller's own. */
	for (uint32_t i = shares; i < n; i++) {
		fn(ctx, i);
	}
	spin_pending();
	pthread_mutex_lock(&pool.lock);
	while (atomic_load(&pool.pending) > 0) {
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

uint64_t bc_render_scale_key(struct bc_renderer *r, const struct bc_camera *cam,
                             uint32_t width, uint32_t height)
{
	const struct bc_lin *l = r->tree ? bc_tree_lin(r->tree) : NULL;
	float scale = bc_render_scale(l);
	float lip = l ? l->lip : 1.0f;
	uint32_t bits, lbits;
	(void)cam;
	(void)width;
	(void)height;
	memcpy(&bits, &scale, sizeof(bits));
	memcpy(&lbits, &lip, sizeof(lbits));
	return (uint64_t)bits | ((uint64_t)lbits << 32);
}
