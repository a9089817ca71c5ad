/*
 * A thread the window starts for one long piece of work of its own --
 * save.c's mesher, load.c's reader -- so that the loop goes on drawing:
 * the work runs once, wakes the loop when it ends, and the loop joins it
 * (bc_viewer_worker_reap) and says how it went. Meanwhile the loop says
 * how it goes at most every BC_VIEWER_WORKER_SAY_MS.
 */
#include "app.h"

/* The thread: the work, then the loop woken to join it. */
static void *worker_main(void *arg)
{
	struct bc_viewer_worker *w = arg;
	w->run(w->arg);
	atomic_store(&w->done, true);
	/* Thread-safe in GLFW. */
	glfwPostEmptyEvent();
	return NULL;
}

int bc_viewer_worker_start(struct bc_viewer_worker *w, void (*run)(void *arg),
                           void *arg)
{
	w->run = run;
	w->arg = arg;
	atomic_store(&w->done, false);
	w->started = w->said = bc_viewer_now_ms();
	if (pthread_create(&w->thread, NULL, worker_main, w)) {
		return -1;
	}
	w->busy = true;
	return 0;
}

bool bc_viewer_worker_reap(struct bc_viewer_worker *w)
{
	if (!w->busy || !atomic_load(&w->done)) {
		return false;
	}
	pthread_join(w->thread, NULL);
	w->busy = false;
	return true;
}

void bc_viewer_worker_join(struct bc_viewer_worker *w)
{
	if (w->busy) {
		pthread_join(w->thread, NULL);
		w->busy = false;
	}
}

bool bc_viewer_worker_say_due(struct bc_viewer_worker *w, double now)
{
	if (now - w->said < BC_VIEWER_WORKER_SAY_MS) {
		return false;
	}
	w->said = now;
	return true;
}

double bc_viewer_worker_next(const struct bc_viewer_worker *w, double now)
{
	return w->said + BC_VIEWER_WORKER_SAY_MS - now;
}
