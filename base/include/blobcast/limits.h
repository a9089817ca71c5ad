/*
 * Limits that more than one module must agree on, each with the reason for
 * its value. A module's own header defines its name for the limit from the
 * one here (BC_TREE_MAX_NODES, BC_PROTO_SCENE_MAX_NODES, BC_SRV_MAX_NODES
 * are all BC_LIMIT_NODES), so the value is written once, and the #error
 * checks below keep the relations between limits true whenever one of
 * them is changed (SQLite's sqliteLimit.h).
 */
#ifndef BLOBCAST_LIMITS_H
#define BLOBCAST_LIMITS_H

/* Nodes of a scene. Linearized nodes are addressed by the 22-bit ancestor
 * field of the GPU node word (paper §7), whose all-ones value means "no
 * ancestor", so the largest index a real node may have is 2^22 - 2. */
#define BC_LIMIT_NODES ((1u << 22) - 1u)

/* Largest frame width or height anywhere (render, protocol). A frame of
 * 8192 x 8192 RGBA is 256 MiB: the most one render may hold. */
#define BC_LIMIT_DIM 8192u

/* ---- Relations --------------------------------------------------------- */

/* Node indices, including the "none" value, fit the 22-bit field. */
#if BC_LIMIT_NODES > (1u << 22) - 1u
#error "BC_LIMIT_NODES must leave the all-ones 22-bit value for 'none'"
#endif

/* Frame sizes travel as uint16 in the protocol (VIEW, FRAME). */
#if BC_LIMIT_DIM > 65535u
#error "BC_LIMIT_DIM must fit the protocol's 16-bit width and height"
#endif

/* A width times a height times 4 bytes of RGBA fits in 32 bits, which the
 * tile and plane arithmetic of the renderers relies on. */
#if BC_LIMIT_DIM > 32768u
#error "BC_LIMIT_DIM^2 * 4 must fit in 32 bits"
#endif

#endif
