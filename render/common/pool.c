/*
 * The worker threads of the CPU backends, the frame clock and the scene
 * scale. bc_pool_run starts a thread per share for now; a persistent pool
 * replaces it behind the same function.
 */
#include "blobcast/render_common.h"

#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <time.h>
#include <unistd.h>

#include "blobcast/log.h"

struct job {
	bc_pool_fn fn;
	void *ctx;
	uint32_t index;
};

static void *job_main(void *arg)
{
	struct job *j = arg;
	j->fn(j->ctx, j->index);
	return NULL;
}

void bc_pool_run(uint32_t n, bc_pool_fn fn, void *ctx)
{
	pthread_t tid[BC_POOL_MAX_THREADS];
	struct job jobs[BC_POOL_MAX_THREADS];
	bool started[BC_POOL_MAX_THREADS] = {false};
	if (n > BC_POOL_MAX_THREADS) {
		n = BC_POOL_MAX_THREADS;
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

uint32_t bc_pool_default_threads(void)
{
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	if (n < 1) {
		return 1;
	}
	return n > (long)BC_POOL_MAX_THREADS ? BC_POOL_MAX_THREADS
					     : (uint32_t)n;
}

double bc_render_now_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

float bc_render_scale(const struct bc_lin *lin)
{
	if (!lin || !(lin->size > 0.0f) || !isfinite(lin->size)) {
		return 1.0f;
	}
	return exp2f(ceilf(log2f(lin->size)));
}
