/*
 * libFuzzer harness for the JSON scene reader (bc_scene_parse_json). Oracle:
 * a refused input has a reason and leaves the tree empty; an accepted one
 * writes back to text that parses again into the same structure (ids,
 * counts, kinds), and encodes to binary bytes that decode to it too.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void die(const char *why)
{
	fprintf(stderr, "fuzz_scene_json: %s\n", why);
	abort();
}

/* Same ids in the same pre-order, with the same kinds and child counts. */
static void check_same_shape(const struct bc_tree *a, const struct bc_tree *b)
{
	struct bc_scene_walk wa, wb;
	struct bc_scene_node na, nb;
	if (bc_tree_node_count(a) != bc_tree_node_count(b) ||
	    bc_tree_prim_count(a) != bc_tree_prim_count(b) ||
	    bc_tree_root(a) != bc_tree_root(b)) {
		die("counts or root differ after a round trip");
	}
	if (bc_scene_walk_init(&wa, a) || bc_scene_walk_init(&wb, b)) {
		die("walk failed");
	}
	while (bc_scene_walk_next(&wa, &na)) {
		if (!bc_scene_walk_next(&wb, &nb) || na.id != nb.id ||
		    na.is_op != nb.is_op || na.nchildren != nb.nchildren ||
		    (na.is_op ? na.op.kind != nb.op.kind
		              : na.prim.kind != nb.prim.kind)) {
			die("node differs after a round trip");
		}
	}
	bc_scene_walk_finish(&wa);
	bc_scene_walk_finish(&wb);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct bc_tree *t = bc_tree_create(), *u = bc_tree_create();
	struct bc_camera cam, cu;
	struct bc_errinfo ei = {0};
	char *text = NULL;
	uint8_t *bytes = NULL;
	size_t len = 0;
	int rc;
	if (!t || !u) {
		die("out of memory");
	}
	rc = bc_scene_parse_json((const char *)data, size, t, &cam, &ei);
	if (rc < 0) {
		if (ei.code != rc || ei.msg[0] == '\0') {
			die("refusal without a reason");
		}
		if (bc_tree_node_count(t) != 0 || bc_tree_root(t) != 0) {
			die("a refused scene left nodes behind");
		}
		goto done;
	}
	if (rc != 0) {
		die("positive return");
	}
	text = bc_scene_to_json(t, &cam);
	if (!text) {
		die("an accepted scene does not write");
	}
	if (bc_scene_parse_json(text, strlen(text), u, &cu, &ei) != 0) {
		fprintf(stderr, "%s\n", ei.msg);
		die("written text does not parse");
	}
	check_same_shape(t, u);
	if (bc_scene_encode(t, &cam, &bytes, &len) != 0) {
		die("an accepted scene does not encode");
	}
	if (bc_scene_decode(bytes, len, u, NULL, NULL, &ei) != 0) {
		fprintf(stderr, "%s\n", ei.msg);
		die("encoded scene does not decode");
	}
	check_same_shape(t, u);
done:
	bc_free(text);
	bc_free(bytes);
	bc_tree_destroy(t);
	bc_tree_destroy(u);
	return 0;
}
