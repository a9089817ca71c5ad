/*
 * Structural edits against scene size: INSERT and REMOVE of one sphere
 * under the one wide union of many-spheres scenes (blobtree/gen.c), at the
 * union's end, start and middle, and REPLACE of one in the middle, spliced
 * into the layout (blobtree/splice.c)
 * -- beside what the same edit cost before: a full layout of the tree, and
 * for an edit batch also a copy of the whole tree. The batch rows are the
 * daemon's path to EDIT_APPLIED (bc_edit_batch_apply_undoable, in place).
 *
 * Usage: bench_splice [max_prims]   (default 1000000; scenes of 10 k,
 *                                    100 k, 700 k and 1 M spheres)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/clock.h"
#include "blobcast/edit.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"

#define SPHERE_ID 0x7ffffff0u

static double now_ms(void)
{
	return (double)bc_clock_ns() * 1e-6;
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

static double median(double *v, int n)
{
	qsort(v, (size_t)n, sizeof(*v), cmp_double);
	return v[n / 2];
}

static void die(const char *what)
{
	fprintf(stderr, "bench_splice: %s failed\n", what);
	exit(1);
}

/* One sphere with a chosen id at the centre of scene's box (inside it:
 * its going does not shrink the box), as a tree and as scene bytes. */
static struct bc_tree *one_sphere(const struct bc_tree *scene, uint8_t **bytes,
                                  size_t *len)
{
	struct bc_tree *t = bc_tree_create();
	const struct bc_lin *l = bc_tree_lin(scene);
	struct bc_prim_data s;
	bc_prim_data_init(&s, BC_PRIM_SPHERE);
	s.params[0] = 0.3f;
	for (int i = 0; i < 3; i++) {
		s.translate[i] = 0.5f * (l->lo[i] + l->hi[i]);
	}
	bc_tree_begin(t);
	if (bc_tree_put_prim(t, SPHERE_ID, &s, NULL) || bc_tree_end(t, NULL) ||
	    bc_scene_encode(t, NULL, bytes, len)) {
		die("building the sphere");
	}
	return t;
}

enum { REPS = 15 };

/* INSERT at pos then REMOVE, REPS times, through blobtree. */
static void tree_edits(struct bc_tree *t, const struct bc_tree *sub,
                       const char *where, uint32_t pos)
{
	double ins[REPS], rem[REPS];
	uint32_t root = bc_tree_root(t);
	for (int r = 0; r < REPS; r++) {
		double t0 = now_ms();
		if (bc_tree_insert(t, root, pos, sub, NULL)) {
			die("insert");
		}
		ins[r] = now_ms() - t0;
		t0 = now_ms();
		if (bc_tree_remove(t, SPHERE_ID, NULL)) {
			die("remove");
		}
		rem[r] = now_ms() - t0;
	}
	printf("  spliced  %-6s insert_ms=%8.3f remove_ms=%8.3f\n", where,
	       median(ins, REPS), median(rem, REPS));
}

/* REPLACE of a sphere in the middle by a sphere (same id), REPS times. */
static void tree_replace(struct bc_tree *t, const struct bc_tree *sub)
{
	double rep[REPS];
	uint32_t root = bc_tree_root(t);
	if (bc_tree_insert(t, root, bc_tree_child_count(t, root) / 2, sub,
	                   NULL)) {
		die("insert");
	}
	for (int r = 0; r < REPS; r++) {
		double t0 = now_ms();
		if (bc_tree_replace(t, SPHERE_ID, sub, NULL)) {
			die("replace");
		}
		rep[r] = now_ms() - t0;
	}
	if (bc_tree_remove(t, SPHERE_ID, NULL)) {
		die("remove");
	}
	printf("  spliced  middle replace_ms=%8.4f\n", median(rep, REPS));
}

/* The same through an undoable edit batch (the daemon's path). */
static void batch_edits(struct bc_tree **t, const uint8_t *bytes, size_t len)
{
	double ins[REPS], rem[REPS];
	struct bc_errinfo ei = {0};
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_INSERT,
	                              .node = bc_tree_root(*t),
	                              .subtree = {bytes, (uint32_t)len}};
	for (int r = 0; r < REPS; r++) {
		struct bc_edit_batch b;
		double t0;
		op.kind = BC_PROTO_EDIT_INSERT;
		op.node = bc_tree_root(*t);
		op.position = bc_tree_child_count(*t, op.node);
		t0 = now_ms();
		if (bc_edit_batch_apply_undoable(&b, t, &op, 1, &ei)) {
			die(ei.msg);
		}
		bc_edit_batch_finish(&b);
		ins[r] = now_ms() - t0;
		op.kind = BC_PROTO_EDIT_REMOVE;
		op.node = SPHERE_ID;
		t0 = now_ms();
		if (bc_edit_batch_apply_undoable(&b, t, &op, 1, &ei)) {
			die(ei.msg);
		}
		bc_edit_batch_finish(&b);
		rem[r] = now_ms() - t0;
	}
	printf("  batch    end    insert_ms=%8.3f remove_ms=%8.3f\n",
	       median(ins, REPS), median(rem, REPS));
}

/* What each edit cost before: the tree laid out whole, and a batch's copy
 * of the tree (which was laid out whole too). */
static void old_path(const struct bc_tree *t)
{
	enum { OLD = 3 };
	double lay[OLD], copy[OLD];
	struct bc_tree *c = bc_tree_create();
	for (int r = 0; r < OLD; r++) {
		double t0 = now_ms();
		if (bc_tree_copy(c, t, NULL)) {
			die("copy");
		}
		copy[r] = now_ms() - t0;
		t0 = now_ms();
		if (bc_tree_relayout(c, NULL)) {
			die("relayout");
		}
		lay[r] = now_ms() - t0;
	}
	printf("  old      full layout_ms=%8.3f  batch_copy_ms=%8.3f "
	       "(old batch edit ~ copy + layout)\n",
	       median(lay, OLD), median(copy, OLD));
	bc_tree_destroy(c);
}

int main(int argc, char **argv)
{
	static const uint32_t sizes[] = {10000, 100000, 700000, 1000000};
	uint32_t max =
	    argc > 1 ? (uint32_t)strtoul(argv[1], NULL, 10) : 1000000;
	for (size_t i = 0; i < sizeof(sizes) / sizeof(sizes[0]); i++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_gen_opts o = {.count = sizes[i], .seed = 1};
		struct bc_errinfo ei = {0};
		struct bc_tree *sub;
		uint8_t *bytes = NULL;
		size_t len = 0;
		uint32_t n;
		if (sizes[i] > max) {
			break;
		}
		if (bc_gen("many-spheres", &o, t, NULL, &ei)) {
			die(ei.msg);
		}
		sub = one_sphere(t, &bytes, &len);
		n = bc_tree_child_count(t, bc_tree_root(t));
		printf("many-spheres prims=%u\n", bc_tree_prim_count(t));
		tree_edits(t, sub, "end", n);
		tree_edits(t, sub, "start", 0);
		tree_edits(t, sub, "middle", n / 2);
		tree_replace(t, sub);
		batch_edits(&t, bytes, len);
		old_path(t);
		bc_tree_destroy(t);
		bc_tree_destroy(sub);
		bc_free(bytes);
	}
	return 0;
}
