/*
 * Packet tracing for the tiled backend: 8 (AVX2) or 16 (AVX-512) rays of a
 * tile sphere traced together through one depth range's pruned view.
 *
 * The work splits in two. The field of a range's view is evaluated for all
 * lanes at once by an ISA-specific kernel (packet_avx2.c, packet_avx512.c,
 * each compiled with its own target flags and chosen at run time): the
 * kernel interprets the view's flat instruction list (a post-order program
 * of primitive records and operators) with every primitive and operator
 * written inline in vector arithmetic, so no per-node call is made. Each
 * lane's sphere tracing logic (trace.c's steps, fallback, refinement and
 * bisection) runs as a small resumable state machine per lane, in portable
 * C (packet.c): it says at which t it needs the field next, the kernel
 * evaluates every lane's request, and each lane consumes its own value.
 * Every transition that is arithmetic alone -- a ray's first value, its
 * marching steps, the start and the rounds of its secant refinement, the
 * start and the halvings of its bisection, the golden-section search of a
 * closest approach, and the ends of a bisection, a search and a march --
 * the kernel takes itself, lane-wise with the same float operations, so
 * that such a lane does not leave the vector registers between samples
 * (bc__pk_march_fn); a lane comes back to the state machine when its
 * secant refinement ends, its budget runs out, or in the rare cases
 * bc__pk_march_fn lists (a value that is not a number, a crossing too
 * narrow to bisect, a hit at the very start). Nothing crosses
 * lanes, so a pixel's value does not depend on which other pixels share
 * its packet.
 */
#ifndef BLOBCAST_RENDER_CPU_PACKET_H
#define BLOBCAST_RENDER_CPU_PACKET_H

#include <stdbool.h>
#include <stdint.h>

#include "cpu.h"

/* Widest packet of any kernel (AVX-512: 16 floats). */
#define BC_PK_MAX_LANES 16u

/* The samples of one packet, structure of arrays: lane i wants the field
 * at o + t d (the kernel computes it with one fused multiply-add per
 * axis). Tracing lanes share the eye as o; shading lanes put the hit point
 * in o and a tetrahedral offset in t d. Lanes outside `active` are not
 * read or written. */
struct bc__pk_lanes {
	_Alignas(64) float ox[BC_PK_MAX_LANES];
	_Alignas(64) float oy[BC_PK_MAX_LANES];
	_Alignas(64) float oz[BC_PK_MAX_LANES];
	_Alignas(64) float dx[BC_PK_MAX_LANES];
	_Alignas(64) float dy[BC_PK_MAX_LANES];
	_Alignas(64) float dz[BC_PK_MAX_LANES];
	_Alignas(64) float t[BC_PK_MAX_LANES];
	_Alignas(64) float v[BC_PK_MAX_LANES]; /* out: the field */
	/* out, bc__pk_eval_id_fn only: the primitive whose value decides
	 * the field (bc_view_eval_id's), BC_NONE where none does. */
	_Alignas(64) uint32_t id[BC_PK_MAX_LANES];
	/* Marching lanes (bc__pk_march_fn): bc__pk_ray's t, v, t_prev,
	 * v_prev, omega and t1, its tn being t[] above, the values taken
	 * since the ray last went through the state machine, and how many
	 * it may take before it must go through it again (what its
	 * evaluation bound leaves; the kernel steps a lane on only while a
	 * next sample fits). */
	_Alignas(64) float mt[BC_PK_MAX_LANES];
	_Alignas(64) float mv[BC_PK_MAX_LANES];
	_Alignas(64) float mt_prev[BC_PK_MAX_LANES];
	_Alignas(64) float mv_prev[BC_PK_MAX_LANES];
	_Alignas(64) float momega[BC_PK_MAX_LANES];
	_Alignas(64) float mt1[BC_PK_MAX_LANES];
	_Alignas(64) float mevals[BC_PK_MAX_LANES];
	_Alignas(64) float mbudget[BC_PK_MAX_LANES];
	/* Bisecting lanes (bc__pk_march_fn's `bisect`): bc__pk_ray's
	 * bracket a, fa, b, fb and its iteration count i, their t[] being
	 * the midpoint asked; mevals and mbudget as for marching lanes. */
	_Alignas(64) float ba[BC_PK_MAX_LANES];
	_Alignas(64) float bfa[BC_PK_MAX_LANES];
	_Alignas(64) float bb[BC_PK_MAX_LANES];
	_Alignas(64) float bfb[BC_PK_MAX_LANES];
	_Alignas(64) float bi[BC_PK_MAX_LANES];
	/* Refining lanes (bc__pk_march_fn's `refine`): bc__pk_ray's t, v,
	 * t_prev, v_prev in mt, mv, mt_prev, mv_prev, its round i, cap and
	 * limit here, their t[] being the probe asked. */
	_Alignas(64) float ri[BC_PK_MAX_LANES];
	_Alignas(64) float rcap[BC_PK_MAX_LANES];
	_Alignas(64) float rlimit[BC_PK_MAX_LANES];
	/* Golden-section lanes (kind BC__PK_LANE_GOLD): bc__pk_ray's a, fa,
	 * b, c, e, vc, ve and i, and which value t[] asks for (gph: 0, 1, 2,
	 * 3 for the states BC__PK_GOLD_C0, _E0, _C, _E). */
	_Alignas(64) float ga[BC_PK_MAX_LANES];
	_Alignas(64) float gfa[BC_PK_MAX_LANES];
	_Alignas(64) float gb[BC_PK_MAX_LANES];
	_Alignas(64) float gc[BC_PK_MAX_LANES];
	_Alignas(64) float ge[BC_PK_MAX_LANES];
	_Alignas(64) float gvc[BC_PK_MAX_LANES];
	_Alignas(64) float gve[BC_PK_MAX_LANES];
	_Alignas(64) float gi[BC_PK_MAX_LANES];
	_Alignas(64) float gph[BC_PK_MAX_LANES];
};

/* The kinds of lane the kernel steps, and the masks of a packet's lanes
 * of each kind (bc__pk_march_fn): in and out, each lane in one kind at
 * most; hit and miss are out only. */
enum {
	BC__PK_LANE_MARCH,
	BC__PK_LANE_BISECT,
	BC__PK_LANE_REFINE,
	BC__PK_LANE_GOLD,
	BC__PK_LANE_KINDS
};
struct bc__pk_kinds {
	uint32_t of[BC__PK_LANE_KINDS];
	uint32_t hit, miss;
};

/* The frame's constants a kernel's steps use: the hit epsilon's terms
 * (BC_CPU_HIT_FOOTPRINT * pix_angle, min_step) and the bisection's end
 * (refine_tol), bc__frame_ctx's. */
struct bc__pk_steps {
	float eps_per_t, min_step, refine_tol;
};

/* Evaluates view v (not empty) of lin for the lanes whose bit is set in
 * active: v[i] = field at o + t d. */
typedef void (*bc__pk_eval_fn)(const struct bc_view *v,
                               const struct bc_lin *lin,
                               struct bc__pk_lanes *ln, uint32_t active);

/* Evaluates as bc__pk_eval_fn, then takes the next sample of the lanes
 * whose next sample packet.c's state machine would decide by arithmetic
 * alone, with the same float operations, each lane in one of four kinds
 * (k->of[], no lane in two):
 *  - marching (waiting at a relaxed or plain step, or for its first value
 *    with the state that value gives it: its state in the m* arrays): an
 *    ordinary step (no crossing, not within the hit epsilon, not at the
 *    interval's end); the plain step from t after an overshot relaxed one
 *    (omega 1 from then on); a refinement's first probe when within the
 *    hit epsilon (the lane turns refining); a bisection's first midpoint
 *    after a crossing (the lane turns bisecting);
 *  - refining (waiting at a secant probe: the m* and r* arrays): the next
 *    probe while the value drops without crossing, fewer than 8 rounds;
 *    a bisection's first midpoint after a crossing;
 *  - bisecting (waiting at a midpoint: the b* arrays): the next midpoint
 *    while fewer than 40 halvings are done, the bracket is wider than
 *    refine_tol and its midpoint strictly inside;
 *  - searching (golden section of a closest approach, waiting at c or e:
 *    the g* arrays): the next sample while fewer than 6 rounds are done;
 *    a bisection's first midpoint after a crossing. A refining lane whose
 *    probe did not come closer starts the search here too;
 * each only with another sample within mbudget (mevals counts the samples
 * taken here since the state machine saw the lane, whatever its kinds).
 * t[] is then the next sample, and the masks say each lane's kind now.
 * A bisecting lane whose bisection ends at this value (the same tests,
 * with that sample within mbudget) is finished here as the state machine
 * would finish it, a hit: it leaves `bisect` for *hit, t[] holds the
 * hit's depth (packet.c's bisect_head, bit for bit) and mevals counts
 * the value; so is a searching lane whose sixth round ends (gold_head's
 * closer sample). A marching lane whose new point is at the interval's
 * end, not within the hit epsilon, is the machine's miss: it leaves
 * `march` for k->miss (mevals counting the value). The rest is the state
 * machine's: a value that is not a number, a crossing too narrow to
 * bisect, a start lane already inside, the end of a secant refinement,
 * a lane without budget for another sample. Returns the active
 * lanes it neither stepped nor finished
 * (v[] holds their field, not yet divided by the Lipschitz bound); their
 * state is as it was, in the arrays of their kind. */
typedef uint32_t (*bc__pk_march_fn)(const struct bc_view *v,
                                    const struct bc_lin *lin,
                                    struct bc__pk_lanes *ln, uint32_t active,
                                    struct bc__pk_kinds *k,
                                    const struct bc__pk_steps *st);

/* A tile's hits to shade, hit i in element i of each array: in, the hit
 * point o and its difference step (bc__put_hit's p and h), the ray
 * direction d; then, from bc__pk_hits_fn, the primitive there and the
 * field gradient g; in again, the albedo; out of bc__pk_shade_fn, the
 * linear colour lit. The kernels read whole vectors: the elements from
 * the hit count up to the next multiple of their width must hold numbers
 * (their results are computed and unused). */
#define BC_PK_SHADE_MAX (BC_CPU_TILE * BC_CPU_TILE)
struct bc__pk_shade {
	_Alignas(64) float o[3][BC_PK_SHADE_MAX];
	_Alignas(64) float step[BC_PK_SHADE_MAX];
	_Alignas(64) float d[3][BC_PK_SHADE_MAX];
	_Alignas(64) uint32_t prim[BC_PK_SHADE_MAX];
	_Alignas(64) float g[3][BC_PK_SHADE_MAX];
	_Alignas(64) float albedo[3][BC_PK_SHADE_MAX];
	_Alignas(64) float lit[3][BC_PK_SHADE_MAX];
};

/* bc__put_hit's samples of hits 0 .. n - 1 of sh (n <= BC_PK_SHADE_MAX)
 * in view v, a lane a hit: prim[] the primitive deciding the field at o
 * (bc_view_eval_id's), g[] the sum of tet[k] times the field at
 * o + step tet[k] over its four tetrahedral offsets, in its order from 0,
 * bit for bit. ln is scratch. */
typedef void (*bc__pk_hits_fn)(const struct bc_view *v,
                               const struct bc_lin *lin,
                               struct bc__pk_lanes *ln, struct bc__pk_shade *sh,
                               uint32_t n);

/* Shades hits 0 .. n - 1 of sh (n <= BC_PK_SHADE_MAX) with s's light:
 * lit[][i] is blobcast/shade_lanes.h's colour for hit i, bit for bit the
 * one bc_shade_hit computes. */
typedef void (*bc__pk_shade_fn)(const struct bc_shade *s,
                                struct bc__pk_shade *sh, uint32_t n);

struct bc__pk_kernel {
	bc__pk_march_fn march; /* NULL: trace one ray at a time (scalar) */
	bc__pk_hits_fn hits;
	bc__pk_shade_fn shade;
	uint32_t lanes;
};

/* The kernel for a simd choice on this CPU: AUTO takes the widest one it
 * has; a forced width the CPU lacks, or OFF, gives the scalar path. */
struct bc__pk_kernel bc__pk_kernel_for(enum bc_simd simd);

#if defined(BLOBCAST_SIMD_X86)
uint32_t bc__pk_march_avx2(const struct bc_view *v, const struct bc_lin *lin,
                           struct bc__pk_lanes *ln, uint32_t active,
                           struct bc__pk_kinds *k,
                           const struct bc__pk_steps *st);
void bc__pk_hits_avx2(const struct bc_view *v, const struct bc_lin *lin,
                      struct bc__pk_lanes *ln, struct bc__pk_shade *sh,
                      uint32_t n);
uint32_t bc__pk_march_avx512(const struct bc_view *v, const struct bc_lin *lin,
                             struct bc__pk_lanes *ln, uint32_t active,
                             struct bc__pk_kinds *k,
                             const struct bc__pk_steps *st);
void bc__pk_hits_avx512(const struct bc_view *v, const struct bc_lin *lin,
                        struct bc__pk_lanes *ln, struct bc__pk_shade *sh,
                        uint32_t n);
void bc__pk_shade_avx2(const struct bc_shade *s, struct bc__pk_shade *sh,
                       uint32_t n);
void bc__pk_shade_avx512(const struct bc_shade *s, struct bc__pk_shade *sh,
                         uint32_t n);
#endif

/* One lane's sphere tracing over [t0, t1], trace.c's bc__trace as a state
 * machine: after bc__pk_ray_start or bc__pk_ray_feed returns false, q is
 * where the ray needs the field (divided by the Lipschitz bound) next;
 * when they return true, res and t_hit hold the result. evals counts the
 * values fed. */
struct bc__pk_ray {
	uint8_t state;
	uint8_t res; /* enum bc__trace_result */
	uint8_t i;   /* iterations of the current refinement phase */
	float q;
	float t0, t1;
	float t, v, t_prev, v_prev, omega, tn; /* marching */
	float cap, limit;                      /* secant refinement */
	float a, fa, b, fb, c, e, vc, ve;      /* bisection, golden section */
	float t_hit;
	uint32_t evals;
};

bool bc__pk_ray_start(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                      float t0, float t1);
bool bc__pk_ray_feed(struct bc__pk_ray *r, const struct bc__frame_ctx *fc,
                     float value);

/* The states that wait for the value at the start (t0), at a marching
 * step (relaxed, or plain after a failed relaxed one), at a secant probe,
 * at a bisection's midpoint and at a golden-section sample (the first at
 * c, then at e, then at c or e): such lanes may take their next samples
 * in the kernel (bc__pk_march_fn). */
#define BC__PK_INIT 1
#define BC__PK_STEP 2
#define BC__PK_STEP2 3
#define BC__PK_REFINE 4
#define BC__PK_BISECT 5
#define BC__PK_GOLD_C0 6
#define BC__PK_GOLD_E0 7
#define BC__PK_GOLD_C 8
#define BC__PK_GOLD_E 9

#endif
