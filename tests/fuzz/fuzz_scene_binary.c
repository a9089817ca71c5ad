/*
 * libFuzzer harness for the binary scene decoder, as a scene (flags and
 * camera first) and as a bare tree. Oracle: a refused input has a reason
 * and leaves the tree empty; an accepted one encodes to bytes of the same
 * length that decode again to the same structure, and writes to JSON that
 * parses back. Then as a binary scene file: the input itself (a header of
 * its own, mostly refused), and the input behind a good header, which
 * must get the very verdict the bare scene got. The count read from an
 * accepted scene's head (bc_scene_head_count) must be its node count.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/bytes.h"
#include "blobcast/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void die(const char *why)
{
	fprintf(stderr, "fuzz_scene_binary: %s\n", why);
	abort();
}

static void check_refusal(int rc, const struct bc_errinfo *ei,
                          const struct bc_tree *t)
{
	if (rc > 0 || (rc < 0 && (ei->code != rc || ei->msg[0] == '\0'))) {
		die("refusal without a reason");
	}
	if (rc < 0 && (bc_tree_node_count(t) != 0 || bc_tree_root(t) != 0)) {
		die("a refused scene left nodes behind");
	}
}

/* Re-encodes an accepted tree and checks the bytes decode to it. */
static void check_accepted(const struct bc_tree *t, const struct bc_camera *cam,
                           size_t in_len, bool scene)
{
	struct bc_tree *u = bc_tree_create();
	struct bc_errinfo ei = {0};
	uint8_t *bytes = NULL;
	size_t len = 0;
	char *text;
	int rc = scene ? bc_scene_encode(t, cam, &bytes, &len)
	               : bc_tree_encode(t, &bytes, &len);
	if (!u || rc != 0) {
		die("an accepted scene does not encode");
	}
	/* Fields are fixed-size: the same scene takes the same bytes. */
	if (len != in_len) {
		die("re-encoding changed the length");
	}
	rc = scene ? bc_scene_decode(bytes, len, u, NULL, NULL, &ei)
	           : bc_tree_decode(bytes, len, u, &ei);
	if (rc != 0) {
		fprintf(stderr, "%s\n", ei.msg);
		die("re-encoded scene does not decode");
	}
	if (bc_tree_node_count(u) != bc_tree_node_count(t) ||
	    bc_tree_root(u) != bc_tree_root(t)) {
		die("round trip changed the tree");
	}
	text = bc_scene_to_json(t, cam);
	if (!text || bc_scene_parse_json(text, strlen(text), u, NULL, &ei)) {
		die("accepted scene does not survive JSON");
	}
	bc_free(text);
	bc_free(bytes);
	bc_tree_destroy(u);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_camera cam;
	struct bc_errinfo ei = {0};
	bool has = false;
	int rc;
	if (!t) {
		die("out of memory");
	}
	int scene_rc;
	uint8_t *file;
	rc = scene_rc = bc_scene_decode(data, size, t, &cam, &has, &ei);
	check_refusal(rc, &ei, t);
	if (rc == 0) {
		check_accepted(t, has ? &cam : NULL, size, true);
		/* What the daemon sizes the scene by, from its head. */
		if (bc_scene_head_count(data,
		                        size < BC_SCENE_HEAD_MAX_BYTES
		                            ? size
		                            : BC_SCENE_HEAD_MAX_BYTES,
		                        size) != bc_tree_node_count(t)) {
			die("the head's count is not the decoded scene's");
		}
	} else if (bc_scene_head_count(data, size, size) >
	           size / BC_SCENE_NODE_MIN_BYTES) {
		die("the head's count passes the bytes");
	}
	memset(&ei, 0, sizeof(ei));
	check_refusal(bc_scene_file_decode(data, size, t, NULL, &ei), &ei, t);
	if (size <= BC_SCENE_FILE_MAX_BYTES &&
	    (file = bc_malloc(size + BC_SCENE_FILE_HEADER))) {
		memcpy(file, BC_SCENE_FILE_MAGIC, 4);
		bc_put_le32(file + 4, (uint32_t)size);
		bc_put_le32(file + 8, (uint32_t)crc32(0L, data, (uInt)size));
		memcpy(file + BC_SCENE_FILE_HEADER, data, size);
		memset(&ei, 0, sizeof(ei));
		rc = bc_scene_file_decode(file, size + BC_SCENE_FILE_HEADER, t,
		                          NULL, &ei);
		check_refusal(rc, &ei, t);
		if (rc != scene_rc) {
			die("a scene file's verdict is not its scene's");
		}
		bc_free(file);
	}
	memset(&ei, 0, sizeof(ei));
	rc = bc_tree_decode(data, size, t, &ei);
	check_refusal(rc, &ei, t);
	if (rc == 0) {
		check_accepted(t, NULL, size, false);
	}
	bc_tree_destroy(t);
	return 0;
}
