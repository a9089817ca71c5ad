/*
 * blobcastd --check DIR [--repair] (sessions layer, no loop): what each
 * session's files give back, read as a start would read them, like
 * redis-check-aof. A session a start would refuse (not whole: see
 * store.h) is named with the reason; --repair sets its files aside and
 * lets it go on from the best state they give, never reusing an order
 * number.
 */
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "blobcast/scene.h"
#include "sessions_impl.h"

struct check {
	struct bc_store *st;
	bool repair;
	FILE *out;
	int status;
};

/* The best state of a session that is not whole, set aside and carried
 * on at the highest order its files named. */
static void repair(struct check *k, const char *name, struct bc_tree **t,
                   struct bc_camera *cam, const struct bc_store_check *c)
{
	struct bc_errinfo ei = {0};
	const char *json = bc_scene_default_json();
	if (!c->loaded) {
		/* Nothing loads: the default scene, at the same order. */
		bc_tree_destroy(*t);
		if (!(*t = bc_tree_create()) ||
		    bc_scene_parse_json(json, strlen(json), *t, cam, &ei)) {
			fprintf(k->out, "%s: cannot repair: %s\n", name,
			        ei.msg);
			k->status = 1;
			return;
		}
	}
	if (bc_store_session_repair(k->st, name, *t, cam, c->frontier, &ei)) {
		fprintf(k->out, "%s: cannot repair: %s\n", name, ei.msg);
		k->status = 1;
		return;
	}
	fprintf(k->out,
	        "%s: repaired: goes on from edit %llu with %s; its old files "
	        "are kept in sessions/.damaged/\n",
	        name, (unsigned long long)c->frontier,
	        c->loaded ? "the state they gave" : "the default scene");
}

static void check_one(void *ud, const char *name)
{
	struct check *k = ud;
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct replay_ctx ctx = {&t, &cam, NULL};
	struct bc_store_check c;
	struct bc_errinfo ei = {0};
	bc_camera_default(&cam);
	if (!t || bc_store_session_check(k->st, name, t, &cam,
	                                 bc__replay_record, &ctx, &c, &ei)) {
		fprintf(k->out, "%s: cannot be read: %s\n", name,
		        t ? ei.msg : "out of memory");
		k->status = 1;
		bc_tree_destroy(t);
		return;
	}
	if (c.whole) {
		fprintf(k->out,
		        "%s: whole: edit %llu, %u primitives (%u snapshot(s), "
		        "%u of them damaged and covered by the journals)\n",
		        name, (unsigned long long)c.order,
		        bc_tree_prim_count(t), c.snapshots,
		        c.damaged_snapshots);
	} else {
		fprintf(k->out,
		        "%s: NOT WHOLE: %s; its files name edits up to %llu "
		        "and give back a state at %llu without the lost "
		        "ones%s\n",
		        name, c.why, (unsigned long long)c.frontier,
		        (unsigned long long)c.order,
		        k->repair ? ""
		                  : "; blobcastd will not serve it (--repair "
		                    "sets its files aside and goes on from "
		                    "there)");
		if (k->repair) {
			repair(k, name, &t, &cam, &c);
		} else {
			k->status = 1;
		}
	}
	bc_tree_destroy(t);
}

int bc_sessions_check(const char *dir, bool repair, FILE *out)
{
	struct bc_errinfo ei = {0};
	struct check k = {.repair = repair, .out = out};
	if (bc_store_open(&k.st, dir, &ei)) {
		fprintf(out, "blobcastd --check: %s%s\n", ei.msg,
		        ei.code == BC_EBUSY ? " (stop it first)" : "");
		return 2;
	}
	if (bc_store_list(k.st, check_one, &k)) {
		fprintf(out, "blobcastd --check: cannot list %s/sessions\n",
		        dir);
		k.status = 2;
	}
	bc_store_close(k.st);
	return k.status;
}
