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
 * nodes, about 200 bytes a primitive in the model and its layout) and a
 * renderer. Sessions on disk are not limited: one with no members is
 * unloaded after BC_SRV_SESSION_IDLE_MS, or at once, least recently used
 * first, when a CREATE or a JOIN needs its place; a JOIN loads it again. */
#define BC_SRV_MAX_SESSIONS 64u

/* A session with no members stays loaded this long (a member who drops and
 * reconnects finds it warm), then its memory goes back: everything it holds
 * is already on disk (journal and snapshots). Checked every
 * BC_SRV_SESSION_SWEEP_MS. */
#define BC_SRV_SESSION_IDLE_MS (15u * 60u * 1000u)
#define BC_SRV_SESSION_SWEEP_MS (60u * 1000u)

/* Nodes of a session's scene: the layout's own limit (22-bit ancestor
 * indices, BC_TREE_MAX_NODES), which a SCENE_LOAD under the payload limit
 * can reach. */
#define BC_SRV_MAX_NODES BC_LIMIT_NODES

/* Largest view width or height. 4096^2 RGBA is 64 MiB per rendered frame;
 * the protocol allows 8192 for future GPUs with more memory. */
#define BC_SRV_MAX_DIM 4096u

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

/* Connections from one peer address that have not completed HELLO (Unix
 * socket peers count as one address). Honest clients send HELLO at once,
 * so a handful suffices even behind a NAT; a flood of silent connections
 * then fills 16 slots, not all BC_SRV_MAX_CONNECTIONS, and other clients
 * still get in. Over it a new connection is closed at once. */
#define BC_SRV_MAX_PREHELLO_PER_ADDR 16u

/* Bytes queued for one client (frames and messages not yet taken by the
 * kernel). Frames are spoiled, so only a client that stopped reading fills
 * this; 32 MiB holds several full-size PNG stills. Over it the client is
 * dropped, with the reason in the log. */
#define BC_SRV_MAX_CLIENT_QUEUE (32u * 1024u * 1024u)

/* Largest scene, as its SCENE_STATE payload (the scene encoding plus the
 * 16 bytes before it): every member and joiner is sent the whole scene in
 * one message, so a scene must fit in a client's output queue, with 1 MiB
 * left for the messages and the frame queued beside it. A SCENE_LOAD or a
 * structural EDIT that would pass it is refused (ELIMIT) before anything
 * is applied or saved. */
#define BC_SRV_MAX_SCENE_BYTES (BC_SRV_MAX_CLIENT_QUEUE - 1024u * 1024u)

/* A client closed with at least this many bytes still queued had large
 * frames or scenes in flight: once they are freed the daemon returns its
 * free heap to the system (malloc_trim), so RSS falls after stalled
 * members are dropped instead of staying at its peak. */
#define BC_SRV_TRIM_AFTER_BYTES (4u * 1024u * 1024u)

/* A client whose FRAME has been in the kernel's hands this long without
 * being taken has stopped reading: it is dropped (with the reason in the
 * log) instead of holding a frame and a render slot forever. */
#define BC_SRV_STALL_MS 10000u

/* Idle time after the last change before the still (full quality) frame is
 * rendered: long enough to coalesce a burst of slider events, short enough
 * to feel immediate when the user lets go. */
#define BC_SRV_STILL_DELAY_MS 300u

/* PICK and SNAPSHOT requests of one client queued for the render thread
 * and not yet answered. Frames need no such cap (a client has at most one
 * frame in flight); requests are answered in order, so a client that wants
 * more than this waits for answers first. Over it: ERROR EBUSY, not fatal.
 * Eight keep a picking or snapshotting client busy without letting it queue
 * minutes of full-size renders ahead of everyone (100 queued 4096^2
 * snapshots once held another session's client for 178 s). */
#define BC_SRV_MAX_CLIENT_REQUESTS 8u

/* A SCENE_LOAD of at least this many bytes is decoded, checked, copied for
 * the render thread, encoded for the members and written to disk on a
 * worker thread, not the loop: an 800 000-node load took the loop for
 * 5.6 s, delaying every other session's messages. Meanwhile its session
 * refuses edits and loads (EBUSY); smaller loads take a few milliseconds
 * and stay on the loop. */
#define BC_SRV_ASYNC_LOAD_BYTES (1024u * 1024u)

/* Undo history of a session: steps kept (a drag is one step) and the
 * memory they may hold (a structural step keeps the whole tree before it,
 * about 256 bytes a node). The oldest steps go first. A hundred steps
 * reach back further than a reviewer wants to click; 64 MiB keep a dozen
 * structural steps of a 20 000-node scene. */
#define BC_SRV_UNDO_STEPS 100u
#define BC_SRV_UNDO_BYTES (64u * 1024u * 1024u)

/* Wait before a session retries the frames it could not queue for lack of
 * memory: the clients stay owed them, and a retry at once would spin. */
#define BC_SRV_OOM_RETRY_MS 100u

/* A session's scene is written whole (and its journal restarted) after this
 * many journaled edits: replaying at most this many on start stays fast. */
#define BC_SRV_SNAPSHOT_EVERY 1000u

/* Time budget of one refinement step, milliseconds (default of
 * --frame-budget). A level is refined in BC_SRV_REFINE_BANDS bands of tile
 * rows; past the budget no band starts, so one pathological scene cannot
 * hold the render thread that every session shares for long. The picture
 * then stays complete at its coarser level, flagged INCOMPLETE, until the
 * next change. */
#define BC_SRV_FRAME_BUDGET_MS 2000u
#define BC_SRV_REFINE_BANDS 8u

/* Views whose planes (colour, depth, ids: 12 bytes a pixel) the render
 * thread keeps for damage renders and refinement: a few per member of a
 * busy session, least recently used dropped first, and at most
 * BC_SRV_VIEW_BYTES in all (about 14 views of 1920x1080). */
#define BC_SRV_MAX_VIEWS 32u
#define BC_SRV_VIEW_BYTES (384u * 1024u * 1024u)

/* Milliseconds the first, coarse picture of a new view should take: the
 * render thread picks the finest level its cost model says fits, so a
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

#endif
