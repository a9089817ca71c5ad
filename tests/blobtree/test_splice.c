/*
 * Structural edits splice the layout in place (blobtree/splice.c): after
 * every one of a long random run of INSERTs, REMOVEs and REPLACEs the
 * layout equals, bit for bit, a full layout of the same tree; the model's
 * slots and records stay right for the parameter edits that follow; and a
 * structural batch refused part way (applied in place, edit/batch.c)
 * leaves the tree exactly as it was.
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/edit.h"
#include "blobcast/scene.h"
#include "test.h"

#include "randtree.h"

static bool same(const void *a, const void *b, size_t bytes)
{
	return bytes == 0 || memcmp(a, b, bytes) == 0;
}

/* Where a's layout differs from b's, or NULL: every array, bit for bit,
 * every scalar, and the slot each node id maps to; box_grown: a's box
 * need only hold b's (a parameter edit followed it). */
static const char *lin_differs_box(const struct bc_tree *ta,
                                   const struct bc_tree *tb, bool box_grown)
{
	const struct bc_lin *a = bc_tree_lin(ta), *b = bc_tree_lin(tb);
	size_t n, k, u;
	if (!a || !b) {
		return a == b ? NULL : "one layout is missing";
	}
	if (a->count != b->count || a->nprims != b->nprims ||
	    a->nparam != b->nparam || a->nunary != b->nunary) {
		return "counts";
	}
	n = a->count;
	k = a->nprims;
	u = a->nunary;
	if (a->stack != b->stack || a->nesting != b->nesting) {
		return "stack or nesting";
	}
	if (box_grown) {
		/* A parameter edit only grows the box (a shrinking ABV would
		 * need every other measured again): it holds the exact one. */
		for (int i = 0; i < 3; i++) {
			if (!(a->lo[i] <= b->lo[i] && a->hi[i] >= b->hi[i])) {
				return "box (not holding the exact one)";
			}
		}
	} else if (!same(a->lo, b->lo, sizeof(a->lo)) ||
	           !same(a->hi, b->hi, sizeof(a->hi)) ||
	           !same(&a->size, &b->size, sizeof(a->size))) {
		return "box";
	}
	if (!same(&a->lip, &b->lip, sizeof(a->lip))) {
		return "Lipschitz bound";
	}
	if (!same(a->node, b->node, 2 * n * sizeof(uint32_t))) {
		return "node words";
	}
	if (!same(a->lead, b->lead, n * 4) || !same(a->fast, b->fast, n * 4) ||
	    !same(a->jump, b->jump, n * 4) ||
	    !same(a->depth, b->depth, n * 4)) {
		return "first, fast, jump or depth";
	}
	/* Kill counts may be kept or not (none for a tree laid out without
	 * an intersection or a difference): the values must agree. */
	for (uint32_t s = 0; s < n; s++) {
		float lo_a = bc_lin_roi_lo(a, s), lo_b = bc_lin_roi_lo(b, s);
		if (bc_lin_kills(a, s) != bc_lin_kills(b, s)) {
			return "kills";
		}
		if (!same(&lo_a, &lo_b, sizeof(lo_a))) {
			return "ROIs (r-)";
		}
	}
	if (!same(a->node_id, b->node_id, n * 4) ||
	    !same(a->roi_hi, b->roi_hi, n * sizeof(float))) {
		return "ids or ROIs (r+)";
	}
	/* A layout may keep these arrays or not (none for a tree that had no
	 * unary node when it was laid out): the values must agree. */
	for (uint32_t s = 0; s < n; s++) {
		if (bc_lin_wrap(a, s) != bc_lin_wrap(b, s) ||
		    bc_lin_wrap_top(a, s) != bc_lin_wrap_top(b, s) ||
		    bc_lin_dom(a, s) != bc_lin_dom(b, s) ||
		    bc_lin_ucount(a, s) != bc_lin_ucount(b, s)) {
			return "wrappers";
		}
	}
	if (!same(a->prim_slot, b->prim_slot, k * 4) ||
	    !same(a->color, b->color, k * sizeof(*a->color))) {
		return "primitive slots or colours";
	}
	/* A layout of spheres alone that a splice brought another kind into
	 * keeps whole ABVs, one laid out again may not: the ABVs must
	 * agree. */
	for (size_t i = 0; i < k; i++) {
		struct bc_abv x = bc_lin_abv(a, (uint32_t)i),
		              y = bc_lin_abv(b, (uint32_t)i);
		if (!same(&x, &y, sizeof(x))) {
			return "ABVs";
		}
	}
	if (!same(a->param, b->param, 4 * (size_t)a->nparam * sizeof(float))) {
		return "parameter records";
	}
	if (!same(a->unary_slot, b->unary_slot, u * 4) ||
	    !same(a->unary_param, b->unary_param, u * 4) ||
	    !same(a->unary_dom, b->unary_dom, u * 4)) {
		return "unary nodes";
	}
	for (size_t s = 0; s < n; s++) {
		uint32_t id = a->node_id[s], p = bc_tree_parent(ta, id);
		if (bc_tree_slot(ta, id) != bc_tree_slot(tb, id)) {
			return "a node's slot";
		}
		if (p &&
		    bc_tree_child(ta, p, bc_tree_child_index(ta, id)) != id) {
			return "a node's position among its siblings";
		}
	}
	return NULL;
}

static const char *lin_differs(const struct bc_tree *ta,
                               const struct bc_tree *tb)
{
	return lin_differs_box(ta, tb, false);
}

/* Whether bc_tree_counts agrees with a walk over t's nodes. */
static bool counts_agree(const struct bc_tree *t)
{
	struct bc_scene_walk w;
	struct bc_scene_node n;
	uint32_t colored = 0, c;
	uint64_t floats = 0, f;
	if (bc_scene_walk_init(&w, t)) {
		return false;
	}
	while (bc_scene_walk_next(&w, &n)) {
		if (!n.is_op) {
			colored += n.prim.has_color ? 1u : 0u;
			floats += bc_scene_prim_nfloats(n.prim.kind);
		}
	}
	bc_scene_walk_finish(&w);
	bc_tree_counts(t, &c, &f);
	return c == colored && f == floats;
}

/* t's layout against a full layout of a copy of t. */
static const char *differs_from_full_box(const struct bc_tree *t,
                                         bool box_grown)
{
	struct bc_tree *full = bc_tree_create();
	const char *why = "copy failed";
	if (full && bc_tree_copy(full, t, NULL) == 0) {
		why = lin_differs_box(t, full, box_grown);
	}
	if (!why && !counts_agree(t)) {
		why = "colour or float counts";
	}
	bc_tree_destroy(full);
	return why;
}

static const char *differs_from_full(const struct bc_tree *t)
{
	return differs_from_full_box(t, false);
}

/* A random node id of t (a slot's), the root's excluded when asked. */
static uint32_t random_node(const struct bc_tree *t, bool not_root)
{
	const struct bc_lin *l = bc_tree_lin(t);
	for (;;) {
		uint32_t id = l->node_id[rt_below(l->count)];
		if (!not_root || id != bc_tree_root(t)) {
			return id;
		}
	}
}

/* A random binary operator of t, 0 when it has none. */
static uint32_t random_operator(const struct bc_tree *t)
{
	for (int tries = 0; tries < 64; tries++) {
		struct bc_op_data op;
		uint32_t id = random_node(t, false);
		if (bc_tree_get(t, id, NULL, &op) && op.kind != BC_OP_INVALID &&
		    !bc_op_is_unary(op.kind)) {
			return id;
		}
	}
	return 0;
}

/* One random structural edit; the tree stays between 2 and 80 primitives.
 * Returns 0 or the error a refused edit gave (a REPLACE of the root by a
 * subtree whose need is too large, say). */
static int random_edit(struct bc_tree *t, struct bc_tree *sub)
{
	uint32_t n = bc_tree_prim_count(t), pick = rt_below(10);
	uint32_t id;
	if (n > 80 || (n > 2 && pick < 4)) {
		return bc_tree_remove(t, random_node(t, true), NULL);
	}
	if (rt_build(sub, rt_next(), (n == 1 ? 2 : 1) + rt_below(4))) {
		return BC_ENOMEM;
	}
	if (n == 1) {
		/* A lone primitive (a REPLACE of the root made it): a tree
		 * again. */
		return bc_tree_replace(t, bc_tree_root(t), sub, NULL);
	}
	if (pick == 9) {
		return bc_tree_replace(t, random_node(t, true), sub, NULL);
	}
	if ((id = random_operator(t)) == 0) {
		return bc_tree_replace(t, bc_tree_root(t), sub, NULL);
	}
	return bc_tree_insert(t, id, rt_below(bc_tree_child_count(t, id) + 1),
	                      sub, NULL);
}

/* Rewrites a random primitive with its own data, its colour taken away or
 * given at random: the record, colour and ABV land where the model says
 * they are, which must be where they were. */
static void rewrite_a_primitive(struct bc_tree *t)
{
	const struct bc_lin *l = bc_tree_lin(t);
	uint32_t id = l->node_id[l->prim_slot[rt_below(l->nprims)]];
	struct bc_prim_data p;
	if (bc_tree_get(t, id, &p, NULL)) {
		p.has_color = rt_below(2) != 0;
		bc_tree_set_prim(t, id, &p, NULL);
	}
}

/* The primitives of a layout: node ids and ABVs, by index. */
struct prims {
	uint32_t n;
	uint32_t id[1024];
	struct bc_abv abv[1024];
};

static void prims_of(const struct bc_tree *t, struct prims *p)
{
	const struct bc_lin *l = bc_tree_lin(t);
	p->n = l ? l->nprims : 0;
	REQUIRE(p->n <= 1024);
	for (uint32_t k = 0; k < p->n; k++) {
		p->id[k] = l->node_id[l->prim_slot[k]];
		p->abv[k] = bc_lin_abv(l, k);
	}
}

static bool gone_has(const struct bc_dirty *d, const struct bc_abv *a)
{
	for (uint32_t i = 0; i < d->ngone; i++) {
		if (memcmp(&d->gone[i], a, sizeof(*a)) == 0) {
			return true;
		}
	}
	return false;
}

/* What a spliced dirty record says, checked against the primitives
 * before (was) and after: its splices take the old indices to the new
 * ones; every new primitive, and every one whose ABV changed, is in
 * [prim_lo, prim_hi); every ABV that went is in gone[]. Returns why not,
 * or NULL. */
static const char *dirty_wrong(const struct bc_dirty *d, struct prims *was,
                               const struct bc_tree *t)
{
	const struct bc_lin *l = bc_tree_lin(t);
	static struct prims now;
	for (uint32_t i = 0; i < d->nsplices; i++) {
		const struct bc_dirty_splice *sp = &d->splice[i];
		if (sp->at + sp->del > was->n ||
		    was->n - sp->del + sp->ins > 1024) {
			return "a splice beyond the primitives";
		}
		for (uint32_t k = sp->at; k < sp->at + sp->del; k++) {
			if (was->id[k] != 0 && !gone_has(d, &was->abv[k])) {
				return "a removed primitive's ABV not gone";
			}
		}
		memmove(was->id + sp->at + sp->ins, was->id + sp->at + sp->del,
		        (was->n - sp->at - sp->del) * sizeof(*was->id));
		memmove(was->abv + sp->at + sp->ins,
		        was->abv + sp->at + sp->del,
		        (was->n - sp->at - sp->del) * sizeof(*was->abv));
		memset(was->id + sp->at, 0, sp->ins * sizeof(*was->id));
		was->n = was->n - sp->del + sp->ins;
	}
	prims_of(t, &now);
	if (!l || was->n != now.n) {
		return "the splices give another primitive count";
	}
	for (uint32_t k = 0; k < now.n; k++) {
		bool dirty = k >= d->prim_lo && k < d->prim_hi;
		if (was->id[k] == 0) {
			if (!dirty) {
				return "an inserted primitive not dirty";
			}
		} else if (was->id[k] != now.id[k]) {
			return "the splices lose a primitive's place";
		} else if (memcmp(&was->abv[k], &now.abv[k],
		                  sizeof(now.abv[k])) != 0 &&
		           (!dirty || !gone_has(d, &was->abv[k]))) {
			return "a primitive placed again, not dirty or gone";
		}
	}
	return NULL;
}

/* Edits of the last run_edits after which the layout kept sphere ABVs
 * alone (struct bc_lin's sabv), and whole ones. */
static int sabv_after, abv_after;

static void run_edits(uint64_t seed, float unary_rate, int edits, int every)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	int refused = 0, checked = 0, spliced = 0;
	sabv_after = abv_after = 0;
	static struct prims was;
	rt_unary_rate = 0.0f;
	REQUIRE(t && sub && rt_build(t, seed, 24) == 0);
	rt_unary_rate = unary_rate;
	for (int e = 0; e < edits; e++) {
		struct bc_dirty d;
		const char *why;
		bc_tree_take_dirty(t, &d);
		prims_of(t, &was);
		if (random_edit(t, sub)) {
			refused++;
		}
		if (rt_below(8) == 0) {
			rewrite_a_primitive(t);
		}
		bc_tree_take_dirty(t, &d);
		if (bc_tree_lin(t)) {
			sabv_after += bc_tree_lin(t)->sabv != NULL;
			abv_after += bc_tree_lin(t)->abv != NULL;
		}
		if (d.spliced) {
			spliced++;
			if ((why = dirty_wrong(&d, &was, t)) != NULL) {
				fprintf(stderr, "  seed %llu edit %d: %s\n",
				        (unsigned long long)seed, e, why);
				CHECK(why == NULL);
				break;
			}
		}
		if (e % every != 0 && e + 1 != edits) {
			continue;
		}
		checked++;
		if ((why = differs_from_full(t)) != NULL) {
			fprintf(stderr, "  seed %llu edit %d: %s\n",
			        (unsigned long long)seed, e, why);
			CHECK(why == NULL);
			break;
		}
	}
	/* Refusals are rare (a REPLACE may nest too deep): the run edits.
	 * Without unary nodes nearly every edit is spliced and says so (a
	 * removal of over BC_DIRTY_GONE primitives does not). */
	CHECK(refused < edits / 10);
	if (unary_rate == 0.0f) {
		CHECK(spliced > edits * 3 / 4);
	}
	CHECK(checked > 0);
	rt_unary_rate = 0.0f;
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* 10 000 random edits of trees without unary nodes (all spliced), each
 * compared with a full layout. */
static void random_edits_equal_a_full_layout(void)
{
	for (uint64_t seed = 1; seed <= 4; seed++) {
		run_edits(seed, 0.0f, 2500, 1);
	}
}

/* Trees of unions keep no kill counts and no r- (struct bc_lin's kills
 * and roi_lo); random splices of union subtrees, of subtrees with any
 * operator (one in sixteen), and operators edited into any kind (one edit
 * in twenty) bring them in, and every layout, before and after, equals a
 * full one (its box holding the full one's once an operator edit shrank
 * an ABV). A whole layout of a tree of unions again drops them. 16 runs
 * of 100 edits. */
static void unions_take_kill_counts_when_an_operand_can_die(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	int without = 0, with = 0;
	bool grown = false;
	REQUIRE(t && sub);
	for (uint64_t seed = 21; seed <= 36; seed++) {
		rt_unions_only = true;
		REQUIRE(rt_build(t, seed, 24) == 0);
		CHECK(bc_tree_lin(t)->kills == NULL &&
		      bc_tree_lin(t)->roi_lo == NULL);
		for (int e = 0; e < 100; e++) {
			const char *why;
			rt_unions_only = rt_below(16) != 0;
			if (rt_below(20) == 0) {
				struct bc_op_data op;
				uint32_t id = random_operator(t);
				rt_unions_only = false;
				rt_random_op(&op);
				if (id) {
					REQUIRE(bc_tree_set_op(t, id, &op,
					                       NULL) == 0);
					grown = true;
				}
			} else {
				/* A splice measures the box again only
				 * where an ABV on it changed: one grown by
				 * an operator edit may stay so. */
				(void)random_edit(t, sub);
			}
			if (bc_tree_lin(t)->kills) {
				with++;
			} else {
				without++;
			}
			if ((why = differs_from_full_box(t, grown)) != NULL) {
				fprintf(stderr, "  seed %llu edit %d: %s\n",
				        (unsigned long long)seed, e, why);
				CHECK(why == NULL);
				break;
			}
		}
		grown = false;
		rt_unions_only = true;
		REQUIRE(rt_build(t, seed + 100, 24) == 0);
		REQUIRE(bc_tree_relayout(t, NULL) == 0);
		CHECK(bc_tree_lin(t)->kills == NULL &&
		      bc_tree_lin(t)->roi_lo == NULL);
	}
	rt_unions_only = false;
	/* Both kinds of layout were edited. */
	CHECK(without > 300 && with > 300);
	printf("  %d edits of layouts without kill counts, %d with\n", without,
	       with);
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* Trees of spheres alone keep sphere ABVs alone through their splices
 * (2500 random edits, each compared with a full layout); where one in
 * fifty primitives drawn is of another kind, the first splice that brings
 * one converts the ABVs (seed 11: after 157 edits of a tree of spheres),
 * and every layout before and after is exact. */
static void spheres_alone_splice_as_laid_out(void)
{
	rt_other_kinds = 0.0f;
	run_edits(5, 0.0f, 2500, 1);
	CHECK(abv_after == 0 && sabv_after > 2000);
	rt_other_kinds = 0.02f;
	run_edits(11, 0.0f, 2500, 1);
	printf("  rare other kinds: %d edits left sphere ABVs, %d whole "
	       "ones\n",
	       sabv_after, abv_after);
	CHECK(abv_after > 0 && sabv_after > 0);
	rt_other_kinds = 1.0f;
}

/* With unary nodes the layout is built whole; edits in and out of that
 * case (a unary subtree inserted, then removed) stay exact. */
static void unary_subtrees_come_and_go(void)
{
	run_edits(77, 0.15f, 1500, 3);
}

/* Wide operators (what big scenes are): the first child, the last and one
 * in the middle, inserted and removed, two-child operators collapsing. */
static void wide_operator_ends(void)
{
	struct bc_tree *t = bc_tree_create(), *one = bc_tree_create();
	struct bc_op_data u = {BC_OP_SMOOTH_UNION, 0.2f, 0.3f};
	struct bc_op_data d = {BC_OP_DIFFERENCE, 0.0f, 0.0f};
	struct bc_prim_data s;
	const char *why;
	rt_state = 5;
	bc_tree_begin(t);
	bc_tree_push_op(t, 1, &d, NULL);
	bc_tree_push_op(t, 2, &u, NULL);
	for (uint32_t i = 0; i < 40; i++) {
		rt_random_prim(&s);
		bc_tree_put_prim(t, 10 + i, &s, NULL);
	}
	bc_tree_pop_op(t, NULL);
	rt_random_prim(&s);
	bc_tree_put_prim(t, 3, &s, NULL);
	bc_tree_pop_op(t, NULL);
	REQUIRE(bc_tree_end(t, NULL) == 0);
	for (int round = 0; round < 30; round++) {
		uint32_t n = bc_tree_child_count(t, 2);
		uint32_t at[3] = {0, n, n / 2};
		for (int i = 0; i < 3; i++) {
			rt_random_prim(&s);
			bc_tree_begin(one);
			bc_tree_put_prim(
			    one, 1000u + 3u * (uint32_t)round + (uint32_t)i, &s,
			    NULL);
			REQUIRE(bc_tree_end(one, NULL) == 0);
			REQUIRE(bc_tree_insert(t, 2, at[i], one, NULL) == 0);
			REQUIRE((why = differs_from_full(t)) == NULL);
		}
		for (int i = 0; i < 3; i++) {
			/* The first, then the last, then one in the middle,
			 * then (as the union thins) its other children. */
			uint32_t c = bc_tree_child_count(t, 2);
			uint32_t kill = i == 0   ? bc_tree_child(t, 2, 0)
			                : i == 1 ? bc_tree_child(t, 2, c - 1)
			                         : bc_tree_child(t, 2, c / 2);
			REQUIRE(bc_tree_remove(t, kill, NULL) == 0);
			REQUIRE((why = differs_from_full(t)) == NULL);
		}
		REQUIRE(bc_tree_remove(t, bc_tree_child(t, 2, 1), NULL) == 0);
		if (bc_tree_child_count(t, 2) < 2) {
			break;
		}
		REQUIRE((why = differs_from_full(t)) == NULL);
	}
	/* Down to two children, then one: the union collapses into the
	 * difference's left operand. */
	while (bc_tree_get(t, 2, NULL, NULL)) {
		REQUIRE(bc_tree_remove(t, bc_tree_child(t, 2, 0), NULL) == 0);
		REQUIRE((why = differs_from_full(t)) == NULL);
	}
	REQUIRE(bc_tree_remove(t, 3, NULL) == 0);
	CHECK(differs_from_full(t) == NULL);
	CHECK_EQ_INT(bc_tree_prim_count(t), 1);
	bc_tree_destroy(one);
	bc_tree_destroy(t);
}

/* Builds in t a union (id 1) of n random primitives (seed) with ids
 * first, first + 1, ..., written to ids; returns the next id, 0 when the
 * tree does not build. */
static uint32_t wide_union(struct bc_tree *t, uint64_t seed, uint32_t n,
                           uint32_t first, uint32_t *ids)
{
	struct bc_op_data u = {BC_OP_UNION, 0.0f, 0.0f};
	struct bc_prim_data s;
	rt_state = seed;
	bc_tree_begin(t);
	bc_tree_push_op(t, 1, &u, NULL);
	for (uint32_t i = 0; i < n; i++) {
		rt_random_prim(&s);
		ids[i] = first + i;
		bc_tree_put_prim(t, first + i, &s, NULL);
	}
	bc_tree_pop_op(t, NULL);
	return bc_tree_end(t, NULL) == 0 ? first + n : 0;
}

/* A wide operator of thousands of operands, edited at random places many
 * times: each splice brings only a share of the model's nodes up to date
 * (the rest follow the splice log when read), so most nodes lag dozens
 * of splices behind, and the log's ring wraps many times over. Every
 * node's slot must still be where a full layout puts it. Some operands
 * are unions of two spheres, a few a sphere in an offset node; the test
 * keeps the operands' ids in order,
 * and the child found at a position (walked in the model near the start,
 * in the layout elsewhere) must be the one it keeps there, an inserted
 * operand's first primitive where the operands before it end. */
static void many_splices_on_a_wide_operator(void)
{
	struct bc_tree *t = bc_tree_create(), *one = bc_tree_create();
	struct bc_op_data u = {BC_OP_UNION, 0.0f, 0.0f};
	struct bc_unary off = {BC_OP_OFFSET, {0.01f}};
	struct bc_prim_data s;
	enum { N0 = 3000, EDITS = 1200 };
	static uint32_t ids[N0 + EDITS], prims[N0 + EDITS];
	uint32_t id = 10, c = N0;
	const char *why = NULL;
	REQUIRE(t && one);
	REQUIRE((id = wide_union(t, 11, N0, id, ids)) != 0);
	for (uint32_t i = 0; i < N0; i++) {
		prims[i] = 1;
	}
	for (int e = 0; e < EDITS && !why; e++) {
		uint32_t at = rt_below(c + (c > N0 / 2 ? 0 : 1)), first = 0;
		REQUIRE(c == bc_tree_child_count(t, 1));
		if (rt_below(2) && c > N0 / 2) {
			REQUIRE(bc_tree_remove(t, ids[at], NULL) == 0);
			memmove(ids + at, ids + at + 1, (c - at - 1) * 4);
			memmove(prims + at, prims + at + 1, (c - at - 1) * 4);
			c--;
		} else {
			uint32_t two = rt_below(3) == 0;
			/* Now and then an operand in an offset node: the
			 * tree is then laid out whole until it goes. */
			bool wrap = !two && rt_below(40) == 0;
			at = rt_below(c + 1);
			bc_tree_begin(one);
			if (two) {
				bc_tree_push_op(one, id++, &u, NULL);
			}
			if (wrap) {
				bc_tree_push_unary(one, id++, &off, NULL);
			}
			memmove(ids + at + 1, ids + at, (c - at) * 4);
			memmove(prims + at + 1, prims + at, (c - at) * 4);
			ids[at] = two || wrap ? id - 1 : id;
			prims[at] = 1 + two;
			first = id;
			for (uint32_t k = 0; k <= two; k++) {
				rt_random_prim(&s);
				bc_tree_put_prim(one, id++, &s, NULL);
			}
			if (two || wrap) {
				bc_tree_pop_op(one, NULL);
			}
			REQUIRE(bc_tree_end(one, NULL) == 0);
			REQUIRE(bc_tree_insert(t, 1, at, one, NULL) == 0);
			c++;
		}
		for (uint32_t k = 0, before = 0; first && k <= at; k++) {
			const struct bc_lin *l = bc_tree_lin(t);
			if (k == at &&
			    bc_lin_prim(l, bc_tree_slot(t, first)) != before) {
				why = "an operand inserted at the wrong place";
			}
			before += prims[k];
		}
		for (int q = 0; q < 8 && !why; q++) {
			uint32_t k =
			    q < 2 ? (uint32_t)q * (c - 1) : rt_below(c);
			if (bc_tree_child(t, 1, k) != ids[k]) {
				why = "a child found at the wrong position";
			}
		}
		if (e % 100 == 99 && !why) {
			why = differs_from_full(t);
		}
		for (uint32_t k = 0; k < c && !why && e % 20 == 0; k++) {
			/* An offset node's slot is its child's. */
			struct bc_unary un;
			uint32_t slot = bc_tree_slot(t, ids[k]);
			uint32_t want = bc_tree_get_unary(t, ids[k], &un)
			                    ? bc_tree_child(t, ids[k], 0)
			                    : ids[k];
			if (slot >= bc_tree_lin(t)->count ||
			    bc_tree_lin(t)->node_id[slot] != want) {
				why = "a node's slot is not where it is";
			}
		}
	}
	if (why) {
		fprintf(stderr, "  %s\n", why);
	}
	CHECK(why == NULL);
	bc_tree_destroy(one);
	bc_tree_destroy(t);
}

/* ---- batches refused part way ------------------------------------------ */

static uint32_t next_id = 100000;

/* Ends the builder of sub and encodes it into *out (scene bytes); sub
 * goes. */
static int end_bytes(struct bc_tree *sub, uint8_t **out, size_t *len)
{
	int rc = bc_tree_end(sub, NULL);
	if (!rc) {
		rc = bc_scene_encode(sub, NULL, out, len);
	}
	bc_tree_destroy(sub);
	return rc;
}

/* Scene bytes of a random subtree of 1..3 primitives with new ids. */
static int subtree_bytes(uint8_t **out, size_t *len)
{
	struct bc_tree *sub = bc_tree_create();
	struct bc_prim_data p;
	struct bc_op_data op;
	uint32_t n = 1 + rt_below(3);
	bc_tree_begin(sub);
	if (n > 1) {
		rt_random_op(&op);
		bc_tree_push_op(sub, next_id++, &op, NULL);
	}
	for (uint32_t i = 0; i < n; i++) {
		rt_random_prim(&p);
		bc_tree_put_prim(sub, next_id++, &p, NULL);
	}
	if (n > 1) {
		bc_tree_pop_op(sub, NULL);
	}
	return end_bytes(sub, out, len);
}

static bool same_tree(const struct bc_tree *a, const struct bc_tree *b)
{
	uint8_t *x = NULL, *y = NULL;
	size_t nx = 0, ny = 0;
	bool ok = bc_tree_encode(a, &x, &nx) == 0 &&
	          bc_tree_encode(b, &y, &ny) == 0 && nx == ny &&
	          memcmp(x, y, nx) == 0 && lin_differs(a, b) == NULL;
	bc_free(x);
	bc_free(y);
	return ok;
}

/* A random structural operation of t; its subtree bytes (if any) into
 * *owned. */
static struct bc_proto_edit_op random_op(const struct bc_tree *t,
                                         uint8_t **owned)
{
	struct bc_proto_edit_op e = {0};
	size_t len = 0;
	uint32_t pick = rt_below(4), parent;
	*owned = NULL;
	if (pick == 0 && bc_tree_prim_count(t) > 3) {
		e.kind = BC_PROTO_EDIT_REMOVE;
		e.node = random_node(t, true);
		return e;
	}
	if (subtree_bytes(owned, &len)) {
		return e;
	}
	e.subtree.ptr = *owned;
	e.subtree.len = (uint32_t)len;
	if (pick == 1) {
		e.kind = BC_PROTO_EDIT_REPLACE;
		e.node = random_node(t, true);
		return e;
	}
	parent = random_operator(t);
	e.kind = BC_PROTO_EDIT_INSERT;
	e.node = parent ? parent : bc_tree_root(t);
	e.position = rt_below(bc_tree_child_count(t, e.node) + 1);
	return e;
}

/* Batches of a few structural operations whose last is refused leave the
 * tree as a copy made before them says, model and layout; batches that
 * apply and are undone too. */
static void refused_batches_leave_the_tree_as_it_was(void)
{
	struct bc_tree *t = bc_tree_create(), *before = bc_tree_create();
	struct bc_errinfo ei = {0};
	int refused = 0, undone = 0;
	REQUIRE(rt_build(t, 99, 30) == 0);
	for (int round = 0; round < 300; round++) {
		struct bc_proto_edit_op ops[6];
		uint8_t *owned[6] = {0};
		struct bc_edit_batch b;
		uint32_t n = 2 + rt_below(5), planned;
		bool fail = rt_below(3) != 0;
		int rc;
		REQUIRE(bc_tree_copy(before, t, NULL) == 0);
		planned = n;
		/* Each operation is drawn against the tree as it will be,
		 * so that the earlier ones apply. */
		for (uint32_t i = 0; i < n; i++) {
			struct bc_edit_batch one;
			ops[i] = random_op(t, &owned[i]);
			if (i + 1 == n && fail) {
				/* Under a primitive, or an unknown node. */
				ops[i].kind = owned[i] ? BC_PROTO_EDIT_INSERT
				                       : BC_PROTO_EDIT_REMOVE;
				ops[i].node =
				    owned[i]
				        ? bc_tree_lin(t)->node_id
				              [bc_tree_lin(t)->prim_slot[0]]
				        : 0x7fffffffu;
				ops[i].position = 0;
				break;
			}
			if (bc_edit_batch_apply(&one, &t, &ops[i], 1, &ei)) {
				n = i;
			}
			bc_edit_batch_finish(&one);
		}
		/* An operation drawn that did not apply ends the batch
		 * early: then it applies whole. */
		fail = fail && n == planned;
		/* Back to the start, through the copy. */
		REQUIRE(bc_tree_copy(t, before, NULL) == 0);
		rc = n ? bc_edit_batch_apply(&b, &t, ops, n, &ei) : 0;
		if (fail && n) {
			CHECK(rc != 0);
			CHECK(same_tree(t, before));
			refused++;
		} else if (n) {
			CHECK_EQ_INT(rc, 0);
			CHECK(differs_from_full(t) == NULL);
			bc_edit_batch_undo(&b, &t);
			CHECK(same_tree(t, before));
			undone++;
			/* And forward again, to move on. */
			CHECK_EQ_INT(bc_edit_batch_apply(&b, &t, ops, n, &ei),
			             0);
			bc_edit_batch_finish(&b);
		}
		for (uint32_t i = 0; i < 6; i++) {
			bc_free(owned[i]);
		}
		if (bc_test_failures) {
			break;
		}
	}
	CHECK(refused > 50 && undone > 30);
	bc_tree_destroy(before);
	bc_tree_destroy(t);
}

/* Out of memory at every allocation in turn: a refused INSERT or REPLACE
 * (the arrays must grow first: the subtree outgrows the room a layout
 * keeps, bc__lin_room) leaves the tree as it was; so does a batch of
 * INSERTs refused part way, put back by REMOVEs, which take no memory. */
static void allocation_failures_leave_the_tree_as_it_was(void)
{
	struct bc_tree *t = bc_tree_create(), *sub = bc_tree_create();
	struct bc_tree *before = bc_tree_create();
	struct bc_proto_edit_op ops[3];
	uint8_t *owned[3] = {0};
	struct bc_errinfo ei = {0};
	int failed = 0, rc = 1;
	REQUIRE(rt_build(t, 5, 40) == 0 && rt_build(sub, 6, 80) == 0);
	REQUIRE(bc_tree_copy(before, t, NULL) == 0);
	for (unsigned long n = 1; rc && n < 1000; n++) {
		uint32_t op = bc_tree_root(t), id = random_node(t, true);
		bc_alloc_fail_after(n);
		rc = n % 2 ? bc_tree_insert(t, op, 1, sub, NULL)
		           : bc_tree_replace(t, id, sub, NULL);
		bc_alloc_fail_after(0);
		if (rc) {
			failed++;
			CHECK(same_tree(t, before));
		}
	}
	CHECK(failed > 2 && rc == 0);
	CHECK(differs_from_full(t) == NULL);
	REQUIRE(bc_tree_copy(before, t, NULL) == 0);
	for (int i = 0; i < 3; i++) {
		size_t len = 0;
		REQUIRE(subtree_bytes(&owned[i], &len) == 0);
		ops[i] = (struct bc_proto_edit_op){
		    .kind = BC_PROTO_EDIT_INSERT,
		    .node = bc_tree_root(t),
		    .position = (uint32_t)i,
		    .subtree = {owned[i], (uint32_t)len}};
	}
	failed = 0;
	rc = 1;
	for (unsigned long n = 1; rc && n < 1000; n++) {
		struct bc_edit_batch b;
		bc_alloc_fail_after(n);
		rc = bc_edit_batch_apply(&b, &t, ops, 3, &ei);
		bc_alloc_fail_after(0);
		if (rc) {
			failed++;
			CHECK(same_tree(t, before));
		} else {
			bc_edit_batch_undo(&b, &t);
			CHECK(same_tree(t, before));
		}
	}
	CHECK(failed > 2 && rc == 0);
	for (int i = 0; i < 3; i++) {
		bc_free(owned[i]);
	}
	bc_tree_destroy(before);
	bc_tree_destroy(sub);
	bc_tree_destroy(t);
}

/* ---- a bare tree ------------------------------------------------------- */

/* Scene bytes of a chain of `depth` unions, each with a primitive first
 * and the next union second: every level adds one entry to the
 * evaluation stack. */
static int chain_bytes(uint32_t depth, uint8_t **out, size_t *len)
{
	struct bc_tree *sub = bc_tree_create();
	struct bc_op_data op = {BC_OP_UNION, 0.0f, 0.0f};
	struct bc_prim_data p;
	bc_tree_begin(sub);
	for (uint32_t i = 0; i < depth; i++) {
		bc_tree_push_op(sub, next_id++, &op, NULL);
		rt_random_prim(&p);
		bc_tree_put_prim(sub, next_id++, &p, NULL);
	}
	rt_random_prim(&p);
	bc_tree_put_prim(sub, next_id++, &p, NULL);
	for (uint32_t i = 0; i < depth; i++) {
		bc_tree_pop_op(sub, NULL);
	}
	return end_bytes(sub, out, len);
}

/* Why the bare tree b's model differs from the laid-out t's, or NULL:
 * scene bytes, nesting, counts, and layouts of copies of both. */
static const char *bare_differs(const struct bc_tree *t,
                                const struct bc_tree *b, bool lay_out)
{
	uint8_t *x = NULL, *y = NULL;
	size_t nx = 0, ny = 0;
	const char *why = NULL;
	if (!bc_tree_lays_out(t) || bc_tree_lays_out(b) || bc_tree_lin(b)) {
		return "the bare tree was laid out, or the other not";
	}
	if (bc_tree_encode(t, &x, &nx) || bc_tree_encode(b, &y, &ny) ||
	    nx != ny || memcmp(x, y, nx) != 0) {
		why = "the models differ";
	} else if (bc_tree_nesting(t) != bc_tree_nesting(b)) {
		why = "nesting";
	} else if (!counts_agree(b)) {
		why = "colour or float counts";
	}
	bc_free(x);
	bc_free(y);
	for (int i = 0; i < 16 && !why && bc_tree_node_count(t) > 1; i++) {
		/* Positions among siblings, and back (the model's walk). */
		uint32_t id = random_node(t, true), p = bc_tree_parent(t, id);
		uint32_t k = bc_tree_child_index(b, id);
		if (k != bc_tree_child_index(t, id) ||
		    bc_tree_child(b, p, k) != id) {
			why = "a node's position among its siblings";
		}
	}
	if (!why && lay_out) {
		/* Full layouts of both (a parameter edit grows t's box and
		 * never shrinks it, so t's own may be wider). */
		struct bc_tree *ft = bc_tree_create(), *fb = bc_tree_create();
		why = "copy failed";
		if (ft && fb && bc_tree_copy(ft, t, NULL) == 0 &&
		    bc_tree_copy(fb, b, NULL) == 0) {
			why = lin_differs(ft, fb);
		}
		bc_tree_destroy(ft);
		bc_tree_destroy(fb);
	}
	return why;
}

/* A bare tree (bc_tree_set_layout, a server session's) edited in lockstep
 * with a laid-out one: random INSERT, REMOVE and REPLACE batches, chains
 * deep enough for the evaluation stack to refuse some, parameter edits
 * and undos. Every result, refusal and nesting must agree, and a layout
 * of the bare tree's copy must equal one of the other's (unary nodes in
 * one of the runs). */
static void a_bare_tree_edits_as_a_laid_out_one(void)
{
	for (uint64_t seed = 11; seed <= 12; seed++) {
		struct bc_tree *t = bc_tree_create(), *b = bc_tree_create();
		struct bc_errinfo ea = {0}, eb = {0};
		int refused = 0, undone = 0, edits = 1200;
		const char *why = NULL;
		rt_unary_rate = seed == 12 ? 0.1f : 0.0f;
		REQUIRE(t && b && rt_build(t, seed, 30) == 0);
		CHECK(bc_tree_lays_out(t));
		CHECK_EQ_INT(bc_tree_set_layout(b, false), 0);
		REQUIRE(bc_tree_copy(b, t, NULL) == 0);
		/* Only an empty tree changes its mind. */
		CHECK_EQ_INT(bc_tree_set_layout(b, true), BC_ESTATE);
		why = bare_differs(t, b, true);
		for (int e = 0; e < edits && !why; e++) {
			struct bc_proto_edit_op op;
			struct bc_edit_batch bt, bb;
			uint8_t *owned = NULL;
			size_t len = 0;
			int rt, rb;
			if (bc_tree_node_count(t) == 1 &&
			    chain_bytes(2, &owned, &len) == 0) {
				/* A lone primitive (a removal collapsed the
				 * root): a tree again. */
				op = (struct bc_proto_edit_op){
				    .kind = BC_PROTO_EDIT_REPLACE,
				    .node = bc_tree_root(t),
				    .subtree = {owned, (uint32_t)len}};
			} else if (rt_below(10) == 0 &&
			           chain_bytes(80 + rt_below(48), &owned,
			                       &len) == 0) {
				/* Often into an earlier chain: too deep. */
				uint32_t at = random_operator(t);
				op = (struct bc_proto_edit_op){
				    .kind = BC_PROTO_EDIT_INSERT,
				    .node = at ? at : bc_tree_root(t),
				    .position = 1,
				    .subtree = {owned, (uint32_t)len}};
			} else {
				op = random_op(t, &owned);
			}
			rt = bc_edit_batch_apply(&bt, &t, &op, 1, &ea);
			rb = bc_edit_batch_apply(&bb, &b, &op, 1, &eb);
			if (rt != rb || (rt && strcmp(ea.msg, eb.msg) != 0)) {
				fprintf(stderr, "  %d (%s) against %d (%s)\n",
				        rt, ea.msg, rb, eb.msg);
				why = "a result differs";
			}
			refused += rt != 0;
			if (!rt && !rb && rt_below(5) == 0) {
				bc_edit_batch_undo(&bt, &t);
				bc_edit_batch_undo(&bb, &b);
				undone++;
			} else {
				bc_edit_batch_finish(&bt);
				bc_edit_batch_finish(&bb);
			}
			if (rt_below(4) == 0) {
				/* A parameter edit, the same on both. */
				uint32_t id = random_node(t, false);
				struct bc_prim_data p;
				if (bc_tree_get(t, id, &p, NULL) &&
				    p.kind != BC_PRIM_INVALID) {
					p.translate[0] += 0.25f;
					p.has_color = !p.has_color;
					CHECK_EQ_INT(
					    bc_tree_set_prim(t, id, &p, NULL),
					    bc_tree_set_prim(b, id, &p, NULL));
				}
			}
			bc_free(owned);
			if (!why) {
				why = bare_differs(t, b, e % 25 == 0);
			}
			if (why) {
				fprintf(stderr, "  seed %llu edit %d: %s\n",
				        (unsigned long long)seed, e, why);
			}
		}
		CHECK(why == NULL);

		CHECK(refused > 5 && refused < edits / 5);
		CHECK(undone > 50);
		rt_unary_rate = 0.0f;
		bc_tree_destroy(b);
		bc_tree_destroy(t);
	}
}

/* A bare tree's wide operator keeps an index of its children's
 * positions (anchors every few hundred children): a union of 3 000
 * spheres loses operands at random places until it is narrow enough to
 * drop its index, then grows past the width that indexes it (2 048)
 * again, with
 * REPLACEs on the way; after every edit children found by position and
 * positions found by child match a list kept beside it. */
static void a_bare_wide_operator_finds_its_children(void)
{
	enum { N0 = 3000, EDITS = 12000 };
	static uint32_t ids[2 * N0];
	struct bc_tree *t = bc_tree_create(), *one = bc_tree_create();
	struct bc_prim_data s;
	uint32_t c = N0, id = 2;
	const char *why = NULL;
	bool shrinking = true, dropped = false;
	REQUIRE(t && one && bc_tree_set_layout(t, false) == 0);
	REQUIRE((id = wide_union(t, 4242, N0, id, ids)) != 0);
	for (int e = 0; e < EDITS && !why; e++) {
		uint32_t at, pick = rt_below(10);
		if (shrinking && c < 900) {
			shrinking = false;
			dropped = true;
		} else if (!shrinking && c > N0 - 500) {
			break;
		}
		if (pick < (shrinking ? 8u : 2u)) {
			at = rt_below(c);
			REQUIRE(bc_tree_remove(t, ids[at], NULL) == 0);
			memmove(ids + at, ids + at + 1, (c - at - 1) * 4);
			c--;
		} else {
			at = pick == 9 ? rt_below(c) : rt_below(c + 1);
			if (rt_below(4) == 0) {
				at = rt_below(2) ? 0 : c - (pick == 9);
			}
			rt_random_prim(&s);
			bc_tree_begin(one);
			bc_tree_put_prim(one, id, &s, NULL);
			REQUIRE(bc_tree_end(one, NULL) == 0);
			if (pick == 9) {
				/* In the same place. */
				REQUIRE(bc_tree_replace(t, ids[at], one,
				                        NULL) == 0);
			} else {
				REQUIRE(bc_tree_insert(t, 1, at, one, NULL) ==
				        0);
				memmove(ids + at + 1, ids + at, (c - at) * 4);
				c++;
			}
			ids[at] = id++;
		}
		if (bc_tree_child_count(t, 1) != c) {
			why = "the count";
		}
		for (int q = 0; q < 12 && !why; q++) {
			uint32_t k = q < 4 ? (uint32_t)q * (c - 1) / 3
			                   : (q < 6 ? at + (uint32_t)q - 5
			                            : rt_below(c));
			k = k < c ? k : c - 1;
			if (bc_tree_child(t, 1, k) != ids[k]) {
				why = "a child found at the wrong position";
			} else if (bc_tree_child_index(t, ids[k]) != k) {
				why = "a child's position";
			}
		}
		if (why) {
			fprintf(stderr, "  edit %d (%u children): %s\n", e, c,
			        why);
		}
	}
	CHECK(why == NULL);
	CHECK(dropped && c > N0 - 500);
	CHECK(bc_tree_lin(t) == NULL);
	bc_tree_destroy(one);
	bc_tree_destroy(t);
}

static const struct bc_test tests[] = {
    {"random_edits_equal_a_full_layout", random_edits_equal_a_full_layout},
    {"spheres_alone_splice_as_laid_out", spheres_alone_splice_as_laid_out},
    {"unions_take_kill_counts_when_an_operand_can_die",
     unions_take_kill_counts_when_an_operand_can_die},
    {"unary_subtrees_come_and_go", unary_subtrees_come_and_go},
    {"wide_operator_ends", wide_operator_ends},
    {"many_splices_on_a_wide_operator", many_splices_on_a_wide_operator},
    {"refused_batches_leave_the_tree_as_it_was",
     refused_batches_leave_the_tree_as_it_was},
    {"allocation_failures_leave_the_tree_as_it_was",
     allocation_failures_leave_the_tree_as_it_was},
    {"a_bare_tree_edits_as_a_laid_out_one",
     a_bare_tree_edits_as_a_laid_out_one},
    {"a_bare_wide_operator_finds_its_children",
     a_bare_wide_operator_finds_its_children},
};
BC_TEST_MAIN(tests)
