/*
 * Every limit of the wire protocol, in one place, each with the reason for
 * its value. The decoder checks each of them before it allocates or copies
 * anything, PROTOCOL.md lists them in its "Limits" table, and the test
 * vectors probe each boundary (the limit itself and one past it).
 *
 * A few values mirror limits of other modules (blobtree, render). The
 * protocol must not include those headers, so the values are repeated here
 * and edit/fields.c (compiled in every build) and tests/protocol assert at
 * compile time that they still agree. proto_fields.h asserts the ones that
 * follow from its table of SET fields.
 */
#ifndef BLOBCAST_PROTO_LIMITS_H
#define BLOBCAST_PROTO_LIMITS_H

#include "blobcast/limits.h"

/* ---- Framing ------------------------------------------------------------ */

/* Largest payload of any message after HELLO. It holds the SCENE_LOAD of a
 * 10^6-node scene whose nodes average up to 67 bytes, which covers every
 * binary tree of 10^6 nodes even with the largest primitive records (500 000
 * primitives of 79 bytes plus 500 000 operators of 17 bytes = 48 MB), and a
 * raw RGBA frame of 4096 x 4096. Bigger scenes travel in parts
 * (PROTOCOL.md 7.10.1, BC_PROTO_MAX_SCENE_BYTES). A reader buffers at most one
 * message, so this is also the memory an authenticated peer can make the daemon
 * hold per connection. */
#define BC_PROTO_MAX_PAYLOAD (64u * 1024u * 1024u)

/* Most bytes of one scene sent in parts (PROTOCOL.md 7.10.1), the sum of
 * its parts' pieces. It holds every scene of the node limit
 * (BC_PROTO_SCENE_MAX_NODES): 2^21 primitives of 79 bytes, as many
 * operators of 17 bytes and a name of 64 bytes for every node come to
 * 500 MB. A receiver refuses a scene that would pass it (EPROTO_LENGTH)
 * before it buffers the part. */
#define BC_PROTO_MAX_SCENE_BYTES (1024u * 1024u * 1024u)

/* Largest payload accepted before the peer has said HELLO. The longest
 * valid HELLO is 1101 bytes (its strings at their limits); 4 KiB leaves room
 * and keeps what an unauthenticated peer can make the daemon buffer small. */
#define BC_PROTO_HELLO_MAX_PAYLOAD 4096u

/* Bytes a reader accepts beyond one whole message of the largest allowed
 * size. A caller that drains the reader with next() after every read holds
 * at most one partial message plus one read; 1 MiB covers the largest read
 * buffer a caller sensibly uses. More than that means the caller stopped
 * draining, and the reader refuses to grow without bound. */
#define BC_PROTO_READ_SLACK (1024u * 1024u)

/* ---- Strings --------------------------------------------------------------
 */

/* Client names, session names and the server id: shown in member lists and
 * logs, where 64 bytes (at least 16 characters of any script) is plenty. */
#define BC_PROTO_MAX_NAME 64u

/* Authentication tokens: a 256-bit key in hex is 64 bytes and a signed JWT
 * is typically 300-900; 1024 holds both while keeping HELLO under its
 * pre-HELLO payload limit. */
#define BC_PROTO_MAX_TOKEN 1024u

/* The human sentence of an ERROR: long enough for a reason naming a node,
 * a field and a value, short enough that an error never costs much. */
#define BC_PROTO_MAX_ERROR_TEXT 1024u

/* ---- Sessions -------------------------------------------------------------
 */

/* Members listed in SESSION_INFO, hence the most clients one session can
 * have: a design review rarely has more than a dozen people, and every
 * member costs the server one render per camera change. */
#define BC_PROTO_MAX_MEMBERS 64u

/* Sessions one SESSIONS answer lists: a server with more lists the first
 * this many by name. A listing is for people choosing a session; 1024
 * entries of at most 89 bytes keep the answer under 92 KB. */
#define BC_PROTO_MAX_SESSIONS_LISTED 1024u

/* Changes one HISTORY answer lists: a server keeps at most 100 steps to
 * undo and 100 to redo (PROTOCOL.md 7.20), and a list longer than that is
 * more than a person reads. */
#define BC_PROTO_MAX_HISTORY 200u

/* MESH resolution: blobcast mesh's largest grid (blobtree's
 * BC_MESH_MAX_RESOLUTION); 0 in a MESH asks for the default. */
#define BC_PROTO_MAX_MESH_RESOLUTION 4096u
/* ... and the least: two cells of margin each way and one of scene. */
#define BC_PROTO_MIN_MESH_RESOLUTION 5u
#define BC_PROTO_MESH_DEFAULT_RESOLUTION 128u
/* A HISTORY entry's description ("SET node 12 translate, rotate"). */
#define BC_PROTO_MAX_HISTORY_TEXT 128u

/* ---- Frames and views ------------------------------------------------------
 */

/* Largest frame width or height: the renderers' BC_RENDER_MAX_DIM, both
 * BC_LIMIT_DIM (blobcast/limits.h says why). */
#define BC_PROTO_MAX_DIM BC_LIMIT_DIM

/* Smallest FRAME payload limit a client may announce in HELLO (other than 0,
 * "the server's limit"): below 64 KiB even a modest JPEG does not fit, and
 * the server would have to drop every frame. */
#define BC_PROTO_MIN_FRAME_BYTES (64u * 1024u)

/* Rectangles in one FRAME. The server sends damaged 8x8 tiles merged into
 * rectangles; past 4096 (a 64 x 64 grid) one full-frame rectangle is cheaper
 * to encode and to draw than many small ones. */
#define BC_PROTO_MAX_RECTS 4096u

/* Largest VIEW downscale: the coarsest block (pixels per side) a client
 * accepts in a refinement frame, so 2^BC_PROTO_MAX_LEVEL. Beyond 1/8 of the
 * resolution a moving image carries too little to be useful. */
#define BC_PROTO_MAX_DOWNSCALE 8u

/* JPEG quality, as TurboJPEG takes it (1 worst .. 100 best). */
#define BC_PROTO_MAX_QUALITY 100u
/* Largest width or height of an H.264 view (encoding 4): the widest
 * picture NVENC codes in H.264 and browsers' decoders take. */
#define BC_PROTO_MAX_VIDEO_DIM 4096u
/* Largest H.264 view in 16 x 16 macroblocks, its sides rounded up to even
 * numbers: MaxFS of levels 5.1 and 5.2 (4096 x 2304), the highest levels
 * hardware decoders and WebCodecs reliably support. */
#define BC_PROTO_MAX_VIDEO_MBS 36864u

/* ---- Edits ----------------------------------------------------------------
 */

/* Operations in one EDIT. A slider drag sends one per message; tools that
 * move a selection send one per selected node. The server applies a batch
 * within one frame, and 1024 parameter edits take well under a millisecond. */
#define BC_PROTO_MAX_EDIT_OPS 1024u

/* Fields in one set-parameters operation: there are 14 field numbers
 * (translate, rotate, colour, 8 shape parameters, blend, range, operator
 * kind) and each may appear once. */
#define BC_PROTO_MAX_SET_FIELDS 14u

/* Values of one field: a rotation quaternion is the widest (4). */
#define BC_PROTO_MAX_FIELD_VALUES 4u

/* Shape parameters of a primitive (field numbers 16..23; floats of a
 * primitive record in the scene encoding); equals BC_PRIM_MAX_PARAMS. */
#define BC_PROTO_MAX_PRIM_PARAMS 8u

/* Largest |value| of a coordinate or parameter carried by an EDIT, a CAMERA
 * or a PICK_RESULT; equals BC_PARAM_MAX_ABS (squared distances stay far from
 * float overflow). */
#define BC_PROTO_MAX_ABS 1.0e6f

/* ---- Scene encoding (documented here, validated by blobtree/) --------------
 */

/* Nodes of a scene; equals BC_TREE_MAX_NODES (the GPU node word has a
 * 22-bit ancestor field whose all-ones value means "none"). */
#define BC_PROTO_SCENE_MAX_NODES BC_LIMIT_NODES

/* Nodes on any path from the root, the root counting 1; equals
 * BC_TREE_MAX_DEPTH. Decoders keep per-level state on the heap, so deep
 * chains (programs emit them; Lipschitz Pruning's Molecule is 1001 levels)
 * cost memory per node, never C stack; evaluation stacks are bounded
 * separately (docs/scene-format.md). */
#define BC_PROTO_SCENE_MAX_DEPTH (1u << 20)

#endif
