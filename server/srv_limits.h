/*
 * Every limit of the daemon, each with the reason for its value. Limits of
 * the wire format itself live in protocol/include/blobcast/proto_limits.h;
 * these are the server's own, at or below those.
 */
#ifndef BLOBCAST_SERVER_LIMITS_H
#define BLOBCAST_SERVER_LIMITS_H

#include "blobcast/limits.h"

/* Open client connections. Each holds a reader buffer of up to one message
 * plus an output queue, and each member of a session may cost a render per
 * change; 256 is far beyond a review meeting while bounding memory. */
#define BC_SRV_MAX_CONNECTIONS 256u

/* Live (loaded) sessions. Each keeps a scene (up to BC_SRV_MAX_NODES
 * nodes, about 56 bytes a primitive in the model, 215 in the render
 * copy's layout while someone looks) and a renderer. Sessions on disk are not
 * limited: one with no members is unloaded after BC_SRV_SESSION_IDLE_MS, or at
 * once, least recently used first, when a CREATE or a JOIN needs its place; a
 * JOIN loads it again. */
#define BC_SRV_MAX_SESSIONS 64u
/* What a loaded scene's node costs the daemon with a view drawn (its
 * tree, render copy and the tiled tracer's lists: 326 bytes a primitive
 * measured on a million spheres, 350 before a union's layout slot took
 * 32 bytes, 366 before a tile's candidates were
 * those its cone can see, 370 before 12-byte layout places, 378
 * before the 52-byte pool node, 383
 * before a view's primitive took 16
 * bytes, 407 before the 56-byte pool node, 429
 * before a view's primitive took 20 bytes, 575 before a sphere's record took
 * one vec4, spheres alone kept sphere ABVs and nodes their rotations in chunks,
 * 640 before the 84-byte pool node; docs/benchmarks.md), by which
 * --scene-memory becomes a count of nodes all loaded sessions may hold;
 * by default half the memory the daemon may use (its cgroup's limit,
 * else the machine's). */
#define BC_SRV_NODE_COST 700u

/* A session with no members stays loaded this long (a member who drops and
 * reconnects finds it warm), then its memory goes back: everything it holds
 * is already on disk (journal and snapshots). Checked every
 * BC_SRV_SESSION_SWEEP_MS. */
#define BC_SRV_SESSION_IDLE_MS (15u * 60u * 1000u)
#define BC_SRV_SESSION_SWEEP_MS (60u * 1000u)

/* A session's render copy (its laid-out twin of the scene) and the
 * renderer's lists drawn from it (together about 250 bytes a primitive:
 * a million spheres at 1024x768, docs/benchmarks.md) are dropped this long
 * after a member last had a view or asked for a picture (--render-idle); the
 * next picture makes them again (the copy about 0.9 s a million primitives,
 * the session busy meanwhile). The SCENE_STATE a big session keeps encoded
 * for joiners (about 51 bytes a primitive) goes this long after it was
 * last sent. The sweep looks every BC_SRV_SESSION_SWEEP_MS, or every
 * quarter of this when that is shorter. */
#define BC_SRV_RENDER_IDLE_MS (5u * 60u * 1000u)

/* Nodes of a session's scene: the layout's own limit (22-bit ancestor
 * indices, BC_TREE_MAX_NODES), which a SCENE_LOAD under the payload limit
 * can reach. */
#define BC_SRV_MAX_NODES BC_LIMIT_NODES

/* Largest view width or height. 4096^2 RGBA is 64 MiB per rendered frame;
 * the protocol allows 8192 for future GPUs with more memory. */
#define BC_SRV_MAX_DIM 4096u
/* The features (PROTOCOL.md 4.1) this server grants when a client
 * announces them: all of this text's. */
#define BC_SRV_FEATURES BC_PROTO_FEATURES_ALL
/* Microseconds acknowledgements may come later than 1.5 times the least
 * round trip seen before frames count as queueing on the path (acks.c):
 * a client's decode and draw vary by a few milliseconds. */
#define BC_SRV_ACK_QUEUE_SLACK_US 8000u

/* Seconds a connection may take to complete its HELLO: a client that never
 * finishes one holds a slot only this long. */
#define BC_SRV_HELLO_TIMEOUT_MS 5000u

/* Time a message may take to arrive once its first byte has (after HELLO):
 * a client that trickles a message holds its reader buffer (up to a 64 MiB
 * payload) and its slot. 64 MiB over a 56 kbit/s link would take longer,
 * but a review client on such a link is not a use case; a slow network
 * still moves a full SCENE_LOAD well within it. Over it: ERROR ETIMEOUT,
 * then the connection is closed. Default of the config key
 * "message_timeout_ms". */
#define BC_SRV_MESSAGE_TIMEOUT_MS 10000u

/* Time a client that is in no session may stay silent after its HELLO (or
 * its last message): such a client holds a slot and does nothing with it.
 * Members of a session are never dropped for idling -- a viewer watches
 * quietly. Five minutes leave a person time to pick a session by hand.
 * Default of the config key "idle_timeout_ms". */
#define BC_SRV_IDLE_TIMEOUT_MS (5u * 60u * 1000u)

/* Connections from one peer address, and from one prefix (/24 of IPv4,
 * /56 of IPv6), that have not completed HELLO (Unix socket peers count as
 * one address). Honest clients send HELLO at once, so a handful suffices
 * even behind a NAT; a flood of silent connections then fills 16 slots of
 * an address, 64 of a prefix, not all BC_SRV_MAX_CONNECTIONS. Over a cap
 * the oldest such connection of the address or prefix is closed for the
 * new one (admit.c), so a client sharing a prefix with a flood still gets
 * in. */
#define BC_SRV_MAX_PREHELLO_PER_ADDR 16u
#define BC_SRV_MAX_PREHELLO_PER_PREFIX 64u

/* When every connection slot is taken and none is without HELLO, a client
 * that said HELLO, joined no session and has been silent this long is
 * closed to make room for a new connection. */
#define BC_SRV_EVICT_IDLE_MS 10000u

/* Bytes queued for one client (frames and messages not yet taken by the
 * kernel). Frames are spoiled, so only a client that stopped reading fills
 * this; 32 MiB holds several full-size PNG stills. Over it the client is
 * dropped, with the reason in the log. The default of --client-queue. */
#define BC_SRV_MAX_CLIENT_QUEUE (32u * 1024u * 1024u)

/* A TLS certificate that expires within this many days is named in the
 * log at start and at each SIGHUP reload. */
#define BC_SRV_TLS_WARN_DAYS 14

/* The most bytes of one connection's output handed to the kernel in one
 * write: a big message goes a piece per loop turn, so that copying (and
 * sealing, on TLS) a 36 MiB snapshot does not hold the loop for its whole
 * length while a fast reader drains the socket as it is filled. */
#define BC_SRV_WRITE_PIECE (256u * 1024u)
/* Pacing (net.c): a TCP client's next frame waits while the kernel holds
 * more than one frame (at least this many bytes) not yet acknowledged,
 * looking again every BC_SRV_PACE_TICK_MS. 64 KiB is about one
 * bandwidth-delay product of 10 Mbit/s at 50 ms. */
#define BC_SRV_PACE_MIN_BYTES (64u * 1024u)
#define BC_SRV_PACE_TICK_MS 4u
/* Frames that did not wait for the link before interactive frames start
 * one level finer again (frames.c, link_level). */
#define BC_SRV_LINK_CALM_FRAMES 8u
/* Below this smoothed round trip (microseconds) a connection is local: a
 * client that reads slowly there is not given coarser frames. */
#define BC_SRV_LINK_MIN_RTT_US 1000u

/* A frame larger than BC_SRV_MAX_CLIENT_QUEUE (a 2048^2 snapshot with its
 * depth and id planes, up to the protocol's payload limit) is not a
 * reason to drop its client: the cap is then the frame plus this much of
 * other messages. */
#define BC_SRV_QUEUE_BESIDE_FRAME (1024u * 1024u)

/* Largest scene, as its SCENE_STATE payload (the scene encoding plus the
 * 20 bytes before it), by default: 64 MiB, about 1.7 million spheres,
 * which is also the most a client without scenes in parts (PROTOCOL.md
 * 7.10.1) can be sent. --max-scene lowers it, or raises it up to
 * BC_SRV_MAX_SCENE_BYTES_LIMIT: a larger scene then reaches only clients
 * granted PARTS (the others are told why and closed), and costs about
 * 1.2 KB of memory a primitive. One encoding is shared by every member it
 * goes to, and a client's output queue takes one such message (or its
 * parts) beyond its cap (net.c). A SCENE_LOAD or a structural EDIT that
 * would pass it is refused (ELIMIT) before anything is applied or
 * saved. */
#define BC_SRV_MAX_SCENE_BYTES BC_PROTO_MAX_PAYLOAD
/* The most --max-scene allows: every scene of the protocol's node limit
 * (4194303 nodes: 2^21 spheres are 140 MB) fits, and the JSON snapshot of
 * one of spheres stays under what restoring reads
 * (BC_SCENE_JSON_MAX_BYTES). */
#define BC_SRV_MAX_SCENE_BYTES_LIMIT (256u * 1024u * 1024u)

/* SCENE_LOADs in parts (PROTOCOL.md 7.10.1) not finished yet, all clients
 * together, in scene bytes received: twice the scene cap, so that two
 * editors may send the largest scene at once. A part that would pass it
 * is refused (EBUSY) once the unfinished scenes that have had no part for
 * BC_SRV_PART_STALE_MS are dropped. */
#define BC_SRV_PARTS_PENDING_SCENES 2u
#define BC_SRV_PART_STALE_MS BC_SRV_MESSAGE_TIMEOUT_MS

/* A client closed with at least this many bytes still queued had large
 * frames or scenes in flight: once they are freed the daemon returns its
 * free heap to the system (malloc_trim), so RSS falls after stalled
 * members are dropped instead of staying at its peak. */
#define BC_SRV_TRIM_AFTER_BYTES (4u * 1024u * 1024u)

/* A client whose FRAME has made no progress this long (no piece taken by
 * the kernel and, while it waits for the link, no byte leaving the
 * socket) has stopped reading: it is dropped (with the reason in the log)
 * instead of holding a frame and a render slot forever. A large snapshot
 * draining through a slow link keeps moving and is not dropped. */
#define BC_SRV_STALL_MS 10000u

/* Idle time after the last change before the still (full quality) frame is
 * rendered: long enough to coalesce a burst of slider events, short enough
 * to feel immediate when the user lets go. */
#define BC_SRV_STILL_DELAY_MS 300u

/* PICK and SNAPSHOT requests of one client queued for the render workers
 * and not yet answered, SNAPSHOT answers not yet written counted (the
 * transport keeps them in order, never spoiled: this caps what it holds
 * for a client to eight answers). Frames need no such cap (a client has at most
 * one frame in flight); requests are answered in order, so a client that wants
 * more than this waits for answers first. Over it: ERROR EBUSY, not fatal.
 * Eight keep a picking or snapshotting client busy without letting it queue
 * minutes of full-size renders ahead of everyone (100 queued 4096^2
 * snapshots once held another session's client for 178 s). */
#define BC_SRV_MAX_CLIENT_REQUESTS 8u

/* MESH (meshes.c, PROTOCOL.md 7.28): meshes in the daemon at once, from
 * request to answer (one a client; over them: EBUSY), and the finest grid
 * it makes (above: ELIMIT). One thread meshes, behind the renders; two
 * keep one waiting while another is made. At 512 cells along the longest
 * side fig18's 1024 smooth spheres took 76 s beside a probe and made
 * 14.9 M triangles, a 387 MB glTF file (and as much again in the mesh
 * itself) that no message can carry (64 MiB); at 256 still 95 MB, while
 * the default scene makes 9.4 MB in a second (docs/benchmarks.md,
 * "Meshing on the daemon"). Finer is the client's to make (`blobcast
 * mesh`). */
#define BC_SRV_MESHES 2u
#define BC_SRV_MESH_MAX_RESOLUTION 256u

/* Undo history of a session: steps kept (a drag is one step) and the
 * memory they may hold (a parameter step the earlier states of its nodes;
 * a structural step the operations that undo it with the subtrees they put
 * back, counted at their encoded size: 39 bytes a sphere, 51 with a
 * colour). The oldest steps go first. A hundred steps reach back further
 * than a reviewer wants to click; 64 MiB keep all hundred when each
 * removes or replaces up to 13 000 coloured spheres, and a step that
 * replaced a whole 60 000-sphere scene (2.3 MB) takes 1/28 of it. */
#define BC_SRV_UNDO_STEPS 100u
#define BC_SRV_UNDO_BYTES (64u * 1024u * 1024u)

/* Wait before a session retries the frames it could not queue for lack of
 * memory: the clients stay owed them, and a retry at once would spin. */
#define BC_SRV_OOM_RETRY_MS 100u

/* A session's scene is written whole (and its journal restarted) after this
 * many journaled edits: replaying at most this many on start stays fast. */
#define BC_SRV_SNAPSHOT_EVERY 1000u

/* Time budget of one refinement step, milliseconds (default of
 * --frame-budget): a refinement that takes longer (its slices share the
 * workers with other sessions) sends the picture it has, complete at its
 * coarser level and flagged INCOMPLETE, and goes on in the next frame, so
 * a client sees progress at least this often. */
#define BC_SRV_FRAME_BUDGET_MS 2000u

/* ---- The render scheduler (work.c) --------------------------------------- */

/* Render workers at most (--render-threads), and the flows (a session's
 * render side) the work layer keeps: every loaded session, plus those
 * dropped and not yet freed by a worker. */
#define BC_SRV_MAX_WORKERS 64u
#define BC_SRV_MAX_FLOWS (2u * BC_SRV_MAX_SESSIONS)

/* Milliseconds of work one slice aims at: a job gives way between slices,
 * so this bounds how long a quiet session's frame waits for a free worker
 * (with two workers about half of it on average). Tiles per slice follow
 * from the session's cost model; the first slice of a job takes
 * BC_SRV_SLICE_TILES_FIRST, none more than BC_SRV_SLICE_TILES_MAX. */
#define BC_SRV_SLICE_MS 4.0
#define BC_SRV_SLICE_TILES_FIRST 8u
#define BC_SRV_SLICE_TILES_MAX 16384u

/* A slice that took this long (a new view's A-buffer of a big scene is
 * one renderer call) marks its session, and so do first slices of its
 * jobs that take this long on average: while the other workers run such
 * slices, the last one keeps to shorter work whenever some waits or
 * waited within BC_SRV_SHORT_RECENT_MS. */
#define BC_SRV_LONG_SLICE_MS 20.0
/* Short work that waited this recently counts as waiting: its session is
 * probably between two requests (an editor's drag at 20 Hz). */
#define BC_SRV_SHORT_RECENT_MS 500.0

/* How far behind the least busy session's clock a session that wakes from
 * idle may start (milliseconds of render time): a quiet session goes first
 * at once, but sleeping banks no more than this. It covers a whole
 * interactive frame of an editor's scene under load (10-25 ms of render
 * for fig18 64 at 640x480), so its slices do not interleave with a busy
 * session's: with 10 the probe of bench_fair's fairness waited 31 ms p50
 * beside three heavy sessions, with 40 it waits 23 ms. */
#define BC_SRV_WAKE_CREDIT_MS 40.0

/* A worker goes on with the job of its last slice unless another session
 * is more than this behind in render time (Linux CFS's wakeup
 * granularity): switching sessions every slice made every job of eight
 * busy sessions wait for the others' slices between its own, so each took
 * as long as all of them (processor sharing), where finishing one job
 * before the next halves the mean wait for jobs of a size. */
#define BC_SRV_GRANULARITY_MS 10.0

/* What the scheduler adds to a session's clock when its next job is a
 * still or a snapshot: interactive frames go first across sessions too,
 * and the others are delayed, never starved. */
#define BC_SRV_STILL_PENALTY_MS 5.0
#define BC_SRV_SNAPSHOT_PENALTY_MS 20.0

/* Field evaluations one ray may spend in a render slice. Ordinary rays
 * take tens to a few hundred; a legal but costly scene (twist or bend at a
 * high rate, repeat with many cells) would take millions, and a tile of
 * 64 such rays would hold a worker for minutes. Rays that run out keep the
 * coarser level's value and the frame says INCOMPLETE; later frames retry
 * those tiles with four times the bound, up to BC_SRV_RAY_EVALS_MAX, after
 * which the picture stays incomplete until the scene changes. */
#define BC_SRV_RAY_EVALS 4096u
#define BC_SRV_RAY_EVALS_MAX (64u * 1024u)
/* While most of a slice's rays run out, the session's bound drops
 * eightfold, down to this: a full-size first picture of a crawling scene
 * (800x600 rays of a twist at a rate of 10^6) then comes in about a second
 * instead of minutes, and retries raise the bound tile by tile. */
#define BC_SRV_RAY_EVALS_MIN 16u

/* Primitive evaluations of one PICK's ray (steps times primitives): a pick
 * is one ray of the whole tree, answered as a miss past this. */
#define BC_SRV_PICK_EVALS 50000000u

/* Memory a node of a render copy holds, to count queued scenes against
 * BC_SRV_FLOW_CHANGE_BYTES. */
#define BC_SRV_NODE_BYTES 256u

/* Changes queued for one session's render copy while its worker renders:
 * parameter states are merged per node, so only structural edits arriving
 * faster than frames fill this; past it the copy takes the scene whole. */
#define BC_SRV_FLOW_CHANGE_BYTES (64u * 1024u * 1024u)

/* ---- Keeping the event loop free ------------------------------------------ */

/* Nodes from which a session's heavy work leaves the loop for a task on
 * libuv's thread pool: structural edits and the undo of one, long SET
 * batches, SCENE_STATE for joiners, freeing trees. Below it they take well
 * under a millisecond. */
#define BC_SRV_HEAVY_NODES 20000u
/* An EDIT of this many SETs or more on such a scene applies on the task
 * too: 1024 SETs on 100 000 nodes took the loop 5-7 ms. */
#define BC_SRV_HEAVY_SETS 256u

/* A SCENE_LOAD payload of at least this many bytes is kept in the
 * reader's own buffer (handed over, bc_proto_reader_detach) instead of
 * copied on the loop; smaller ones are copied, cheaper than a new buffer
 * for the reader. */
#define BC_SRV_DETACH_BYTES (1024u * 1024u)

/* A request that takes longer than this on the loop is logged. */
#define BC_SRV_SLOW_REQUEST_MS 5u
/* A turn of the loop (requests, results, writes) longer than this is
 * logged at info, with the CPU time it used. */
#define BC_SRV_SLOW_TURN_MS 20u
/* A connection's share of one loop turn: past it, with more of its
 * messages waiting, it reads no more until the next turn (a 1024-SET EDIT
 * on 100 000 nodes takes about 5 ms; four in one read held others' PINGs
 * 30 ms). */
#define BC_SRV_READ_SHARE_MS 2u

/* A SESSION_CAMERA makes the server send the whole scene to every member
 * that does not know SESSION_CAMERA_SET (PROTOCOL.md 7.25); in a session
 * with such members it is taken at most once in this many milliseconds
 * (EBUSY otherwise), so a 40-byte request cannot make the server send
 * scenes without a bound. */
#define BC_SRV_CAMERA_STATE_MS 1000u

/* SIGTERM and SIGINT: the daemon exits within BC_SRV_STOP_MS whatever is
 * running; it spends at most BC_SRV_STOP_SAVE_MS writing snapshots (the
 * rest stays in journals) and waits BC_SRV_STOP_WORKERS_MS for render
 * workers to leave their slices. */
#define BC_SRV_STOP_MS 1800u
#define BC_SRV_STOP_SAVE_MS 1000u
#define BC_SRV_STOP_WORKERS_MS 300u

/* Views whose planes (colour, 4 bytes a pixel; depth and ids only for a
 * snapshot that asks for them) the work layer keeps for damage renders
 * and refinement: a few per member of a busy session, least recently
 * used dropped first, and at most BC_SRV_VIEW_BYTES in all, the
 * renderers' own per-view state counted in. */
#define BC_SRV_MAX_VIEWS 32u
#define BC_SRV_VIEW_BYTES (384u * 1024u * 1024u)
/* What a renderer keeps per pixel of the view it last drew (the tiled
 * backend: its tile lists and per-tile state, 2.9-5.1 bytes a pixel
 * measured for the default scene and fig18 with 1 024 spheres, 640x480
 * to 2048^2; it kept 12 more of ray directions before the tracer made
 * them per tile): counted against BC_SRV_VIEW_BYTES before a new view is
 * drawn, so that the cap holds while it is built. Big scenes keep more
 * (lists per primitive), counted once drawn. */
#define BC_SRV_RENDERER_BYTES_PX 6u

/* Milliseconds the first, coarse picture of a new view should take: the
 * worker picks the finest level its cost model says fits, so a
 * camera drag shows a complete picture at about 10 frames a second. */
#define BC_SRV_COARSE_MS 60.0

/* A damage over this percentage of a view's tiles starts a new coarse
 * picture instead of re-rendering the tiles at full resolution: beyond
 * it the damage render costs about as much as a whole frame. */
#define BC_SRV_DAMAGE_PCT 40u

/* An edit whose subtree holds more primitives than this damages whole
 * views without projecting each ABV (an operator near the root). */
#define BC_SRV_DAMAGE_PRIMS 4096u

/* Length of a session name as a directory name under the data directory:
 * letters, digits, '-', '_' and '.', not starting with '.'. */
#define BC_SRV_MAX_SESSION_NAME 64u

/* The server's limits stay within the wire's: WELCOME announces them in
 * fields whose ranges PROTOCOL.md fixes, and a session name must be one
 * the protocol can carry. */
#include "blobcast/proto_limits.h"
_Static_assert(BC_SRV_MAX_DIM >= 1 && BC_SRV_MAX_DIM <= BC_PROTO_MAX_DIM,
               "WELCOME max_dim is 1..BC_PROTO_MAX_DIM");
_Static_assert(BC_SRV_MAX_SESSION_NAME == BC_PROTO_MAX_NAME,
               "a session directory holds any session name the wire carries");
_Static_assert(BC_SRV_MAX_NODES <= BC_LIMIT_NODES,
               "WELCOME max_nodes within the layout's limit");

#endif
