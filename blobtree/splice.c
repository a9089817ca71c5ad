/*
 * Structural edits without a new layout: an INSERT, a REMOVE or a REPLACE
 * splices the post-order arrays of struct bc_lin in place, and the result is
 * bit for bit the layout bc__lin_fill would build for the edited tree
 * (tests/blobtree/test_splice.c holds it to that).
 *
 * Why "splice with memmove and fix indices" and not a gap buffer, chunked
 * arrays or a rope: struct bc_lin is the renderers' contract -- flat
 * arrays indexed by slot, primitive and record, read in place and uploaded
 * whole -- and render/ must not change with this. Any of the other
 * structures would make every reader translate indices. A splice keeps
 * the arrays as they are: it moves each array's tail by the size of the
 * change (memmove, at memory bandwidth), adds that size to every stored
 * index past the edit point (one pass over the index arrays; the model's
 * nodes follow a log of the last splices when read, tree_impl.h), and
 * recomputes what depends on a slot's place in the
 * binary tree -- depth, fast and jump pointers, ROI, kill counts -- only
 * in the part of the edited operator's fold whose shape changed (its
 * operands left of the edit point: they sit one level deeper or higher).
 * ABVs are placed again only where a slot's ROI changed, and the scalars
 * follow from what changed: the box grows with new ABVs and is measured
 * again only when an ABV that touched it went or shrank; the evaluation
 * stack is the root's need, kept exact along the edited path (tree.c).
 * What stays linear in the scene: the tail move and the index pass, and
 * when an operand is added to or taken from the end of a wide operator,
 * the depth and jump pointers of every operand before it. These are
 * memory-speed passes; docs/benchmarks.md ("Structural edits spliced")
 * has their cost beside a full layout's.
 *
 * Trees with unary nodes are laid out whole (tree.c): their wrapper chains,
 * domain chains and twist and bend bounds reach across the tree.
 */
#include "tree_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

/* ---- room -------------------------------------------------------------- */

/* Grows array ptr to n entries of size bytes, or returns BC_ENOMEM (ptr
 * as it was). */
#define GROW(ptr, n, size)                                                     \
	do {                                                                   \
		void *grown_ = bc_reallocarray((ptr), (n), (size));            \
		if (!grown_) {                                                 \
			return BC_ENOMEM;                                      \
		}                                                              \
		(ptr) = grown_;                                                \
	} while (0)

/* A capacity of at least need, with room for the edits that follow. */
static uint32_t roomy(uint32_t cap, uint32_t need)
{
	uint64_t c = (uint64_t)cap + cap / 2u + 64u;
	if (c < need) {
		c = need;
	}
	return c > UINT32_MAX ? UINT32_MAX : (uint32_t)c;
}

/* A layout of spheres alone (struct bc_lin's sabv) that a splice brings
 * another kind into keeps whole ABVs from then on: converted once, here,
 * in room for cap primitives. */
static int whole_abvs(struct bc_lin *l, uint32_t cap)
{
	struct bc_abv *abv = bc_calloc(cap, sizeof(*abv));
	if (!abv) {
		return BC_ENOMEM;
	}
	for (uint32_t k = 0; k < l->nprims; k++) {
		abv[k] = bc_lin_abv(l, k);
	}
	bc_free(l->sabv);
	l->sabv = NULL;
	l->abv = abv;
	return 0;
}

/* The marks' words for cap slots. */
static size_t mark_words(uint32_t cap)
{
	return ((size_t)cap + 63u) / 64u;
}

int bc__lin_want_kills(struct bc_tree *t)
{
	struct bc_lin *l = &t->lin;
	if (!t->has_lin || l->kills) {
		return 0;
	}
	/* No intersection or difference so far (and no unary node: this
	 * layout splices): every count and every r- is 0. */
	if (!l->roi_lo) {
		l->roi_lo =
		    bc_calloc(t->lin_cap ? t->lin_cap : 1u, sizeof(float));
		if (!l->roi_lo) {
			return BC_ENOMEM;
		}
	}
	l->kills = bc_calloc(t->lin_cap ? t->lin_cap : 1u, sizeof(uint32_t));
	return l->kills ? 0 : BC_ENOMEM;
}

int bc__splice_reserve(struct bc_tree *t, uint32_t count, uint32_t nprims,
                       uint32_t nparam, bool others, bool kills)
{
	struct bc_lin *l = &t->lin;
	if (count > t->lin_cap) {
		uint32_t c = roomy(t->lin_cap, count);
		size_t had = mark_words(t->lin_cap);
		GROW(l->node, c, 2 * sizeof(uint32_t));
		GROW(l->lead, c, sizeof(uint32_t));
		GROW(l->fast, c, sizeof(uint32_t));
		GROW(l->jump, c, sizeof(uint32_t));
		if (l->kills) {
			GROW(l->kills, c, sizeof(uint32_t));
		}
		GROW(l->marks, mark_words(c), sizeof(uint64_t));
		memset(l->marks + had, 0,
		       (mark_words(c) - had) * sizeof(uint64_t));
		GROW(l->depth, c, sizeof(uint32_t));
		GROW(l->node_id, c, sizeof(uint32_t));
		if (l->roi_lo) {
			GROW(l->roi_lo, c, sizeof(float));
		}
		GROW(l->roi_hi, c, sizeof(float));
		if (l->wrap) {
			/* Kept by a layout whose tree had unary nodes. */
			GROW(l->wrap, c, sizeof(uint32_t));
			GROW(l->wrap_top, c, sizeof(uint32_t));
			GROW(l->dom, c, sizeof(uint32_t));
			GROW(l->ucount, c, sizeof(uint32_t));
		}
		t->lin_cap = c;
	}
	if (nprims > t->lin_kcap) {
		uint32_t c = roomy(t->lin_kcap, nprims);
		GROW(l->prim_slot, c, sizeof(uint32_t));
		if (l->abv) {
			GROW(l->abv, c, sizeof(struct bc_abv));
		} else {
			GROW(l->sabv, c, sizeof(*l->sabv));
		}
		GROW(l->color, c, sizeof(*l->color));
		t->lin_kcap = c;
	}
	if (others && l->sabv) {
		int rc = whole_abvs(l, t->lin_kcap);
		if (rc) {
			return rc;
		}
	}
	if (kills) {
		int rc = bc__lin_want_kills(t);
		if (rc) {
			return rc;
		}
	}
	if (nparam > t->lin_pcap) {
		uint32_t c = roomy(t->lin_pcap, nparam);
		GROW(l->param, c, 4 * sizeof(float));
		t->lin_pcap = c;
	}
	return 0;
}

/* ---- moving and renumbering --------------------------------------------- */

/* One splice of slots, records (vec4 units) and primitives. keep_first:
 * operators' first slots (lead[]) equal to s.at keep pointing there (an
 * operand inserted at the very left of a subtree becomes its first slot).
 * relinked: the caller's relink() computes the fast and jump pointers of
 * the slots from relink_lo on again (its range runs past the point), so
 * apply() need not renumber those before the point: at the root's wide
 * operator that is every slot, a pass over the whole layout saved.
 * unlogged: the caller logs the shift for the model's nodes itself (it
 * stands for two, bc__splice_insert). */
struct splice {
	struct bc__span s, p, k;
	bool keep_first;
	bool relinked;
	uint32_t relink_lo;
	bool unlogged;
};

static void move_tail(void *base, size_t size, uint32_t n,
                      const struct bc__span *sp)
{
	char *b = base;
	size_t tail = (size_t)n - sp->at - sp->del;
	if (sp->del != sp->ins && tail > 0) {
		memmove(b + (size_t)(sp->at + sp->ins) * size,
		        b + (size_t)(sp->at + sp->del) * size, tail * size);
	}
}

/* Renumbers n indices v[0], v[stride], ... through sp (BC_NONE kept). */
static void renumber(uint32_t *v, size_t n, size_t stride,
                     const struct bc__span *sp)
{
	uint32_t at = sp->at, hi = sp->at + sp->del;
	uint32_t shift = sp->ins - sp->del; /* modulo 2^32 */
	if (sp->del == 0 && sp->ins == 0) {
		return;
	}
	for (size_t i = 0; i < n; i++) {
		uint32_t x = v[i * stride];
		uint32_t y = x >= hi ? x + shift : (x >= at ? at : x);
		v[i * stride] = x == BC_NONE ? x : y;
	}
}

/* The first primitive whose slot is at or past slot s (primitives are in
 * slot order). */
static uint32_t prim_from(const struct bc_lin *l, uint32_t s)
{
	uint32_t lo = 0, hi = l->nprims;
	while (lo < hi) {
		uint32_t mid = lo + (hi - lo) / 2;
		if (l->prim_slot[mid] < s) {
			lo = mid + 1;
		} else {
			hi = mid;
		}
	}
	return lo;
}

/* Notes the splice for the model's nodes to follow when read (struct
 * bc_tree's shift log, a ring). First the next 1 / BC__SWEEP of the pool
 * is brought up to date: a cursor that passes over the whole pool at
 * least once per BC__SWEEP splices (a pool that grows meanwhile makes
 * the shares larger), so a node lags at most about 2 * BC__SWEEP
 * splices, and the entry the ring overwrites (BC__SHIFTS back) is
 * followed by none. */
static void log_shift(struct bc_tree *t, const struct splice *sp)
{
	uint32_t n = t->npool, i = t->sweep < n ? t->sweep : 0;
	uint32_t share = n / BC__SWEEP + 1u;
	for (uint32_t k = 0; k < share && k < n; k++) {
		if (t->pool[i].live) {
			bc__refresh(t, &t->pool[i]);
		}
		i = i + 1u == n ? 0 : i + 1u;
	}
	t->sweep = i;
	t->shift[t->epoch % BC__SHIFTS] =
	    (struct bc__shift){.s = sp->s, .p = sp->p, .k = sp->k};
	t->epoch++;
}

/* ---- what the dirty record says of a splice ------------------------------ */

/* Whether the dirty record lists splices: a structure change that
 * starts with this one does. */
static bool following(struct bc_tree *t)
{
	struct bc_dirty *d = &t->dirty;
	if (!d->structure) {
		d->structure = true;
		d->spliced = true;
	}
	return d->spliced;
}

/* The dirty record follows a splice of the primitives' indices: the
 * splice is listed (spliced, while there is room), and the range of dirty
 * primitives moves with them. A record of a whole layout stays one. */
static void note_splice(struct bc_tree *t, const struct bc__span *k)
{
	struct bc_dirty *d = &t->dirty;
	struct bc_dirty_splice sp = {.at = k->at, .del = k->del, .ins = k->ins};
	bool listed = following(t);
	if (k->del == 0 && k->ins == 0) {
		return;
	}
	bc_dirty_splice_range(&sp, &d->prim_lo, &d->prim_hi);
	if (!listed) {
		return;
	}
	if (d->nsplices == BC_DIRTY_SPLICES) {
		d->spliced = false;
		return;
	}
	d->splice[d->nsplices++] = sp;
}

/* Primitives k .. k + n - 1 go, or are placed again: their ABVs now are
 * where pixels can change. */
static void note_gone(struct bc_tree *t, uint32_t k, uint32_t n)
{
	struct bc_dirty *d = &t->dirty;
	if (!following(t)) {
		return;
	}
	if (n > BC_DIRTY_GONE - d->ngone) {
		d->spliced = false;
		return;
	}
	for (uint32_t i = 0; i < n; i++) {
		d->gone[d->ngone++] = bc_lin_abv(&t->lin, k + i);
	}
}

/* An operand that reaches no pixel leaves a union's value alone, but
 * makes an intersection's or a difference's nothing (renderers prune it
 * that way): an operand added to or taken from such an operator changes
 * pixels wherever its other operands are. Marks every primitive of the
 * subtree under slot top dirty then. */
static void note_operands(struct bc_tree *t, uint32_t op, uint32_t top)
{
	const struct bc_lin *l = &t->lin;
	uint32_t first, k;
	if (op == BC_OP_UNION || op == BC_OP_SMOOTH_UNION) {
		return;
	}
	first = bc_lin_first(l, top);
	k = bc_lin_leaf_prim(l, first);
	bc__dirty_range(&t->dirty.prim_lo, &t->dirty.prim_hi, k,
	                k + (top - first) / 2 + 1);
}

/* Moves every array's tail (room reserved) and renumbers every stored
 * index of the layout (the model's nodes follow the log). The new entries are
 * left for the caller to write. What lies before the splice point keeps
 * its first slot, record and primitive (they come before in both
 * post-order and pre-order); only its pointers up the tree (ancestor,
 * fast, jump) may cross the point. */
static void apply(struct bc_tree *t, const struct splice *sp)
{
	struct bc_lin *l = &t->lin;
	uint32_t n = l->count, np = l->nprims, nr = l->nparam;
	uint32_t tail, ktail;
	/* A splice at the very end of all three spaces moves no entry that
	 * stays, so no node of the model has an index to follow: it needs
	 * no place in the shift log, and the log's sweep (a share of the
	 * pool brought up to date, some 8 % of an end edit at a million)
	 * is spared. */
	bool at_end = sp->s.at + sp->s.del == n && sp->p.at + sp->p.del == nr &&
	              sp->k.at + sp->k.del == np;
	note_splice(t, &sp->k);
	move_tail(l->node, 2 * sizeof(uint32_t), n, &sp->s);
	move_tail(l->lead, sizeof(uint32_t), n, &sp->s);
	move_tail(l->fast, sizeof(uint32_t), n, &sp->s);
	move_tail(l->jump, sizeof(uint32_t), n, &sp->s);
	if (l->kills) {
		move_tail(l->kills, sizeof(uint32_t), n, &sp->s);
	}
	move_tail(l->depth, sizeof(uint32_t), n, &sp->s);
	move_tail(l->node_id, sizeof(uint32_t), n, &sp->s);
	if (l->roi_lo) {
		move_tail(l->roi_lo, sizeof(float), n, &sp->s);
	}
	move_tail(l->roi_hi, sizeof(float), n, &sp->s);
	if (l->wrap) {
		move_tail(l->wrap, sizeof(uint32_t), n, &sp->s);
		move_tail(l->wrap_top, sizeof(uint32_t), n, &sp->s);
		move_tail(l->dom, sizeof(uint32_t), n, &sp->s);
		move_tail(l->ucount, sizeof(uint32_t), n, &sp->s);
	}
	move_tail(l->prim_slot, sizeof(uint32_t), np, &sp->k);
	if (l->abv) {
		move_tail(l->abv, sizeof(struct bc_abv), np, &sp->k);
	} else {
		move_tail(l->sabv, sizeof(*l->sabv), np, &sp->k);
	}
	move_tail(l->color, sizeof(*l->color), np, &sp->k);
	move_tail(l->param, 4 * sizeof(float), nr, &sp->p);
	l->count = n - sp->s.del + sp->s.ins;
	l->nprims = np - sp->k.del + sp->k.ins;
	l->nparam = nr - sp->p.del + sp->p.ins;
	tail = sp->s.at + sp->s.ins;
	if (sp->s.del == sp->s.ins && sp->p.del == sp->p.ins &&
	    sp->k.del == sp->k.ins) {
		/* A block for one of the same size (a REPLACE): nothing moved,
		 * and nothing outside the block pointed into it but at its
		 * first slot, which stays. */
		return;
	}

	if (sp->s.del == 0 && sp->s.at == n) {
		/* Slots added after every other (an operand appended to the
		 * root's operator, the usual edit of a big scene): no stored
		 * index reaches the point, and nothing moved. The new slots'
		 * and their ancestors' pointers are the caller's (relink). */
		if (!sp->unlogged && !at_end) {
			log_shift(t, sp);
		}
		return;
	}
	/* Pointers up, everywhere but the new entries. */
	for (uint32_t s = 0; s < l->count; s++) {
		uint32_t w = l->node[2 * s], a = w & BC_WORD_ANCESTOR_MASK;
		if (s == sp->s.at && sp->s.ins > 0) {
			s = tail - 1;
			continue;
		}
		if (a != BC_WORD_NO_ANCESTOR && a >= sp->s.at) {
			l->node[2 * s] = (w & ~BC_WORD_ANCESTOR_MASK) |
			                 bc__span_map(&sp->s, a);
		}
	}
	{
		uint32_t keep = sp->relinked && sp->relink_lo < sp->s.at
		                    ? sp->relink_lo
		                    : sp->s.at;
		renumber(l->fast, keep, 1, &sp->s);
		renumber(l->jump, keep, 1, &sp->s);
	}
	renumber(l->fast + tail, l->count - tail, 1, &sp->s);
	renumber(l->jump + tail, l->count - tail, 1, &sp->s);
	/* First slots, records and primitives, past the point. */
	renumber(l->node + 2 * (size_t)tail + 1, l->count - tail, 2, &sp->p);
	for (uint32_t s = tail; s < l->count; s++) {
		uint32_t *v = &l->lead[s];
		if (bc_lin_is_leaf(l, s)) {
			renumber(v, 1, 1, &sp->k); /* its primitive */
		} else if (!(sp->keep_first && *v == sp->s.at)) {
			*v = bc__span_map(&sp->s, *v); /* its first slot */
		}
	}
	/* Primitives past the point: past the new ones, or found in the
	 * (then unmoved, increasing) slots. */
	ktail = sp->k.del || sp->k.ins ? sp->k.at + sp->k.ins
	                               : prim_from(l, sp->s.at);
	renumber(l->prim_slot + ktail, l->nprims - ktail, 1, &sp->s);
	if (!sp->unlogged && !at_end) {
		log_shift(t, sp);
	}
}

/* Moves per-slot entry [from, from + n) of every array to `to`. */
static void slots_move(struct bc_lin *l, uint32_t to, uint32_t from, uint32_t n)
{
	uint32_t *const four[] = {l->lead,  l->fast,    l->jump, l->kills,
	                          l->depth, l->node_id, l->wrap, l->wrap_top,
	                          l->dom,   l->ucount};
	float *const fl[] = {l->roi_lo, l->roi_hi};
	memmove(l->node + 2 * (size_t)to, l->node + 2 * (size_t)from,
	        2 * (size_t)n * sizeof(uint32_t));
	for (size_t i = 0; i < sizeof(four) / sizeof(four[0]); i++) {
		if (four[i]) {
			memmove(four[i] + to, four[i] + from,
			        (size_t)n * sizeof(uint32_t));
		}
	}
	for (size_t i = 0; i < sizeof(fl) / sizeof(fl[0]); i++) {
		if (fl[i]) {
			memmove(fl[i] + to, fl[i] + from,
			        (size_t)n * sizeof(float));
		}
	}
}

/* The n slots of a subtree at from .. from + n - 1 move one place: up,
 * over the slot after them, or down, over the slot before them. Their
 * entries, what among them points into them (ancestors, operators' first
 * slots) and the slots of their primitives, from kp on, follow. Nothing
 * outside points into a subtree but at its first slot (ancestors lie
 * after it), which the caller sets (refirst(), keep_first), as it
 * computes their fast and jump pointers again (relink()). */
static void nudge(struct bc_lin *l, uint32_t from, uint32_t n, uint32_t kp,
                  bool up)
{
	uint32_t to = up ? from + 1u : from - 1u;
	uint32_t d = to - from; /* +1 or -1, modulo 2^32 */
	slots_move(l, to, from, n);
	for (uint32_t i = to; i < to + n; i++) {
		uint32_t w = l->node[2 * i], a = w & BC_WORD_ANCESTOR_MASK;
		if (a != BC_WORD_NO_ANCESTOR && a - from < n) {
			l->node[2 * i] = (w & ~BC_WORD_ANCESTOR_MASK) | (a + d);
		}
		if (!bc_lin_is_leaf(l, i) && l->lead[i] - from < n) {
			l->lead[i] += d;
		}
	}
	for (uint32_t k = kp; k < kp + (n + 1u) / 2u; k++) {
		l->prim_slot[k] += d;
	}
}

/* ---- what depends on the place in the tree ------------------------------ */

/* Does the AABB of primitive k's ABV touch l's box (so that the box may
 * shrink when the ABV goes or changes)? */
static bool touches_box(const struct bc_lin *l, uint32_t k)
{
	float lo[3], hi[3];
	struct bc_abv a = bc_lin_abv(l, k);
	bc_abv_aabb(&a, lo, hi);
	for (int i = 0; i < 3; i++) {
		if (lo[i] <= l->lo[i] || hi[i] >= l->hi[i]) {
			return true;
		}
	}
	return false;
}

static bool same_bits(float a, float b)
{
	return memcmp(&a, &b, sizeof(a)) == 0;
}

/* Marks slot s for relink(): its ROI and counts must be computed again. */
static void again(struct bc_lin *l, uint32_t s)
{
	l->marks[s / 64u] |= 1ull << (s % 64u);
}

/* Clears slot s's mark (again). */
static void clear_mark(struct bc_lin *l, uint32_t s)
{
	l->marks[s / 64u] &= ~(1ull << (s % 64u));
}

/* The highest marked slot in [lo, s], BC_NONE when none: a word of the
 * bitmap at a time, so that a relink over a million slots with a few
 * marks reads 16 000 words, not a million bits one by one. */
static uint32_t prev_mark(const struct bc_lin *l, uint32_t s, uint32_t lo)
{
	uint32_t w = s / 64u;
	uint64_t bits = l->marks[w] & (~0ull >> (63u - s % 64u));
	for (;;) {
		if (bits) {
			uint32_t hit =
			    w * 64u + 63u - (uint32_t)__builtin_clzll(bits);
			return hit >= lo ? hit : BC_NONE;
		}
		if (w * 64u <= lo) {
			return BC_NONE;
		}
		bits = l->marks[--w];
	}
}

/* First slots of the operators of slots lo..hi (whose operands are there too)
 * from the bottom up: an operator's left operand ends where its right one
 * starts. */
static void refirst(struct bc_lin *l, uint32_t lo, uint32_t hi)
{
	for (uint32_t s = lo; s <= hi; s++) {
		if (!bc_lin_is_leaf(l, s)) {
			l->lead[s] =
			    bc_lin_first(l, bc_lin_first(l, s - 1) - 1);
		}
	}
}

/*
 * The subtree of slots [lo, top], whose top's parent is final, from the
 * top down: depth and pointers everywhere (a depth changed), ROIs and
 * counts where marked (again(): the top, the new slots [new_lo, new_hi), and
 * what the caller marked: slots whose parent or side changed), and below
 * every slot whose ROI or counts came out different, as the full layout
 * computes them (bc__lin_pointers, bc__lin_propagate). ABVs of new
 * primitives and of those whose ROI changed are placed again. Returns
 * whether an ABV that touched the box changed.
 */
static bool relink(struct bc_tree *t, uint32_t lo, uint32_t top,
                   uint32_t new_lo, uint32_t new_hi)
{
	struct bc_lin *l = &t->lin;
	bool touch = false;
	again(l, top);
	for (uint32_t s = new_lo; s < new_hi; s++) {
		again(l, s);
	}
	/* Depth and pointers need only the parent's, and so do ROIs and
	 * counts: two passes, the second reading the marks only. */
	bc__lin_pointers_down(l, lo, top);
	/* Marks are only ever set below the slot at hand. */
	for (uint32_t s = prev_mark(l, top, lo); s != BC_NONE;
	     s = s > lo ? prev_mark(l, s - 1u, lo) : BC_NONE) {
		float r0, r1;
		uint32_t kills, uc, dom;
		bool fresh, changed;
		clear_mark(l, s);
		kills = bc_lin_kills(l, s);
		r0 = bc_lin_roi_lo(l, s);
		r1 = l->roi_hi[s];
		uc = bc_lin_ucount(l, s);
		dom = bc_lin_dom(l, s);
		fresh = s >= new_lo && s < new_hi;
		bc__lin_propagate(l, s);
		changed = !same_bits(r0, bc_lin_roi_lo(l, s)) ||
		          !same_bits(r1, l->roi_hi[s]) ||
		          kills != bc_lin_kills(l, s) ||
		          uc != bc_lin_ucount(l, s) || dom != bc_lin_dom(l, s);
		if (!bc_lin_is_leaf(l, s)) {
			if (changed) {
				again(l, s - 1);
				again(l, bc_lin_first(l, s - 1) - 1);
			}
			continue;
		}
		if (fresh || !same_bits(r1, l->roi_hi[s])) {
			uint32_t k = bc_lin_leaf_prim(l, s);
			uint32_t n = bc__id_find(t, l->node_id[s]);
			if (!fresh && touches_box(l, k)) {
				touch = true;
			}
			if (!fresh) {
				note_gone(t, k, 1);
			}
			bc__dirty_range(&t->dirty.prim_lo, &t->dirty.prim_hi, k,
			                k + 1);
			struct bc_prim_data pd;
			bc__prim_read(t, &t->pool[n], &pd);
			bc__lin_place_abv(t, l, k, &pd);
		}
	}
	return touch;
}

void bc__splice_finish(struct bc_tree *t, bool touch)
{
	struct bc_lin *l = &t->lin;
	if (touch) {
		/* The box as the full layout measures it: every ABV in
		 * order. */
		for (int i = 0; i < 3; i++) {
			l->lo[i] = INFINITY;
			l->hi[i] = -INFINITY;
		}
		for (uint32_t k = 0; k < l->nprims; k++) {
			float lo[3], hi[3];
			struct bc_abv a = bc_lin_abv(l, k);
			bc_abv_aabb(&a, lo, hi);
			for (int i = 0; i < 3; i++) {
				l->lo[i] = fminf(l->lo[i], lo[i]);
				l->hi[i] = fmaxf(l->hi[i], hi[i]);
			}
		}
	}
	bc__lin_update_size(l);
	l->stack = t->pool[t->root].need;
	l->lip = 1.0f;
	t->dirty.structure = true;
	t->dirty.edits++;
}

/* Gives slot s the parent and side of a node word w whose ancestor is now
 * slot a (BC_WORD_NO_ANCESTOR: s becomes the root). */
static void adopt(struct bc_lin *l, uint32_t s, uint32_t w, uint32_t a)
{
	l->node[2 * s] &= ~(BC_WORD_LEFT | BC_WORD_ANCESTOR_MASK);
	l->node[2 * s] |= (w & BC_WORD_LEFT) | a;
}

/* The rightmost leaf of the subtree at pool node n (last in pre-order:
 * its record ends the subtree's records). */
static uint32_t last_leaf(const struct bc_tree *t, uint32_t n)
{
	while (t->pool[n].is_op) {
		n = t->pool[n].u.last_child;
	}
	return n;
}

/* Where the records of the subtree at pool node n end: after its
 * rightmost leaf's, whose size its kind gives. */
static uint32_t records_end(const struct bc_tree *t, uint32_t n)
{
	const struct bc__node *leaf = &t->pool[last_leaf(t, n)];
	return bc__param(t, leaf) + bc_prim_record_vec4(leaf->pkind);
}

/* ---- insert ------------------------------------------------------------- */

/*
 * Pool node m (px primitives, records of rx vec4, no unary nodes) was linked as
 * a child of operator P. Its slots come in as a block with one new fold
 * f = (left op m): after the fold of the child before it, or, for the
 * first child, before the old first child c0, whose fold (m op c0) comes
 * after c0. The operands left of the edit point (the subtree of f) are
 * linked again; nothing right of it or above P changes but its indices.
 * Returns whether an ABV that touched the box changed (the first child
 * changes sides).
 */
bool bc__splice_insert(struct bc_tree *t, uint32_t m, uint32_t px, uint32_t rx)
{
	struct bc_lin *l = &t->lin;
	uint32_t p = t->pool[m].parent, prev = t->pool[m].prev;
	uint32_t next = t->pool[m].next;
	uint32_t sx = 2 * px - 1;
	struct bc__fill fs = {.l = l};
	uint32_t f, lo, block;
	bool touch;
	if (prev != BC_NONE) {
		uint32_t last = last_leaf(t, prev);
		uint32_t s0 = bc__slot(t, &t->pool[prev]) + 1 +
		              (t->pool[prev].prev != BC_NONE ? 1u : 0u);
		uint32_t old_top = bc__slot(t, &t->pool[p]);
		uint32_t w = l->node[2 * old_top];
		/* relink() below takes [first of s0 - 1, f]; what lies before
		 * the point keeps its first slot. */
		struct splice sp = {
		    .s = {s0, 0, sx + 1},
		    .p = {records_end(t, last), 0, rx},
		    .k = {bc__prim(t, &t->pool[last]) + 1, 0, px},
		    .relinked = true,
		    .relink_lo = bc_lin_first(l, s0 - 1)};
		apply(t, &sp);
		fs.slot = s0;
		fs.prim = sp.k.at;
		fs.param = sp.p.at;
		bc__lin_emit(t, &fs, m);
		f = s0 + sx;
		bc__lin_fold(l, &t->pool[p], bc__refresh(t, &t->pool[p])->param,
		             s0 - 1, f - 1, f);
		again(l, s0 - 1);
		if (next == BC_NONE) {
			/* f is P's new top, where the old one was. */
			uint32_t a = w & BC_WORD_ANCESTOR_MASK;
			adopt(l, f, w,
			      a == BC_WORD_NO_ANCESTOR
			          ? a
			          : bc__span_map(&sp.s, a));
			bc__refresh(t, &t->pool[p])->slot = f;
		} else {
			bc__lin_set_parent(
			    l, f, bc__slot(t, &t->pool[next]) + 1, true);
		}
		lo = bc_lin_first(l, s0 - 1);
		block = s0;
	} else {
		uint32_t c0 = next, c0top = bc__slot(t, &t->pool[c0]);
		uint32_t first = bc_lin_first(l, c0top);
		struct splice fold = {.s = {c0top + 1, 0, 1}};
		struct splice sp = {
		    .s = {first, 0, sx},
		    .p = {bc__param(t, &t->pool[p]) + BC_OP_RECORD_VEC4, 0, rx},
		    .k = {bc_lin_leaf_prim(l, first), 0, px},
		    .keep_first = true};
		/* The block before c0 and the fold after it, in one move of
		 * the arrays' tail, not two: everything from first on moves
		 * sx + 1 places, then c0's slots come back one, to where the
		 * block ends, and the spare slot after them is the fold's.
		 * The model's nodes follow the two splices this stands for. */
		struct splice both = sp;
		both.s.ins = sx + 1;
		both.unlogged = true;
		apply(t, &both);
		nudge(l, first + sx + 1, c0top - first + 1, sp.k.at + px,
		      false);
		log_shift(t, &fold);
		log_shift(t, &sp);
		fs.slot = first;
		fs.prim = sp.k.at;
		fs.param = sp.p.at;
		bc__lin_emit(t, &fs, m);
		c0top = bc__slot(t, &t->pool[c0]);
		f = c0top + 1;
		refirst(l, first + sx, c0top);
		bc__lin_fold(l, &t->pool[p], bc__refresh(t, &t->pool[p])->param,
		             first + sx - 1, c0top, f);
		again(l, c0top);
		bc__lin_set_parent(
		    l, f, bc__slot(t, &t->pool[t->pool[c0].next]) + 1, true);
		lo = first;
		block = first;
	}
	touch = relink(t, lo, f, block, block + sx);
	note_operands(t, t->pool[p].u.op.kind, bc__slot(t, &t->pool[p]));
	return touch;
}

/* ---- remove -------------------------------------------------------------- */

/*
 * Takes pool node c's slots, records and primitives out of the layout
 * before the model drops it (tree.c cuts it next), with the fold that
 * joined it -- or, when its parent P had two children, P's only fold and
 * record, the other child taking P's place. The operands that were left
 * of c in P's fold (or the child that stays) are linked again. Returns
 * whether an ABV that touched the box went or changed.
 */
/* ---- replace ------------------------------------------------------------ */

void bc__splice_note(struct bc_tree *t, uint32_t c, struct bc__block *b)
{
	struct bc_lin *l = &t->lin;
	b->top = bc__slot(t, &t->pool[c]);
	b->first = bc_lin_first(l, b->top);
	b->word = l->node[2 * b->top];
	b->param = bc__param(t, &t->pool[c]);
	b->pend = records_end(t, c);
	b->k = bc_lin_leaf_prim(l, b->first);
	b->nprims = (b->top - b->first) / 2 + 1;
	b->touch = false;
	for (uint32_t k = b->k; k < b->k + b->nprims && !b->touch; k++) {
		b->touch = touches_box(l, k);
	}
}

bool bc__splice_replace(struct bc_tree *t, const struct bc__block *b,
                        uint32_t m, uint32_t px, uint32_t rx)
{
	struct bc_lin *l = &t->lin;
	uint32_t sx = 2 * px - 1, a = b->word & BC_WORD_ANCESTOR_MASK;
	struct bc__fill fs = {
	    .l = l, .slot = b->first, .prim = b->k, .param = b->param};
	struct splice sp = {.s = {b->first, b->top - b->first + 1, sx},
	                    .p = {b->param, b->pend - b->param, rx},
	                    .k = {b->k, b->nprims, px}};
	note_gone(t, b->k, b->nprims);
	apply(t, &sp);
	bc__lin_emit(t, &fs, m);
	adopt(l, b->first + sx - 1, b->word,
	      a == BC_WORD_NO_ANCESTOR ? a : bc__span_map(&sp.s, a));
	return relink(t, b->first, b->first + sx - 1, b->first,
	              b->first + sx) ||
	       b->touch;
}

bool bc__splice_remove(struct bc_tree *t, uint32_t c)
{
	struct bc_lin *l = &t->lin;
	uint32_t p = t->pool[c].parent, nkids = t->pool[p].u.nchildren;
	uint32_t prev = t->pool[c].prev, next = t->pool[c].next;
	struct bc__block b;
	uint32_t ctop, cf, cparam, px, klo, pend, ptop, w, a, top;
	struct splice one = {0}, two = {0};
	bool touch;
	bc__splice_note(t, c, &b);
	ctop = b.top;
	cf = b.first;
	cparam = b.param;
	px = b.nprims;
	klo = b.k;
	pend = b.pend;
	touch = b.touch;
	ptop = bc__slot(t, &t->pool[p]);
	w = l->node[2 * ptop];
	a = w & BC_WORD_ANCESTOR_MASK;
	note_gone(t, klo, px);
	if (nkids >= 3 && prev != BC_NONE) {
		/* c's block and its fold go; the fold below takes over, and
		 * relink() below takes [first of cf - 1, cf - 1]. */
		one = (struct splice){.s = {cf, ctop - cf + 2, 0},
		                      .p = {cparam, pend - cparam, 0},
		                      .k = {klo, px, 0},
		                      .relinked = true,
		                      .relink_lo = bc_lin_first(l, cf - 1)};
		apply(t, &one);
		top = cf - 1;
		if (next != BC_NONE) {
			bc__lin_set_parent(
			    l, top, bc__slot(t, &t->pool[next]) + 1, true);
		} else {
			adopt(l, top, w,
			      a == BC_WORD_NO_ANCESTOR
			          ? a
			          : bc__span_map(&one.s, a));
			bc__refresh(t, &t->pool[p])->slot = top;
		}
	} else if (nkids >= 3) {
		/* The first child and the fold (c op c1) go: c1 is first.
		 * Both in one move of the arrays' tail, not two: c1's slots
		 * first take the fold's place, one to the right, so that c's
		 * block and the slot they left are one run to take out. The
		 * model's nodes follow the two splices this stands for. */
		uint32_t c1top = bc__slot(t, &t->pool[next]);
		struct splice both;
		one = (struct splice){.s = {c1top + 1, 1, 0}};
		two = (struct splice){.s = {cf, ctop - cf + 1, 0},
		                      .p = {cparam, pend - cparam, 0},
		                      .k = {klo, px, 0}};
		both = two;
		both.s.del++;
		both.unlogged = true;
		nudge(l, ctop + 1, c1top - ctop, klo + px, true);
		apply(t, &both);
		log_shift(t, &one);
		log_shift(t, &two);
		top = bc__slot(t, &t->pool[next]);
		bc__lin_set_parent(
		    l, top, bc__slot(t, &t->pool[t->pool[next].next]) + 1,
		    true);
	} else {
		/* P goes with c: its fold and record; the other child takes
		 * P's place. */
		uint32_t sib = prev != BC_NONE ? prev : next;
		uint32_t rec = bc__param(t, &t->pool[p]);
		if (prev != BC_NONE) {
			one = (struct splice){.s = {cf, ctop - cf + 2, 0},
			                      .p = {cparam, pend - cparam, 0},
			                      .k = {klo, px, 0}};
			two = (struct splice){.p = {rec, BC_OP_RECORD_VEC4, 0}};
		} else {
			one = (struct splice){.s = {ptop, 1, 0}};
			two = (struct splice){.s = {cf, ctop - cf + 1, 0},
			                      .p = {rec, pend - rec, 0},
			                      .k = {klo, px, 0}};
		}
		apply(t, &one);
		apply(t, &two);
		top = bc__slot(t, &t->pool[sib]);
		if (a != BC_WORD_NO_ANCESTOR) {
			a = bc__span_map(&two.s, bc__span_map(&one.s, a));
		}
		adopt(l, top, w, a);
	}
	touch = relink(t, bc_lin_first(l, top), top, 0, 0) || touch;
	note_operands(t, t->pool[p].u.op.kind,
	              nkids >= 3 ? bc__slot(t, &t->pool[p]) : top);
	return touch;
}
