/*
 * Scene encodings: the JSON scene file (version 1) and the compact binary
 * form that SCENE_LOAD and SCENE_STATE carry. Both are untrusted input: every
 * length, count, depth and number is checked before anything is allocated or
 * built, and every failure comes back as a BC_E* code with a sentence naming
 * where (the JSON path, or the binary node index) and why.
 *
 * docs/scene-format.md is the reference for both formats; PROTOCOL.md quotes
 * the binary one. Decoders rebuild the caller's tree through the public
 * builder (bc_tree_begin ... bc_tree_end): on success it holds the scene, on
 * failure it is left empty (decode into a scratch tree to keep the old scene
 * when a load fails).
 */
#ifndef BLOBCAST_SCENE_H
#define BLOBCAST_SCENE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/export.h"

/* The JSON format version this build reads and writes ("blobcast": 1). */
#define BC_SCENE_JSON_VERSION 1

/* Largest scene file accepted, in bytes. The largest generated scene (fig16
 * level 6: 1.1 M primitives) is 289 MB of JSON, which this admits with room
 * to spare; jansson holds about eleven times the text size while a file is
 * parsed (docs/benchmarks.md), so the ceiling also keeps a hostile file
 * near 4 GB of memory. Scenes sent over the network use the binary form,
 * which is bounded by the protocol's message limit. */
#define BC_SCENE_JSON_MAX_BYTES (384u * 1024u * 1024u)

/* Nesting a JSON scene file can carry: nodes on a path, the root counting
 * 1. jansson's parser stops at JSON_PARSER_MAX_DEPTH = 2048 nested values
 * (a compile-time constant of the library, 2.14 in Debian; scalars count
 * as a level), and a scene node at depth d sits at JSON depth 2d (an object
 * in a "children" array) with its vectors' numbers at 2d + 2. So 1023
 * levels read back through any jansson build, which holds Lipschitz
 * Pruning's 1001-deep Molecule as it is. Deeper trees (up to
 * BC_TREE_MAX_DEPTH) travel in the binary form; the JSON writer refuses
 * them rather than write a file no reader takes. */
#define BC_SCENE_JSON_MAX_DEPTH 1023u

/* Smallest encoded node: a u8 tag and a u32 id. Decoders check every count
 * against the bytes left divided by this before looping or allocating. */
#define BC_SCENE_NODE_MIN_BYTES 5u

/* Flags byte of the binary scene: a camera follows the flags; a names
 * table follows the tree (PROTOCOL.md 8). */
#define BC_SCENE_FLAG_CAMERA 0x01u
#define BC_SCENE_FLAG_NAMES 0x02u
/* The camera a scene's flags announce: eye, target, up, fov_y_deg (ten
 * little-endian f32). */
#define BC_SCENE_CAMERA_BYTES 40u
/* Bytes from a binary scene's start to the end of its node count, at
 * most: flags, camera, node_count (bc_scene_head_count). */
#define BC_SCENE_HEAD_MAX_BYTES (1u + BC_SCENE_CAMERA_BYTES + 4u)
/* Smallest names table entry: id, length and one byte. */
#define BC_SCENE_NAME_MIN_BYTES 7u
/* Tag bit that marks an operator node in the binary form. */
#define BC_SCENE_TAG_OP 0x80u

/* ---- JSON --------------------------------------------------------------- */

/*
 * Parses a version-1 scene from text[0..len) (need not be NUL-terminated)
 * into t, and its camera into *cam (bc_camera_default() when the file has
 * none; cam may be NULL). Strict: unknown keys, wrong types, missing keys,
 * non-finite numbers, nesting over BC_SCENE_JSON_MAX_DEPTH and texts over
 * BC_SCENE_JSON_MAX_BYTES are errors. Returns 0 or a BC_E* code with the
 * JSON path and reason in ei.
 */
BC_API int bc_scene_parse_json(const char *text, size_t len, struct bc_tree *t,
                               struct bc_camera *cam, struct bc_errinfo *ei);
/* Reads the file at path (refusing files over BC_SCENE_JSON_MAX_BYTES before
 * reading them) and parses it as bc_scene_parse_json() does. */
BC_API int bc_scene_load_json(const char *path, struct bc_tree *t,
                              struct bc_camera *cam, struct bc_errinfo *ei);

/*
 * Writes t (and cam, when not NULL) as a version-1 scene. Every id and every
 * float is written so that parsing it back reproduces the tree and camera
 * bit for bit; optional fields equal to their defaults are left out (see
 * docs/scene-format.md). Returns a NUL-terminated bc_malloc'd string the
 * caller bc_free's, or NULL when t is empty, nests deeper than
 * BC_SCENE_JSON_MAX_DEPTH (bc_tree_nesting) or memory runs out.
 */
BC_API char *bc_scene_to_json(const struct bc_tree *t,
                              const struct bc_camera *cam);
/* Receives a scene's text in pieces: returns 0 to go on, or an error code
 * that stops the writing and is returned by the writer. */
typedef int (*bc_scene_sink)(void *ctx, const void *bytes, size_t len);
/* Hands bc_scene_to_json()'s text to sink in pieces of about 256 KiB,
 * holding no more of it in memory (a million primitives are some 170 MB
 * of text). Returns 0, BC_EINVAL (empty tree), BC_EDEPTH, BC_ENOMEM, or
 * the sink's error. */
BC_API int bc_scene_write_json(const struct bc_tree *t,
                               const struct bc_camera *cam, bc_scene_sink sink,
                               void *ctx);
/* Writes bc_scene_to_json()'s text to path atomically: a temporary file in
 * the same directory, fsync, rename over path, fsync of the directory.
 * Returns 0, BC_EINVAL (empty tree), BC_ENOMEM or BC_EIO with the reason. */
BC_API int bc_scene_save_json(const char *path, const struct bc_tree *t,
                              const struct bc_camera *cam,
                              struct bc_errinfo *ei);

/* The built-in scene: a small colourful composition that shows primitives of
 * several kinds and sharp and smooth operators, framed by its camera. A
 * static NUL-terminated string, never to be freed. */
BC_API const char *bc_scene_default_json(void);

/* ---- Binary ------------------------------------------------------------- */

/*
 * scene := u8 flags, [camera: 10 x f32] if flags & BC_SCENE_FLAG_CAMERA, tree
 * tree  := u32 node_count, node_count nodes in pre-order
 * (docs/scene-format.md gives every field). Little-endian, no padding.
 *
 * Encoders return 0, BC_EINVAL (empty tree) or BC_ENOMEM; on success *out is
 * a bc_malloc'd buffer of *len bytes the caller bc_free's. *out and *len are
 * reset on entry.
 */
BC_API int bc_scene_encode(const struct bc_tree *t, const struct bc_camera *cam,
                           uint8_t **out, size_t *len);
BC_API int bc_tree_encode(const struct bc_tree *t, uint8_t **out, size_t *len);
/* Hands bc_scene_encode()'s bytes to sink (scene.h's JSON section) in
 * pieces of about 256 KiB, holding no more of them in memory. Returns 0,
 * BC_EINVAL (empty tree), BC_ENOMEM, or the sink's error. */
BC_API int bc_scene_write_binary(const struct bc_tree *t,
                                 const struct bc_camera *cam,
                                 bc_scene_sink sink, void *ctx);
/* bc_scene_encode after head zero bytes for the caller to fill (a message's
 * header): *out holds *len bytes, the encoding from (*out)[head] on. A
 * sender that frames a big scene then copies none of it. */
BC_API int bc_scene_encode_after(const struct bc_tree *t,
                                 const struct bc_camera *cam, size_t head,
                                 uint8_t **out, size_t *len);

/*
 * Decodes exactly buf[0..len) (trailing bytes are an error). bc_scene_decode
 * sets *has_camera (may be NULL) and, when the scene carries a camera, *cam
 * (may be NULL; otherwise bc_camera_default()). Nodes with id 0 get fresh ids
 * that no other node of the encoding uses. Returns 0 or a BC_E* code
 * (BC_EPROTO_TRUNCATED, BC_EPROTO_TRAILING, BC_EPROTO_COUNT,
 * BC_EPROTO_FLAGS, BC_EENUM, BC_ENONFINITE, BC_EDEPTH, BC_EDUPID, BC_ERANGE,
 * BC_ELIMIT, BC_ENOMEM) with the node index and reason in ei.
 */
BC_API int bc_scene_decode(const uint8_t *buf, size_t len, struct bc_tree *t,
                           struct bc_camera *cam, bool *has_camera,
                           struct bc_errinfo *ei);
BC_API int bc_tree_decode(const uint8_t *buf, size_t len, struct bc_tree *t,
                          struct bc_errinfo *ei);
/*
 * The node count a binary scene of total bytes announces, read from its
 * first len bytes (head; len may be less than total: the start of a scene
 * that comes in parts): the count bc_scene_decode would build, checked
 * against the bytes as it checks it (at most BC_TREE_MAX_NODES, at
 * BC_SCENE_NODE_MIN_BYTES a node). 0 when head ends before the count or
 * the bytes could not hold that many nodes (the decoder refuses those);
 * nothing else is checked. For sizing what a scene will take before
 * decoding it.
 */
BC_API uint32_t bc_scene_head_count(const uint8_t *head, size_t len,
                                    size_t total);

/* ---- Scene files -------------------------------------------------------- */

/*
 * A binary scene file: "BCS1", u32 length, u32 CRC32 (zlib's) of what
 * follows, then the scene's binary encoding above with its camera
 * (docs/scene-format.md, "Binary scene file"). A million spheres are
 * about 40 MB of it against 167 MB of JSON, and read back in a twentieth
 * of the time; the daemon keeps its sessions' snapshots in it.
 */
#define BC_SCENE_FILE_MAGIC "BCS1"
#define BC_SCENE_FILE_HEADER 12u
/* The largest encoding a scene file holds (a scene as the protocol
 * carries it is at most 64 MiB a message, 256 MiB a daemon's scene). */
#define BC_SCENE_FILE_MAX_BYTES (384u * 1024u * 1024u)

/* t (and cam, when not NULL) as a binary scene file's bytes: a
 * bc_malloc'd buffer the caller bc_free's. Returns 0, BC_EINVAL (empty
 * tree), BC_ELIMIT (over BC_SCENE_FILE_MAX_BYTES) or BC_ENOMEM. */
BC_API int bc_scene_file_encode(const struct bc_tree *t,
                                const struct bc_camera *cam, uint8_t **out,
                                size_t *len);
/* Reads a binary scene file's bytes into t (reset first) and *cam (may be
 * NULL; bc_camera_default() when the scene has none). Returns 0,
 * BC_EPARSE (no such header, a length that is not the file's, or a
 * checksum that does not match: a damaged file), or bc_scene_decode's
 * errors, with the reason in ei. */
BC_API int bc_scene_file_decode(const uint8_t *buf, size_t len,
                                struct bc_tree *t, struct bc_camera *cam,
                                struct bc_errinfo *ei);
/* Writes t as a binary scene file to fd, a new empty file open for
 * writing (and reading: the header, written last, goes at its start with
 * pwrite), the scene streamed as bc_scene_write_binary() hands it.
 * Returns 0, BC_EINVAL (empty tree), BC_ELIMIT (over
 * BC_SCENE_FILE_MAX_BYTES), BC_ENOMEM, or BC_EIO with errno set. */
BC_API int bc_scene_file_write_fd(int fd, const struct bc_tree *t,
                                  const struct bc_camera *cam);
/* Writes t as a binary scene file at path, atomically as
 * bc_scene_save_json() does. Returns 0, BC_EINVAL, BC_ELIMIT, BC_ENOMEM or
 * BC_EIO with the reason. */
BC_API int bc_scene_save_binary(const char *path, const struct bc_tree *t,
                                const struct bc_camera *cam,
                                struct bc_errinfo *ei);
/* Reads the binary scene file at path (refusing one over
 * BC_SCENE_FILE_MAX_BYTES before reading it) as bc_scene_file_decode()
 * does. */
BC_API int bc_scene_load_binary(const char *path, struct bc_tree *t,
                                struct bc_camera *cam, struct bc_errinfo *ei);
/* Reads the scene file at path, binary (it starts with
 * BC_SCENE_FILE_MAGIC: bc_scene_load_binary) or JSON (bc_scene_load_json),
 * into t and *cam. */
BC_API int bc_scene_load_file(const char *path, struct bc_tree *t,
                              struct bc_camera *cam, struct bc_errinfo *ei);

/* Number of floats a primitive of kind carries in its binary node (the
 * extent of its bc_prim_info parameter layout); 0 for an invalid kind. */
BC_API uint32_t bc_scene_prim_nfloats(enum bc_prim kind);

/* ---- Pre-order walk ------------------------------------------------------ */

/*
 * Visits every node of a built tree in pre-order (the order of both
 * encodings) in time linear in the tree size, however wide its operators
 * are, and without memory of its own: it follows the model's child lists
 * (so it needs no layout: a bare tree walks too).
 */
struct bc_scene_node {
	uint32_t id;
	uint32_t index;     /* pre-order index, 0 at the root */
	uint32_t depth;     /* 0 at the root */
	uint32_t nchildren; /* 0 for primitives */
	/* Operators completed by this node: how many open operators this node
	 * is the last descendant of (always 0 for an operator). */
	uint32_t closes;
	bool is_op;
	struct bc_prim_data prim; /* when !is_op */
	struct bc_op_data op;     /* when is_op */
	/* When is_op and op.kind is unary (nchildren 1): its parameters. */
	struct bc_unary unary;
};

struct bc_scene_walk {
	const struct bc_tree *t;
	uint32_t top;   /* where the walk started (model index) */
	uint32_t next;  /* the node visited next, BC_NONE after the last */
	uint32_t depth; /* next's depth below top */
	uint32_t index;
};

/* Starts a walk over t (which must stay unchanged during the walk). Returns
 * 0 or BC_EINVAL (empty or unfinished tree). */
BC_API int bc_scene_walk_init(struct bc_scene_walk *w, const struct bc_tree *t);
/* The same over the subtree of node id only (depths from it, 0), in time
 * of that subtree. Returns 0 or BC_EINVAL (no such node). */
BC_API int bc_scene_walk_init_at(struct bc_scene_walk *w,
                                 const struct bc_tree *t, uint32_t id);
/* Fills *out with the next node; returns false after the last one. */
BC_API bool bc_scene_walk_next(struct bc_scene_walk *w,
                               struct bc_scene_node *out);
/* Ends the walk (it holds no memory; kept for callers that stop early);
 * accepts a zeroed walk. */
BC_API void bc_scene_walk_finish(struct bc_scene_walk *w);

#endif
