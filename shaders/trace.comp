#version 430 core
// The tracing pass (Zanni 2024 Sec. 6.2, Algorithm 3): one 8x8 workgroup per
// tile of the region (every tile, or the tiles it lists), one invocation
// per pixel ray; pixels outside the region's refinement level are not
// traced, and keep what the image held. The tile's sorted A-buffer list is
// walked in shared depth ranges [z_begin, z_end] (eq. 21-22); for each
// range the first invocation updates the active set and builds the pruned
// tree view by the sparse bottom-up traversal (the rule of blobtree/eval.c:
// a missing operand is +inf; unions and a difference's right side pass the
// other operand through, intersections and a difference's left side make
// the node missing; the climb uses the fast ancestor index, the jump pointer
// and the parent). The workgroup then copies the view's parameter records
// into the shared node cache (D_cache) together, and every ray without a
// hit yet is sphere traced inside the range with over-relaxation (factor
// 1.7, Lipschitz bound 1.45). A hit is shaded here, since the normal needs
// the view that holds only inside this range. No subgroup operations: the
// workgroup synchronizes with barriers and shared memory alone.
//
// Limits degrade instead of failing. Active primitives past M_overlap and
// view instructions past BC_VIEW_SHARED live in global scratch at the
// tile's list offset (each tile owns as many scratch entries as it has
// fragments, which bounds both); records that do not fit the cache are
// read from the parameter buffer. Both only cost speed.
//
// Work per dispatch is bounded when the host asks (u_pool.z): llvmpipe
// stops every loop of an invocation once 65535 loop iterations have run in
// it, all loops together, which a dense tile exceeds. The workgroup counts
// what it spends (the first invocation's traversal and fetching, and per
// pass the longest ray's samples times the view's length); rays pause
// between sphere tracing steps when a pass would go over (and resume with
// the same sample: where a ray pauses in a dispatch never changes its
// value), and the tile
// suspends, its walk and rays saved in a scratch slot, when the dispatch's
// budget is spent. The host dispatches again until no tile is suspended.
//
// A region's evaluation bound (u_bound.x, blobcast/render.h) is of another
// kind: it caps each ray's samples over the whole frame, so that a scene
// whose rays crawl (a huge Lipschitz bound) costs a bounded call. A ray
// stops before its first sample past it and is marked in b_short; the host
// does not copy its pixel out, whatever this pass wrote there.
//
// The tracer and the shading are render/cpu/trace.c and shade.c, step for
// step, so that the two backends draw the same pictures.
#include "common.glsl"
#include "ops.glsl"
#include "prim.glsl"
#include "unary.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(r32ui, binding = 0) uniform writeonly uimage2D img_rgba;
layout(r32f, binding = 1) uniform writeonly image2D img_depth;
layout(r32ui, binding = 2) uniform writeonly uimage2D img_ids;

// View instruction: x = kind (6 bits: primitive kinds reach 32) | leaf
// flag | primitive index << 11 (leaves), y = offset of the parameter record
// in vec4 units.
#define VI_KIND_MASK 63u
#define VI_LEAF 0x40u
// A unary node's value map (its index above VI_PRIM_SHIFT).
#define VI_UNARY 0x80u
#define VI_PRIM_SHIFT 11u

// Pending values the fast evaluation keeps in registers (besides the top):
// left combs need one, balanced trees of 64 leaves six.
#define FAST_STACK 6u

#define STATE_TRACE 1u
#define STATE_DONE 2u

#define TRACE_MISS 1u
#define TRACE_HIT 2u
#define TRACE_NEAR_END 3u
#define TRACE_PAUSED 4u // out of budget between two steps: resume there
#define TRACE_SHORT 5u  // out of the region's evaluation bound: not drawn

// Samples a ray may still take after its step budget runs out (refinement,
// bisection, closest approach and shading are not cut): 8 + 40 + 8 + 5.
#define TAIL_SAMPLES 64u
// The budget a dispatch keeps for loops it does not count (the pass and
// range loops themselves, cache fills, the tile's start and end).
#define BUDGET_MARGIN 2048u

// A ray that still steps after this many evaluations in one range has met
// a field the tracer cannot resolve (it cannot happen for valid scenes: the
// minimal step bounds the count). Ending it keeps the GPU from hanging,
// which would cost the whole context.
#define MAX_STEPS 1000000u

shared uint s_act[BC_M_OVERLAP];
shared float s_act_t1[BC_M_OVERLAP];
shared uvec2 s_view[BC_VIEW_SHARED];
shared uint s_vcache[BC_VIEW_SHARED]; // cache offset or BC_NONE
shared vec4 s_cache[BC_CACHE_VEC4];
// The traversal's stack of complete subtrees (first invocation only).
shared uint s_st_slot[BC_EVAL_STACK];
shared uint s_st_start[BC_EVAL_STACK];
shared bool s_st_miss[BC_EVAL_STACK];
shared uint s_nview, s_na, s_next, s_left, s_state, s_evals;
// The view fits the fast evaluation path: all of it in shared memory, every
// record cached, at most FAST_STACK + 1 values pending.
shared bool s_fast;
shared uint s_over_m, s_over_cache, s_ranges, s_general;
shared float s_zb, s_ze;
// Suspension: loop iterations spent in this dispatch, the pass's step cap,
// the longest ray's samples in the pass, rays left to trace in the range,
// whether the range is resumed in the middle, the tile's slot.
shared uint s_cost, s_budget, s_cap, s_rmax, s_todo, s_slot;
shared bool s_mid, s_was_mid, s_suspend;

// The tile's list: g_n fragments from g_off in b_frag (and as many scratch
// entries there).
uint g_off, g_n;
uint g_evals;
// Loop iterations the first invocation spends fetching and building.
uint g_work;

// ---- The tile's list, active set and view -------------------------------

float frag_t0(uint j)
{
	return uintBitsToFloat(b_frag[g_off + j].x);
}

uint scratch_act(uint i)
{
	return g_off + i;
}

uint scratch_t1(uint i)
{
	return u_counts.y + g_off + i;
}

uint scratch_view(uint i)
{
	return 2u * u_counts.y + 2u * (2u * g_off + i);
}

uint act_get(uint i)
{
	return i < BC_M_OVERLAP ? s_act[i] : b_scratch[scratch_act(i)];
}

float act_t1_get(uint i)
{
	return i < BC_M_OVERLAP ? s_act_t1[i]
				: uintBitsToFloat(b_scratch[scratch_t1(i)]);
}

void act_set(uint i, uint k, float t1)
{
	if (i < BC_M_OVERLAP) {
		s_act[i] = k;
		s_act_t1[i] = t1;
	} else {
		b_scratch[scratch_act(i)] = k;
		b_scratch[scratch_t1(i)] = floatBitsToUint(t1);
	}
}

uvec2 view_get(uint i)
{
	if (i < BC_VIEW_SHARED) {
		return s_view[i];
	}
	uint j = scratch_view(i);
	return uvec2(b_scratch[j], b_scratch[j + 1u]);
}

void view_set(uint i, uvec2 v)
{
	if (i < BC_VIEW_SHARED) {
		s_view[i] = v;
	} else {
		uint j = scratch_view(i);
		b_scratch[j] = v.x;
		b_scratch[j + 1u] = v.y;
	}
}

// Adds list entry j to the active set of na primitives, keeping it sorted
// by primitive index (the traversal needs post-order).
void activate(uint na, uint j)
{
	uvec4 f = b_frag[g_off + j];
	uint i = na;
	while (i > 0u && act_get(i - 1u) > f.z) {
		act_set(i, act_get(i - 1u), act_t1_get(i - 1u));
		i--;
		g_work++;
	}
	act_set(i, f.z, uintBitsToFloat(f.y));
}

// ---- Sparse traversal: the pruned view ------------------------------------

uint parent_of(uint s)
{
	uint a = b_node[s].x & BC_WORD_ANCESTOR_MASK;
	return a == BC_WORD_ANCESTOR_MASK ? BC_NONE : a;
}

uint kind_of(uint s)
{
	uint w = b_node[s].x;
	uint type = (w >> BC_WORD_TYPE_SHIFT) & BC_WORD_TYPE_MASK;
	return (w & BC_WORD_LEAF) != 0u ? type : (type & 31u);
}

// May the climbing entry stand for ancestor a? a must be complete (before
// the next active slot q) and hold nothing of the entry below (first >= lo).
bool may_climb(uint a, uint q, uint lo)
{
	return a < q && b_topo[a].x >= lo;
}

// View instructions a tile may hold: shared memory, then two per list
// entry in scratch. Only unary instructions can go past 2 na - 1.
bool view_room(uint nview)
{
	return nview < max(BC_VIEW_SHARED, 2u * g_n);
}

// Appends slot s's value-changing wrappers (blobtree/eval.c's emit_wraps);
// false when the view has no room left.
bool emit_wraps(inout uint nview, uint s)
{
	if (!bc_has_unary()) {
		return true;
	}
	for (uint u = bc_slot_unary(s).x; u != BC_NONE;) {
		uvec4 un = bc_unary_node(u);
		g_work++;
		if (bc_unary_has_value(un.x)) {
			if (!view_room(nview)) {
				return false;
			}
			view_set(nview++, uvec2(un.x | VI_UNARY |
						(u << VI_PRIM_SHIFT), un.y));
		}
		u = un.z;
	}
	return true;
}

// Does the climb from x to its ancestor a pass a slot with a
// value-changing wrapper (a is one, or one lies between)?
bool value_wrapped(uint x, uint a)
{
	return bc_has_unary() && bc_slot_unary(x).z != bc_slot_unary(a).z;
}

// Builds the view of the na active primitives. Returns false when the view
// is empty (every active primitive was pruned: the field is +inf).
bool build_view(uint na)
{
	uint nview = 0u, sp = 0u;
	bool room = true;
	for (uint i = 0u; i < na; i++) {
		uint k = act_get(i);
		uint s = b_prim[k].info.x;
		g_work++;
		uint q = i + 1u < na ? b_prim[act_get(i + 1u)].info.x : BC_NONE;
		if (sp >= BC_EVAL_STACK) {
			return false; // beyond the tree depth limit: unreachable
		}
		s_st_slot[sp] = s;
		s_st_start[sp] = nview;
		s_st_miss[sp] = false;
		sp++;
		if (!view_room(nview)) {
			room = false;
			break;
		}
		view_set(nview++, uvec2(kind_of(s) | VI_LEAF |
						(k << VI_PRIM_SHIFT),
					b_node[s].y));
		room = room && emit_wraps(nview, s);
		for (;;) {
			uint top = sp - 1u;
			uint lo = sp >= 2u ? s_st_slot[sp - 2u] + 1u : 0u;
			uint x = s_st_slot[top], a;
			g_work++;
			// No shortcut passes a value-changing wrapper: the
			// climb stops there to emit it.
			for (;;) {
				uvec4 tp = b_topo[x];
				g_work++;
				if (tp.y != BC_NONE && may_climb(tp.y, q, lo) &&
				    !value_wrapped(x, tp.y)) {
					x = tp.y;
					continue;
				}
				if (tp.z != BC_NONE && may_climb(tp.z, q, lo) &&
				    !value_wrapped(x, tp.z)) {
					x = tp.z;
					continue;
				}
				a = parent_of(x);
				if (a != BC_NONE && may_climb(a, q, lo)) {
					bool wrapped = value_wrapped(x, a);
					x = a;
					if (wrapped) {
						if (x != s_st_slot[top] &&
						    b_topo[s_st_slot[top]].w !=
							    b_topo[x].w &&
						    !s_st_miss[top]) {
							s_st_miss[top] = true;
							nview = s_st_start[top];
						}
						s_st_slot[top] = x;
						if (!s_st_miss[top]) {
							room = room &&
							       emit_wraps(nview, x);
						}
					}
					continue;
				}
				break;
			}
			if (x != s_st_slot[top] &&
			    b_topo[s_st_slot[top]].w != b_topo[x].w &&
			    !s_st_miss[top]) {
				s_st_miss[top] = true;
				nview = s_st_start[top];
			}
			s_st_slot[top] = x;
			a = parent_of(x);
			if (a == BC_NONE || a >= q) {
				break;
			}
			// The parent holds the entry below: both operands.
			uint left = sp - 2u;
			uint cls = bc_op_class(kind_of(a));
			bool lm = s_st_miss[left], rm = s_st_miss[top];
			bool missing;
			if (!lm && !rm) {
				view_set(nview++, uvec2(kind_of(a), b_node[a].y));
				missing = false;
			} else if (lm && rm) {
				missing = true;
			} else if (lm) {
				missing = cls != BC_OPCLASS_UNION;
			} else {
				missing = cls == BC_OPCLASS_INTERSECTION;
			}
			if (missing) {
				nview = s_st_start[left];
			} else {
				room = room && emit_wraps(nview, a);
			}
			s_st_slot[left] = a;
			s_st_miss[left] = missing;
			sp--;
		}
	}
	if (!room) {
		// More unary instructions than the tile's scratch holds: the
		// host reports the frame as failed (never a wrong picture).
		atomicAdd(b_stat[BC_STAT_OVER_VIEW], 1u);
		s_nview = 0u;
		return false;
	}
	if (sp == 0u || s_st_miss[0]) {
		s_nview = 0u;
		return false;
	}
	s_nview = nview;
	// The node cache: records in view order while they fit.
	uint used = 0u;
	bool over = false;
	g_work += 2u * min(nview, BC_VIEW_SHARED);
	for (uint i = 0u; i < min(nview, BC_VIEW_SHARED); i++) {
		uint size = (s_view[i].x & VI_LEAF) != 0u
				? bc_record_vec4(s_view[i].x & VI_KIND_MASK)
			  : (s_view[i].x & VI_UNARY) != 0u ? 2u : 1u;
		if (used + size <= BC_CACHE_VEC4) {
			s_vcache[i] = used;
			used += size;
		} else {
			s_vcache[i] = BC_NONE;
			over = true;
		}
	}
	if (over || nview > BC_VIEW_SHARED) {
		s_over_cache++;
	}
	uint depth = 0u, most = 0u;
	for (uint i = 0u; i < min(nview, BC_VIEW_SHARED); i++) {
		if ((s_view[i].x & VI_UNARY) != 0u) {
			continue;
		}
		depth = (s_view[i].x & VI_LEAF) != 0u ? depth + 1u : depth - 1u;
		most = max(most, depth);
	}
	// Trees with unary nodes take the general evaluator.
	s_fast = !over && nview <= BC_VIEW_SHARED && most <= FAST_STACK + 1u &&
		 !bc_has_unary();
	return true;
}

// The first invocation's part of a loop turn: retire, fetch (eq. 21-22),
// build the view. Loops internally over ranges with nothing to trace, so
// the workgroup only synchronizes for ranges that need rays.
void next_range()
{
	uint na = s_na, next = s_next;
	float z_end = s_ze;
	s_state = STATE_DONE;
	while (s_left > 0u) {
		float max_exit = -BC_INF, z_begin;
		uint kept = 0u, fetched = 0u;
		g_work += na + 1u;
		for (uint i = 0u; i < na; i++) {
			float t1 = act_t1_get(i);
			if (t1 > z_end) {
				act_set(kept, act_get(i), t1);
				max_exit = max(max_exit, t1);
				kept++;
			}
		}
		na = kept;
		if (na == 0u) {
			if (next >= g_n) {
				break;
			}
			z_begin = frag_t0(next);
		} else {
			z_begin = z_end;
		}
		while (next < g_n && fetched < BC_MAX_FETCH &&
		       na < BC_M_OVERLAP &&
		       (na == 0u || frag_t0(next) <= max_exit)) {
			activate(na, next);
			max_exit = max(max_exit,
				       uintBitsToFloat(b_frag[g_off + next].y));
			na++;
			next++;
			fetched++;
			g_work++;
		}
		if (na >= BC_M_OVERLAP && next < g_n &&
		    frag_t0(next) <= z_begin) {
			// Over M_overlap at this very depth: no smaller range
			// excludes the next primitive, so the set grows into
			// global scratch.
			while (next < g_n && frag_t0(next) <= z_begin) {
				activate(na, next);
				max_exit = max(max_exit,
					       uintBitsToFloat(
						       b_frag[g_off + next].y));
				na++;
				next++;
				g_work++;
			}
			s_over_m++;
		}
		z_end = next < g_n ? min(frag_t0(next), max_exit) : max_exit;
		if (!(z_end > z_begin)) {
			continue;
		}
		if (!build_view(na)) {
			continue; // no surface can be in this range
		}
		s_zb = z_begin;
		s_state = STATE_TRACE;
		s_ranges++;
		s_general += s_fast ? 0u : 1u;
		break;
	}
	s_na = na;
	s_next = next;
	s_ze = z_end;
}

// All invocations: copy the cached records of the view into shared memory.
void fill_cache(uint lid)
{
	uint n = min(s_nview, BC_VIEW_SHARED);
	for (uint i = lid; i < n; i += BC_TILE_RAYS) {
		uint c = s_vcache[i];
		if (c == BC_NONE) {
			continue;
		}
		uvec2 in_ = s_view[i];
		uint size = (in_.x & VI_LEAF) != 0u
				? bc_record_vec4(in_.x & VI_KIND_MASK) : 1u;
		for (uint j = 0u; j < size; j++) {
			s_cache[c + j] = b_param[in_.y + j];
		}
	}
}

// ---- Field of the view --------------------------------------------------------

// Algorithm 4: the view is a post-order program. Both evaluators also track
// which primitive decides the value (blobtree/eval.c's rule), for ids and
// colours.
//
// The fast one keeps the stack in registers (a shift register below the
// top) and reads only shared memory: it covers the views of real scenes.
// Dynamically indexed arrays and a shared-or-global choice per record cost
// llvmpipe twice the time, so they are left to the general one.
float field_fast(vec3 p, out uint prim)
{
	float top = BC_INF;
	float s0 = BC_INF, s1 = BC_INF, s2 = BC_INF, s3 = BC_INF, s4 = BC_INF,
	      s5 = BC_INF;
	uint w = BC_NONE, w0 = BC_NONE, w1 = BC_NONE, w2 = BC_NONE,
	     w3 = BC_NONE, w4 = BC_NONE, w5 = BC_NONE;
	uint n = s_nview;
	for (uint i = 0u; i < n; i++) {
		uvec2 in_ = s_view[i];
		uint c = s_vcache[i];
		uint kind = in_.x & VI_KIND_MASK;
		if ((in_.x & VI_LEAF) != 0u) {
			float v;
			if (kind == BC_PRIM_SPHERE) {
				v = bc_sphere_record(s_cache[c], p);
			} else {
				v = bc_prim_record(kind, s_cache[c],
						   s_cache[c + 1u],
						   s_cache[c + 2u],
						   s_cache[c + 3u],
						   s_cache[c + 4u], p);
			}
			s5 = s4;
			s4 = s3;
			s3 = s2;
			s2 = s1;
			s1 = s0;
			s0 = top;
			w5 = w4;
			w4 = w3;
			w3 = w2;
			w2 = w1;
			w1 = w0;
			w0 = w;
			top = v;
			w = in_.x >> VI_PRIM_SHIFT;
		} else {
			vec4 r = s_cache[c];
			if (!bc_follows_right(kind, s0, top)) {
				w = w0;
			}
			top = bc_op_eval(kind, r.x, r.y, s0, top);
			s0 = s1;
			s1 = s2;
			s2 = s3;
			s3 = s4;
			s4 = s5;
			w0 = w1;
			w1 = w2;
			w2 = w3;
			w3 = w4;
			w4 = w5;
		}
	}
	prim = w;
	return top;
}

vec4 record(uint i, uvec2 in_, uint j)
{
	uint c = i < BC_VIEW_SHARED ? s_vcache[i] : BC_NONE;
	return c != BC_NONE ? s_cache[c + j] : b_param[in_.y + j];
}

// Any view: instructions and records wherever they are, a stack as deep as
// the tree allows.
float field_general(vec3 p, out uint prim)
{
	float st[BC_EVAL_STACK];
	uint who[BC_EVAL_STACK];
	float top = BC_INF;
	uint w = BC_NONE;
	uint depth = 0u, n = s_nview;
	for (uint i = 0u; i < n; i++) {
		uvec2 in_ = view_get(i);
		uint kind = in_.x & VI_KIND_MASK;
		if ((in_.x & VI_UNARY) != 0u) {
			top = bc_unary_value(in_.x >> VI_PRIM_SHIFT, top, p);
			continue;
		}
		if ((in_.x & VI_LEAF) != 0u) {
			// The point through the domain nodes around the leaf.
			vec3 q = p;
			if (bc_has_unary()) {
				uint s = b_prim[in_.x >> VI_PRIM_SHIFT].info.x;
				q = bc_domain_map(bc_slot_unary(s).y, p);
			}
			float v;
			if (kind == BC_PRIM_SPHERE) {
				v = bc_sphere_record(record(i, in_, 0u), q);
			} else {
				v = bc_prim_record(kind, record(i, in_, 0u),
						   record(i, in_, 1u),
						   record(i, in_, 2u),
						   record(i, in_, 3u),
						   record(i, in_, 4u), q);
			}
			if (depth > 0u) {
				uint s = min(depth - 1u, BC_EVAL_STACK - 1u);
				st[s] = top;
				who[s] = w;
			}
			top = v;
			w = in_.x >> VI_PRIM_SHIFT;
			depth++;
		} else {
			vec4 r = record(i, in_, 0u);
			uint s = min(depth - 2u, BC_EVAL_STACK - 1u);
			float f0 = st[s];
			if (!bc_follows_right(kind, f0, top)) {
				w = who[s];
			}
			top = bc_op_eval(kind, r.x, r.y, f0, top);
			depth--;
		}
	}
	prim = w;
	return top;
}

// ---- The ray: sphere tracing and shading as one state machine -------------
//
// render/cpu/trace.c and shade.c, step for step: the same samples in the
// same order, so the same evaluation counts. Written as a loop with a single
// evaluation site, because GLSL inlines every call: a tracer with separate
// loops for stepping, refinement, bisection and shading holds many copies
// of every primitive's field (minutes of compiling on llvmpipe), and its
// SIMD lanes wait for each other at every loop; here lanes in different
// phases still evaluate together.

#define ST_END 0u
#define ST_START 1u   // sample at the range's start
#define ST_STEP 2u    // sample at the next sphere tracing step
#define ST_REFINE 3u  // sample past a near hit (trace.c's refine)
#define ST_BISECT 4u  // sample inside a sign change
#define ST_CLOSE_C 5u // golden section for the closest approach: first c,
#define ST_CLOSE_E 6u // then e,
#define ST_CLOSE 7u   // then one per narrowing (r_which: c or e)
#define ST_ID 8u      // sample at the hit: value and primitive
#define ST_NORMAL 9u  // four samples around the hit: the gradient

#define GOLDEN 0.618034

uint r_state, r_result, r_count, r_prim, r_which;
uint r_steps; // samples taken in this pass
float r_t, r_v, r_tp, r_vp, r_omega, r_t1, r_smp;
float r_a, r_fa, r_b, r_fb, r_cap, r_limit, r_thit, r_h;
float r_c, r_e, r_vc, r_ve;
vec3 r_n;

const vec3 tet[4] = vec3[4](vec3(1.0, -1.0, -1.0), vec3(-1.0, -1.0, 1.0),
			    vec3(-1.0, 1.0, -1.0), vec3(1.0, 1.0, 1.0));

void ray_finish(uint result, float t)
{
	r_result = result;
	if (result == TRACE_MISS) {
		r_state = ST_END;
		return;
	}
	r_thit = t;
	r_smp = t;
	r_h = max(BC_HIT_FOOTPRINT * u_up.w * t, u_right.w);
	r_state = ST_ID;
}

void ray_bisect_next()
{
	if (r_count < 40u && r_b - r_a > u_misc.x) {
		float m = 0.5 * (r_a + r_b);
		if (m > r_a && m < r_b) {
			r_smp = m;
			r_state = ST_BISECT;
			return;
		}
	}
	float t = r_a;
	if (r_fa - r_fb > 0.0 && r_fa - r_fb < BC_INF) {
		t = clamp(r_a + (r_b - r_a) * r_fa / (r_fa - r_fb), r_a, r_b);
	}
	ray_finish(TRACE_HIT, t);
}

void ray_bisect(float a, float fa, float b, float fb)
{
	r_a = a;
	r_fa = fa;
	r_b = b;
	r_fb = fb;
	r_count = 0u;
	ray_bisect_next();
}

// trace.c's closest(): the ray passes the surface by; the minimum of the
// field in [a, b] is narrowed by golden section search.
void ray_closest(float a, float va, float b)
{
	r_a = a;
	r_fa = va;
	r_b = b;
	r_c = b - GOLDEN * (b - a);
	r_e = a + GOLDEN * (b - a);
	r_smp = r_c;
	r_state = ST_CLOSE_C;
}

void ray_closest_next()
{
	if (r_count >= 6u) {
		ray_finish(TRACE_HIT, r_vc < r_ve ? r_c : r_e);
		return;
	}
	if (r_vc < r_ve) {
		r_b = r_e;
		r_e = r_c;
		r_ve = r_vc;
		r_c = r_b - GOLDEN * (r_b - r_a);
		r_smp = r_c;
		r_which = 0u;
	} else {
		r_a = r_c;
		r_fa = r_vc;
		r_c = r_e;
		r_vc = r_ve;
		r_e = r_a + GOLDEN * (r_b - r_a);
		r_smp = r_e;
		r_which = 1u;
	}
	r_state = ST_CLOSE;
}

void ray_refine_next()
{
	float reach;
	if (r_count >= 8u) {
		ray_finish(TRACE_HIT, r_t);
		return;
	}
	if (r_t > r_tp && r_vp > r_v) {
		reach = 1.5 * r_v * (r_t - r_tp) / (r_vp - r_v);
	} else if (r_count == 0u) {
		reach = r_v;
	} else {
		ray_finish(TRACE_HIT, r_t);
		return;
	}
	float probe = min(r_t + max(reach, u_right.w), r_limit);
	if (!(probe > r_t)) {
		ray_finish(r_t1 < r_cap ? TRACE_NEAR_END : TRACE_HIT, r_t);
		return;
	}
	r_smp = probe;
	r_state = ST_REFINE;
}

// After a value at r_t: refine near a surface, stop at the range's end, or
// step on.
void ray_step_check()
{
	float eps = max(BC_HIT_FOOTPRINT * u_up.w * r_t, u_right.w);
	// Steps are divided by the tree's Lipschitz bound (u_misc.z), the hit
	// band is not (render/cpu/trace.c).
	eps *= u_misc.w;
	if (r_v < eps) {
		r_cap = r_t + 64.0 * BC_LIPSCHITZ * u_misc.z * eps;
		r_limit = min(r_cap, r_t1);
		r_count = 0u;
		ray_refine_next();
		return;
	}
	if (r_t >= r_t1 || r_count >= MAX_STEPS) {
		ray_finish(TRACE_MISS, r_t);
		return;
	}
	r_count++;
	r_smp = min(r_t + max(r_omega * r_v, 1.0e-6 * r_t), r_t1);
	r_state = ST_STEP;
	if (r_steps >= s_cap) {
		// Out of this pass's budget: the next pass takes this very
		// sample, from the state kept as it is (trace_pass). The step
		// is computed here only: a second site could round it
		// differently (the compiler may contract either to an FMA).
		r_result = TRACE_PAUSED;
	}
}

// Consumes the value x of the sample the state asked for (prim: the
// primitive deciding it).
void ray_take(float x, uint prim)
{
	if (r_state < ST_ID) {
		x *= 1.0 / BC_LIPSCHITZ;
		x *= u_misc.w;
	}
	switch (r_state) {
	case ST_START:
		if (x < 0.0) {
			ray_finish(TRACE_HIT, r_t);
		} else {
			r_v = x;
			r_count = 0u;
			ray_step_check();
		}
		break;
	case ST_STEP: {
		float tn = r_smp;
		if (r_omega > 1.0 && r_v + abs(x) < tn - r_t) {
			// Disjoint unbounding spheres: the plain step.
			r_omega = 1.0;
			r_smp = min(r_t + max(r_v, 1.0e-6 * r_t), r_t1);
		} else if (x < 0.0) {
			ray_bisect(r_t, r_v, tn, x);
		} else if (!(x == x)) {
			ray_finish(TRACE_MISS, r_t);
		} else {
			r_tp = r_t;
			r_vp = r_v;
			r_t = tn;
			r_v = x;
			ray_step_check();
		}
		break;
	}
	case ST_REFINE:
		if (x < 0.0) {
			ray_bisect(r_t, r_v, r_smp, x);
		} else if (!(x < r_v)) {
			// Rising: closest between the previous sample and here.
			ray_closest(r_tp < r_t ? r_tp : r_t,
				    r_tp < r_t ? r_vp : r_v, r_smp);
		} else {
			r_tp = r_t;
			r_vp = r_v;
			r_t = r_smp;
			r_v = x;
			r_count++;
			ray_refine_next();
		}
		break;
	case ST_BISECT:
		if (x < 0.0) {
			r_b = r_smp;
			r_fb = x;
		} else {
			r_a = r_smp;
			r_fa = x;
		}
		r_count++;
		ray_bisect_next();
		break;
	case ST_CLOSE_C:
		r_vc = x;
		if (x < 0.0) {
			ray_bisect(r_a, r_fa, r_c, x);
		} else {
			r_smp = r_e;
			r_state = ST_CLOSE_E;
		}
		break;
	case ST_CLOSE_E:
		r_ve = x;
		if (x < 0.0) {
			ray_bisect(r_a, r_fa, r_e, x);
		} else {
			r_count = 0u;
			ray_closest_next();
		}
		break;
	case ST_CLOSE:
		if (r_which == 0u) {
			r_vc = x;
		} else {
			r_ve = x;
		}
		if (x < 0.0) {
			ray_bisect(r_a, r_fa, r_which == 0u ? r_c : r_e, x);
		} else {
			r_count++;
			ray_closest_next();
		}
		break;
	case ST_ID:
		r_prim = prim;
		r_n = vec3(0.0);
		r_count = 0u;
		r_state = ST_NORMAL;
		break;
	default: // ST_NORMAL
		r_n += tet[r_count] * x;
		r_count++;
		if (r_count == 4u) {
			r_state = ST_END;
		}
		break;
	}
}

// ---- Shading (render/cpu/shade.c) -------------------------------------------

uint to_srgb8(float c)
{
	if (!(c > 0.0)) {
		return 0u;
	}
	if (c >= 1.0) {
		return 255u;
	}
	float s = c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
	return uint(s * 255.0 + 0.5);
}

uint pack_rgba(uvec4 c)
{
	return c.r | (c.g << 8u) | (c.b << 16u) | (c.a << 24u);
}

// Viridis sampled at five points, for x in [0, 1].
uint ramp(float x)
{
	const vec3 stops[5] = vec3[5](
		vec3(0.267, 0.005, 0.329), vec3(0.229, 0.322, 0.545),
		vec3(0.128, 0.567, 0.551), vec3(0.369, 0.789, 0.383),
		vec3(0.993, 0.906, 0.144));
	x = clamp(x, 0.0, 1.0);
	float s = x * 4.0;
	int i = s >= 4.0 ? 3 : int(s);
	s -= float(i);
	vec3 v = stops[i] + (stops[i + 1] - stops[i]) * s;
	return pack_rgba(uvec4(uvec3(v * 255.0 + 0.5), 255u));
}

uint debug_colour(uint overlaps)
{
	if (u_counts.z == BC_DEBUG_EVALS) {
		return ramp(float(g_evals) / BC_DEBUG_EVALS_MAX);
	}
	return ramp(float(overlaps) / BC_DEBUG_OVERLAPS_MAX);
}

void put_miss(ivec2 px, uint overlaps)
{
	uint c;
	if (u_counts.z != BC_DEBUG_NONE) {
		c = debug_colour(overlaps);
	} else {
		// The whole view's gradient (u_window).
		float h = float(u_window.w);
		float v = u_window.w > 1u
			      ? float(uint(px.y) + u_window.y) / (h - 1.0)
			      : 0.0;
		c = pack_rgba(uvec4(uint(30.0 - 22.0 * v), uint(33.0 - 24.0 * v),
				    uint(42.0 - 30.0 * v), 255u));
	}
	imageStore(img_rgba, px, uvec4(c));
	imageStore(img_depth, px, vec4(BC_INF));
	imageStore(img_ids, px, uvec4(0u));
}

// The hit at r_thit, its primitive r_prim and gradient r_n.
void put_hit(ivec2 px, vec3 d, uint overlaps)
{
	vec3 n = r_n;
	if (!(abs(n.x) < BC_INF && abs(n.y) < BC_INF && abs(n.z) < BC_INF) ||
	    dot(n, n) == 0.0) {
		n = -d; // no usable gradient: face the viewer
	}
	n = normalize(n);
	if (dot(n, d) > 0.0) {
		n = -n; // seen from inside
	}
	uint prim = r_prim, c;
	if (u_counts.z != BC_DEBUG_NONE) {
		c = debug_colour(overlaps);
	} else {
		vec3 albedo = prim < u_counts.x ? b_prim[prim].color.rgb
						: vec3(0.7);
		vec3 light = u_light.xyz;
		float ambient = u_light.w;
		vec3 hv = normalize(light - d);
		float diff = max(dot(n, light), 0.0);
		float spec = diff > 0.0 ? pow(max(dot(n, hv), 0.0), 48.0) : 0.0;
		vec3 lit = albedo * (ambient + (1.0 - ambient) * diff) +
			   0.25 * spec;
		c = pack_rgba(uvec4(to_srgb8(lit.r), to_srgb8(lit.g),
				    to_srgb8(lit.b), 255u));
	}
	imageStore(img_rgba, px, uvec4(c));
	imageStore(img_depth, px, vec4(r_thit));
	imageStore(img_ids, px,
		   uvec4(prim < u_counts.x ? b_prim[prim].info.y : 0u));
}

// ---- Suspension ----------------------------------------------------------------

// Each ray's state across passes and dispatches: done, pending (with the
// provisional hit's t), to trace in the current range, and paused inside
// it (the sphere tracing state r_t, r_v, r_tp, r_vp, r_omega, r_count is
// kept with the sample it asked for, so a paused ray resumes with the very
// step it would have taken).
bool p_done, p_pending, p_todo, p_paused;
float p_pending_t, p_resume_t;

uint slot_base(uint slot)
{
	return u_pool.x + slot * BC_SLOT_WORDS;
}

// Saves the tile's walk (first invocation) and every ray, and marks the
// tile suspended. Returns false when no slot was free: the tile then goes
// on over budget and the host, seeing the count, redraws with more slots.
// A tile suspends between passes, when every ray still to trace in the
// range is paused, or between ranges, when none is: p_resume_t need not be
// kept.
bool suspend(uint lid, uint tid)
{
	if (lid == 0u) {
		uint slot = s_slot;
		if (slot == BC_NONE) {
			slot = atomicAdd(b_stat[BC_STAT_SLOTS], 1u);
			if (slot >= u_pool.y) {
				atomicAdd(b_stat[BC_STAT_NO_SLOT], 1u);
				slot = BC_NONE;
			}
		}
		s_slot = slot;
		if (slot != BC_NONE) {
			uint b = slot_base(slot);
			b_scratch[b] = s_na;
			b_scratch[b + 1u] = s_next;
			b_scratch[b + 2u] = floatBitsToUint(s_ze);
			b_scratch[b + 3u] = floatBitsToUint(s_zb);
			b_scratch[b + 4u] = s_left;
			b_scratch[b + 5u] = s_mid ? 1u : 0u;
			// The part of the active set held in shared memory.
			for (uint i = 0u; i < min(s_na, BC_M_OVERLAP); i++) {
				b_scratch[scratch_act(i)] = s_act[i];
				b_scratch[scratch_t1(i)] =
					floatBitsToUint(s_act_t1[i]);
			}
			b_tile[tid].w = (slot << 2u) | BC_TILE_SUSPENDED;
			atomicAdd(b_stat[BC_STAT_SUSPENDED], 1u);
		}
	}
	memoryBarrierShared();
	barrier();
	if (s_slot == BC_NONE) {
		return false;
	}
	uint b = slot_base(s_slot) + BC_SLOT_TILE_WORDS + BC_SLOT_RAY_WORDS * lid;
	b_scratch[b] = (p_done ? 1u : 0u) | (p_pending ? 2u : 0u) |
		       (p_todo ? 4u : 0u) | (p_paused ? 8u : 0u) |
		       (g_evals << 4u);
	b_scratch[b + 1u] = floatBitsToUint(p_pending_t);
	b_scratch[b + 2u] = floatBitsToUint(r_t);
	b_scratch[b + 3u] = floatBitsToUint(r_v);
	b_scratch[b + 4u] = floatBitsToUint(r_tp);
	b_scratch[b + 5u] = floatBitsToUint(r_vp);
	b_scratch[b + 6u] = floatBitsToUint(r_omega);
	b_scratch[b + 7u] = r_count;
	b_scratch[b + 8u] = floatBitsToUint(r_smp);
	return true;
}

// Loads what suspend() saved.
void resume(uint lid, uint slot)
{
	uint b = slot_base(slot);
	if (lid == 0u) {
		s_na = b_scratch[b];
		s_next = b_scratch[b + 1u];
		s_ze = uintBitsToFloat(b_scratch[b + 2u]);
		s_zb = uintBitsToFloat(b_scratch[b + 3u]);
		s_left = b_scratch[b + 4u];
		s_mid = b_scratch[b + 5u] != 0u;
		for (uint i = 0u; i < min(s_na, BC_M_OVERLAP); i++) {
			s_act[i] = b_scratch[scratch_act(i)];
			s_act_t1[i] = uintBitsToFloat(b_scratch[scratch_t1(i)]);
		}
	}
	b += BC_SLOT_TILE_WORDS + BC_SLOT_RAY_WORDS * lid;
	uint w = b_scratch[b];
	p_done = (w & 1u) != 0u;
	p_pending = (w & 2u) != 0u;
	p_todo = (w & 4u) != 0u;
	p_paused = (w & 8u) != 0u;
	g_evals = w >> 4u;
	p_pending_t = uintBitsToFloat(b_scratch[b + 1u]);
	r_t = uintBitsToFloat(b_scratch[b + 2u]);
	r_v = uintBitsToFloat(b_scratch[b + 3u]);
	r_tp = uintBitsToFloat(b_scratch[b + 4u]);
	r_vp = uintBitsToFloat(b_scratch[b + 5u]);
	r_omega = uintBitsToFloat(b_scratch[b + 6u]);
	r_count = b_scratch[b + 7u];
	r_smp = uintBitsToFloat(b_scratch[b + 8u]);
}

// Traces this ray inside the current range, from p_resume_t or from where
// it paused, for at most s_cap steps. Returns the samples taken. Where the
// passes split a ray's steps never changes its samples: a paused ray
// continues with the step it was about to take, so its value depends on
// nothing but its own ray and the tile's depth ranges (not on the other
// rays of the workgroup, whose samples set s_cap). A ray whose samples over
// all its ranges (shading's included) would go past the region's bound
// stops before the first one past it: it is done, its pixel is not drawn
// (a near hit it wrote in an earlier range is not copied out either) and
// its bit is set in the tile's b_short words.
uint trace_pass(ivec2 px, vec3 d, uint tid)
{
	uint samples = 0u;
	r_t1 = s_ze;
	r_result = TRACE_MISS;
	r_steps = 0u;
	if (p_paused) {
		// The step ray_step_check asked for before pausing.
		p_paused = false;
		r_state = ST_STEP;
	} else {
		r_state = ST_START;
		r_t = p_resume_t;
		r_tp = r_t;
		r_vp = 0.0;
		r_omega = BC_OVERRELAX;
		r_smp = r_t;
		if (!(r_t1 >= r_t)) {
			r_state = ST_END;
		}
	}
	vec3 hit_p = vec3(0.0);
	while (r_state != ST_END && r_result != TRACE_PAUSED) {
		if (u_bound.x != 0u && g_evals >= u_bound.x) {
			r_result = TRACE_SHORT;
			break;
		}
		vec3 q;
		if (r_state == ST_NORMAL) {
			q = hit_p + r_h * tet[r_count];
		} else {
			q = u_eye.xyz + r_smp * d;
			hit_p = q;
		}
		uint who;
		float x = s_fast ? field_fast(q, who) : field_general(q, who);
		g_evals++;
		samples++;
		r_steps++;
		ray_take(x, who);
	}
	if (r_result == TRACE_PAUSED) {
		p_paused = true;
		return samples;
	}
	p_todo = false;
	if (r_result == TRACE_SHORT) {
		uint lid = gl_LocalInvocationIndex;
		p_done = true;
		p_pending = false;
		atomicOr(b_short[BC_SHORT_WORDS * tid + lid / 32u],
			 1u << (lid % 32u));
		atomicAdd(s_left, 0xffffffffu);
		return samples;
	}
	if (r_result == TRACE_MISS) {
		p_pending = false;
		return samples;
	}
	put_hit(px, d, g_n);
	if (r_result == TRACE_HIT) {
		p_done = true;
		p_pending = false;
		atomicAdd(s_left, 0xffffffffu);
	} else {
		// Within the hit epsilon at the range's end: the crossing, if
		// any, is in a later range. This stands unless one is found.
		p_pending = true;
		p_pending_t = r_thit;
	}
	return samples;
}

// ---- The loop (Algorithm 3) ---------------------------------------------------

void main()
{
	uint lid = gl_LocalInvocationIndex;
	uint tid = bc_region_tile(gl_WorkGroupID);
	if (tid == BC_NONE) {
		return;
	}
	uvec2 tile = uvec2(tid % u_size.z, tid / u_size.z);
	uvec4 tl = b_tile[tid];
	uint status = tl.w & 3u;
	ivec2 px = ivec2(tile * BC_TILE + gl_LocalInvocationID.xy);
	// The pixels the region asks for. The others take no part in the
	// tracing, only in the workgroup's barriers: the depth ranges are the
	// tile list's alone, and a ray's samples depend on its own ray and
	// those ranges only (trace_pass), so an asked pixel's value is the
	// one a whole frame gives it.
	bool asked = uint(px.x) < u_size.x && uint(px.y) < u_size.y &&
		     bc_region_has(uint(px.x), uint(px.y));
	bool suspended = false;
	vec3 d = bc_ray_dir(float(px.x) + 0.5, float(px.y) + 0.5);
	uint evals_before;
	if (status == BC_TILE_FINISHED) {
		return;
	}
	g_off = tl.z;
	g_n = tl.y;
	g_evals = 0u;
	g_work = 0u;
	// A ray that ended a range within the hit epsilon, still approaching
	// (trace.c's NEAR_END), is pending: its provisional hit is written;
	// the next range decides, and when none follows right there, it
	// stands.
	p_done = !asked;
	p_pending = false;
	p_todo = false;
	p_paused = false;
	p_pending_t = 0.0;
	p_resume_t = 0.0;
	if (lid == 0u) {
		s_left = 0u;
		s_na = 0u;
		s_next = 0u;
		s_ze = 0.0;
		s_evals = 0u;
		s_over_m = 0u;
		s_over_cache = 0u;
		s_ranges = 0u;
		s_general = 0u;
		s_cost = 0u;
		s_budget = u_pool.z == 0u ? 0xffffffffu
					  : u_pool.z - BUDGET_MARGIN;
		s_mid = false;
		s_suspend = false;
		s_slot = status == BC_TILE_SUSPENDED ? tl.w >> 2u : BC_NONE;
		atomicAdd(b_stat[BC_STAT_DISPATCHES], 1u);
	}
	memoryBarrierShared();
	barrier();
	if (status == BC_TILE_SUSPENDED) {
		resume(lid, tl.w >> 2u);
	} else if (asked) {
		atomicAdd(s_left, 1u);
	}
	evals_before = g_evals;
	memoryBarrierShared();
	barrier();
	// Out of time (the frame's budget): keep the hits, the rest is
	// background.
	for (; u_pool.w == 0u;) {
		// A range to trace: the one left in the middle, or the next.
		if (lid == 0u) {
			s_was_mid = s_mid;
			if (s_mid) {
				// The same active set gives the same view.
				s_state = build_view(s_na) ? STATE_TRACE
							    : STATE_DONE;
				s_mid = false;
			} else {
				next_range();
			}
			s_cost += g_work;
			g_work = 0u;
			if (s_budget != 0xffffffffu &&
			    s_cost > s_budget + BUDGET_MARGIN / 2u) {
				// One range's fetch and view alone went over:
				// nothing smaller to split it into.
				atomicAdd(b_stat[BC_STAT_OVER_BUDGET], 1u);
			}
		}
		memoryBarrierShared();
		memoryBarrierBuffer();
		barrier();
		if (s_state == STATE_DONE) {
			break;
		}
		fill_cache(lid);
		if (!s_was_mid) {
			p_todo = false;
			if (!p_done) {
				if (p_pending && s_zb > p_pending_t) {
					p_done = true; // nothing right behind
					atomicAdd(s_left, 0xffffffffu);
				} else {
					p_todo = true;
					p_paused = false;
					p_resume_t = s_zb;
				}
			}
		}
		memoryBarrierShared();
		barrier();
		// Passes over the range until every ray is through it, each
		// within what is left of the budget.
		for (;;) {
			if (lid == 0u) {
				uint per = s_nview + 2u;
				uint left = s_cost < s_budget ? s_budget - s_cost
							      : 0u;
				uint cap = left / per;
				// Two samples at least: the start and one step,
				// so that every pass moves every ray on.
				s_cap = cap > TAIL_SAMPLES + 2u ? cap - TAIL_SAMPLES
								: 2u;
				s_rmax = 0u;
				s_todo = 0u;
			}
			memoryBarrierShared();
			barrier();
			uint samples = 0u;
			if (p_todo) {
				samples = trace_pass(px, d, tid);
				if (p_todo) {
					atomicAdd(s_todo, 1u);
				}
			}
			atomicMax(s_rmax, samples);
			memoryBarrierShared();
			barrier();
			if (lid == 0u) {
				s_cost += (s_rmax + 1u) * (s_nview + 2u);
				if (s_budget != 0xffffffffu &&
				    s_cost > s_budget + BUDGET_MARGIN / 2u) {
					// A view so long that two steps of
					// every ray do not fit.
					atomicAdd(b_stat[BC_STAT_OVER_BUDGET], 1u);
				}
				s_suspend = s_todo > 0u && s_cost >= s_budget;
				s_mid = s_suspend;
			}
			memoryBarrierShared();
			barrier();
			if (s_todo == 0u || s_suspend) {
				break;
			}
		}
		if (lid == 0u && !s_suspend && s_left > 0u) {
			// Between ranges: stop while the next range's fetch,
			// view and first pass still fit comfortably.
			s_suspend = s_cost >= s_budget / 2u;
		}
		memoryBarrierShared();
		barrier();
		if (s_suspend) {
			if (suspend(lid, tid)) {
				suspended = true;
				break;
			}
			// No slot left: go on without a budget; the host saw
			// the refusal and draws the frame again with more.
			if (lid == 0u) {
				s_budget = 0xffffffffu;
				s_suspend = false;
			}
			memoryBarrierShared();
			barrier();
		}
	}
	if (!suspended) {
		if (asked && !p_done && !p_pending) {
			put_miss(px, g_n);
		}
		if (lid == 0u) {
			b_tile[tid].w = BC_TILE_FINISHED;
		}
	}
	atomicAdd(s_evals, g_evals - evals_before);
	memoryBarrierShared();
	barrier();
	if (lid == 0u) {
		atomicAdd(b_stat[BC_STAT_EVALS + tid % BC_STAT_EVAL_BUCKETS],
			  s_evals);
		if (s_over_m > 0u) {
			atomicAdd(b_stat[BC_STAT_OVER_M], s_over_m);
		}
		if (s_over_cache > 0u) {
			atomicAdd(b_stat[BC_STAT_OVER_CACHE], s_over_cache);
		}
		atomicAdd(b_stat[BC_STAT_RANGES], s_ranges);
		if (s_general > 0u) {
			atomicAdd(b_stat[BC_STAT_GENERAL], s_general);
		}
	}
}
