/*
 * The adaptive sparse voxel octree (thesis §5.4, Alg. 5.6): a region is
 * pruned; if its variant still has more active terms than the threshold tau
 * and the depth allows, it is split into eight, each pruned from its
 * parent's variant. Leaves keep their variant as a compressed mask (only the
 * non-zero words), or nothing when the region is empty or full. Points are
 * evaluated through the octree by walking to their leaf (§5.5).
 *
 * Memory is accounted as it grows; once the budget is spent no region is
 * split any more, so a scene too complex for the budget gets leaves with more
 * terms than tau -- slower to evaluate, never wrong.
 */
#include "svo_impl.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"

/* Levels a region may be split without losing a single term before it is
 * kept as a leaf anyway. The terms a blend needs where several primitives
 * come within its range of one another stay however small the region gets:
 * splitting there only multiplies leaves (the thesis, with Boolean
 * operators only, never meets this). Three levels is a cell 8 times
 * smaller, past where a separation of primitives could still show. Large
 * regions are exempt: there the ranges themselves are loose, and splitting
 * removes terms again once they tighten. */
#define SVO_STALL_LEVELS 3u
#define SVO_STALL_MIN_DEPTH 5u

int bc__svo_pool_put(struct bc__svo_pool *pool, const uint32_t *mask,
                     uint32_t nwords, uint32_t *off, uint32_t *npairs)
{
	uint32_t k = 0;
	for (uint32_t w = 0; w < nwords; w++) {
		k += mask[w] != 0;
	}
	if (pool->n + 2u * (size_t)k > pool->cap) {
		size_t cap = pool->cap ? pool->cap : 1024;
		uint32_t *grown;
		while (cap < pool->n + 2u * (size_t)k) {
			cap *= 2;
		}
		grown = bc_reallocarray(pool->v, cap, sizeof(*grown));
		if (!grown) {
			return BC_ENOMEM;
		}
		pool->v = grown;
		pool->cap = cap;
	}
	if (pool->n / 2 > UINT32_MAX - k) {
		return BC_ENOMEM; /* offsets are 32-bit */
	}
	*off = (uint32_t)(pool->n / 2);
	*npairs = k;
	for (uint32_t w = 0; w < nwords; w++) {
		if (mask[w]) {
			pool->v[pool->n++] = w;
			pool->v[pool->n++] = mask[w];
		}
	}
	return 0;
}

void bc__svo_pool_finish(struct bc__svo_pool *pool)
{
	bc_free(pool->v);
	memset(pool, 0, sizeof(*pool));
}

float bc__svo_state_value(enum bc_svo_state st, struct bc_svo_ivl root)
{
	if (st == BC_SVO_STATE_EMPTY) {
		return root.lo >= (double)FLT_MAX
		           ? FLT_MAX
		           : fmaxf((float)root.lo, FLT_MIN);
	}
	return root.hi <= -(double)FLT_MAX ? -FLT_MAX
	                                   : fminf((float)root.hi, -FLT_MIN);
}

/* ---- Construction -------------------------------------------------------- */

struct build {
	struct bc_svo *s;
	struct bc_svo_ranger *g;
	uint32_t *masks; /* one working mask per depth */
	uint32_t tau, max_depth;
	uint64_t rpn_bytes;
	uint64_t used; /* bytes of nodes, leaves and stored masks so far */
};

static int grow_nodes(struct bc_svo *s, uint32_t more)
{
	if (s->nnodes + more > s->capnodes) {
		uint32_t cap = s->capnodes ? s->capnodes : 64;
		struct bc__svo_node *grown;
		while (cap < s->nnodes + more) {
			if (cap > UINT32_MAX / 2) {
				return BC_ENOMEM;
			}
			cap *= 2;
		}
		grown = bc_reallocarray(s->nodes, cap, sizeof(*grown));
		if (!grown) {
			return BC_ENOMEM;
		}
		s->nodes = grown;
		s->capnodes = cap;
	}
	return 0;
}

static int make_leaf(struct build *b, uint32_t node, uint32_t depth,
                     const uint32_t *mask,
                     const struct bc_svo_prune_result *res)
{
	struct bc_svo *s = b->s;
	struct bc__svo_leaf *lf;
	double w = ldexp(1.0, -3 * (int)depth); /* the leaf's volume share */
	int rc;
	if (s->nleaves == s->capleaves) {
		uint32_t cap = s->capleaves ? 2 * s->capleaves : 64;
		struct bc__svo_leaf *grown =
		    bc_reallocarray(s->leaves, cap, sizeof(*grown));
		if (!grown) {
			return BC_ENOMEM;
		}
		s->leaves = grown;
		s->capleaves = cap;
	}
	lf = &s->leaves[s->nleaves];
	memset(lf, 0, sizeof(*lf));
	lf->state = (uint8_t)res->state;
	lf->depth = (uint8_t)depth;
	lf->nterms = res->nterms;
	if (res->state == BC_SVO_STATE_ACTIVE) {
		uint32_t steep = 0;
		if ((rc = bc__svo_pool_put(&s->pool, mask, s->rpn->nwords,
		                           &lf->off, &lf->npairs))) {
			return rc;
		}
		for (uint32_t k = 0; k < s->rpn->nwords; k++) {
			steep |= mask[k] & s->rpn->steep[k];
		}
		lf->flags =
		    (uint16_t)(steep || s->opts.no_step ? 0u
		                                        : BC__SVO_LEAF_LIP1);
		s->stats.stepped += lf->flags != 0;
	} else {
		lf->value = bc__svo_state_value(res->state, res->root);
	}
	b->used += sizeof(*lf) + 8u * (uint64_t)lf->npairs;
	s->nodes[node].child = 0;
	s->nodes[node].leaf = s->nleaves++;
	s->stats.leaves++;
	s->stats.empty += res->state == BC_SVO_STATE_EMPTY;
	s->stats.full += res->state == BC_SVO_STATE_FULL;
	s->stats.active += res->state == BC_SVO_STATE_ACTIVE;
	s->stats.max_depth =
	    depth > s->stats.max_depth ? depth : s->stats.max_depth;
	s->stats.max_terms =
	    res->nterms > s->stats.max_terms ? res->nterms : s->stats.max_terms;
	s->stats.avg_depth += w * depth;
	s->stats.avg_terms += w * res->nterms;
	s->stats.avg_depth_leaf += depth;
	s->stats.avg_terms_leaf += res->nterms;
	return 0;
}

/* Bytes a leaf for a variant with these mask words takes. */
static uint64_t leaf_cost(const uint32_t *mask, uint32_t nwords,
                          const struct bc_svo_prune_result *res)
{
	uint64_t k = 0;
	if (res->state == BC_SVO_STATE_ACTIVE) {
		for (uint32_t w = 0; w < nwords; w++) {
			k += mask[w] != 0;
		}
	}
	return sizeof(struct bc__svo_leaf) + 8u * k;
}

/*
 * Builds the subtree of node, whose region [lo, hi] at depth has already
 * been pruned into mask (result res). allow is the memory the subtree may
 * take. The budget is shared out as the tree grows: a node prunes its eight
 * children first, sets aside what those that will be leaves need, and
 * divides the rest among the others in proportion to their terms, giving
 * each what is left when its turn comes. A budget too small for the
 * threshold thus coarsens the octree where it is most complex instead of
 * starving whichever regions happen to be built last.
 */
static int build_node(struct build *b, uint32_t node, const float lo[3],
                      const float hi[3], uint32_t depth, const uint32_t *mask,
                      const struct bc_svo_prune_result *res,
                      uint32_t parent_terms, uint32_t stall, uint64_t allow)
{
	struct bc_svo *s = b->s;
	uint32_t nw = s->rpn->nwords;
	uint32_t *cm = b->masks + ((size_t)(depth + 1) * 8u) * nw;
	struct bc_svo_prune_result cr[8];
	float clo[8][3], chi[8][3];
	uint64_t cost[8], weight[8], wsum = 0, reserve = 0, left;
	uint32_t first;
	int rc;
	if (res->state != BC_SVO_STATE_ACTIVE || res->nterms <= b->tau ||
	    depth >= b->max_depth) {
		return make_leaf(b, node, depth, mask, res);
	}
	/* A cell narrower than the band cannot separate what lies within the
	 * band of its surface: its children would keep the same terms. */
	if (0.5f * (hi[0] - lo[0]) < s->opts.band) {
		s->stats.stalled++;
		return make_leaf(b, node, depth, mask, res);
	}
	stall = res->nterms < parent_terms || depth < SVO_STALL_MIN_DEPTH
	            ? 0
	            : stall + 1;
	if (stall >= SVO_STALL_LEVELS) {
		s->stats.stalled++;
		return make_leaf(b, node, depth, mask, res);
	}
	for (uint32_t c = 0; c < 8; c++) {
		struct bc_svo_region rg;
		memset(&rg, 0, sizeof(rg));
		for (int i = 0; i < 3; i++) {
			float mid = 0.5f * (lo[i] + hi[i]);
			bool upper = (c >> i) & 1u;
			clo[c][i] = upper ? mid : lo[i];
			chi[c][i] = upper ? hi[i] : mid;
		}
		memcpy(rg.lo, clo[c], sizeof(rg.lo));
		memcpy(rg.hi, chi[c], sizeof(rg.hi));
		if ((rc = bc_svo_prune(b->g, mask, cm + (size_t)c * nw, &rg,
		                       s->opts.band, &cr[c]))) {
			return rc;
		}
		s->stats.pruned++;
		cost[c] = leaf_cost(cm + (size_t)c * nw, nw, &cr[c]);
		weight[c] = cr[c].state == BC_SVO_STATE_ACTIVE &&
		                    cr[c].nterms > b->tau &&
		                    depth + 1 < b->max_depth
		                ? cr[c].nterms
		                : 0;
		wsum += weight[c];
		reserve += cost[c];
	}
	if (8u * sizeof(struct bc__svo_node) + reserve > allow) {
		/* Not even the children as leaves fit. */
		s->stats.truncated = true;
		return make_leaf(b, node, depth, mask, res);
	}
	if ((rc = grow_nodes(s, 8))) {
		return rc;
	}
	first = s->nnodes;
	s->nnodes += 8;
	b->used += 8u * sizeof(struct bc__svo_node);
	s->nodes[node].child = first;
	s->nodes[node].leaf = 0;
	left = allow - 8u * sizeof(struct bc__svo_node) - reserve;
	for (uint32_t c = 0; c < 8; c++) {
		uint64_t before = b->used, spent, mine = cost[c];
		if (weight[c]) {
			/* A share of what is left, as a fraction computed in
			 * double: the product could overflow 64 bits. */
			mine += (uint64_t)((double)left * (double)weight[c] /
			                   (double)wsum);
		}
		s->nodes[first + c].child = 0;
		s->nodes[first + c].leaf = 0;
		if ((rc = build_node(b, first + c, clo[c], chi[c], depth + 1,
		                     cm + (size_t)c * nw, &cr[c], res->nterms,
		                     stall, mine))) {
			return rc;
		}
		/* What the child did not use of its share goes on to the
		 * siblings still to come. */
		spent = b->used - before;
		left += cost[c];
		left -= spent < left ? spent : left;
		wsum -= weight[c];
	}
	return 0;
}

int bc_svo_build(struct bc_svo **out, const struct bc_svo_rpn *rpn,
                 const struct bc_svo_opts *opts, struct bc_errinfo *ei)
{
	struct bc_svo *s;
	struct build b;
	double t0 = bc_clock_ms();
	int rc;
	*out = NULL;
	memset(&b, 0, sizeof(b));
	if (!rpn || rpn->n == 0) {
		return bc_errinfo_set(ei, BC_EINVAL, "svo: empty tree");
	}
	if (opts->max_depth > BC_SVO_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "svo: max depth %u exceeds %u",
		                      opts->max_depth, BC_SVO_MAX_DEPTH);
	}
	if (!(opts->band >= 0.0f) || !isfinite(opts->band)) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "svo: band must be finite and >= 0");
	}
	s = bc_calloc(1, sizeof(*s));
	if (!s) {
		return bc_errinfo_set(ei, BC_ENOMEM, "svo: out of memory");
	}
	s->rpn = rpn;
	s->opts = *opts;
	s->opts.threshold =
	    opts->threshold ? opts->threshold : BC_SVO_DEFAULT_THRESHOLD;
	s->opts.max_depth =
	    opts->max_depth ? opts->max_depth : BC_SVO_DEFAULT_MAX_DEPTH;
	s->opts.max_bytes =
	    opts->max_bytes ? opts->max_bytes : BC_SVO_DEFAULT_MAX_BYTES;
	if (s->opts.arith == BC_RANGE_DEFAULT) {
		/* The faster pruner for this scene (docs/svo.md, "IA
		 * against RevAA"). */
		if ((rc = bc_svo_arith_default(rpn, s->opts.band,
		                               &s->opts.arith))) {
			bc_svo_destroy(s);
			return bc_errinfo_set(ei, rc, "svo: %s",
			                      bc_strerror(rc));
		}
	}
	s->stats.arith = s->opts.arith;
	bc__svo_root_box(rpn, s->opts.band, s->lo, s->hi);
	b.s = s;
	b.tau = s->opts.threshold;
	b.max_depth = s->opts.max_depth;
	b.rpn_bytes = (uint64_t)rpn->n * sizeof(struct bc_svo_term) +
	              (uint64_t)rpn->nprims * (BC_SVO_PRIM_REC * 4u + 16u);
	if ((rc = bc_svo_ranger_create(&b.g, rpn, s->opts.arith))) {
		bc_svo_destroy(s);
		return bc_errinfo_set(ei, rc, "svo: %s", bc_strerror(rc));
	}
	/* The variants of the eight children of one node per depth. */
	b.masks = bc_calloc((size_t)(b.max_depth + 2u) * 8u * rpn->nwords,
	                    sizeof(*b.masks));
	s->full = bc_calloc(rpn->nwords, sizeof(*s->full));
	if (!b.masks || !s->full || grow_nodes(s, 1)) {
		rc = BC_ENOMEM;
		goto cleanup;
	}
	bc_svo_mask_fill(rpn, s->full);
	if ((rc = bc__svo_pool_put(&s->pool, s->full, rpn->nwords, &s->full_off,
	                           &s->full_c.nwords))) {
		goto cleanup;
	}
	s->nnodes = 1;
	{
		/* What the build needs besides the tree: the RPN, the working
		 * masks and the full variant. */
		uint64_t fixed = b.rpn_bytes + (uint64_t)(b.max_depth + 3u) *
		                                   8u * rpn->nwords * 4u;
		uint64_t allow =
		    s->opts.max_bytes > fixed ? s->opts.max_bytes - fixed : 0;
		struct bc_svo_region rg;
		struct bc_svo_prune_result res;
		memset(&rg, 0, sizeof(rg));
		memcpy(rg.lo, s->lo, sizeof(rg.lo));
		memcpy(rg.hi, s->hi, sizeof(rg.hi));
		rc = bc_svo_prune(b.g, s->full, b.masks, &rg, s->opts.band,
		                  &res);
		if (rc) {
			goto cleanup;
		}
		s->stats.pruned++;
		b.used = sizeof(struct bc__svo_node);
		rc = build_node(&b, 0, s->lo, s->hi, 0, b.masks, &res,
		                UINT32_MAX, 0, allow);
	}
	if (rc) {
		goto cleanup;
	}
	/* The pool no longer moves: compressed masks may point into it. */
	s->full_c.pairs = s->pool.v + 2u * (size_t)s->full_off;
	s->stats.nodes = s->nnodes;
	if (s->stats.leaves) {
		s->stats.avg_depth_leaf /= s->stats.leaves;
	}
	if (s->stats.active) {
		s->stats.avg_terms_leaf /= s->stats.active;
	}
	s->stats.bytes = b.rpn_bytes +
	                 (uint64_t)s->nnodes * sizeof(struct bc__svo_node) +
	                 (uint64_t)s->nleaves * sizeof(struct bc__svo_leaf) +
	                 (uint64_t)s->pool.n * sizeof(uint32_t);
	s->stats.build_ms = bc_clock_ms() - t0;
cleanup:
	bc_svo_ranger_destroy(b.g);
	bc_free(b.masks);
	if (rc) {
		bc_svo_destroy(s);
		return bc_errinfo_set(ei, rc, "svo: %s", bc_strerror(rc));
	}
	*out = s;
	return 0;
}

void bc_svo_destroy(struct bc_svo *s)
{
	if (!s) {
		return;
	}
	bc_free(s->nodes);
	bc_free(s->leaves);
	bc__svo_pool_finish(&s->pool);
	bc_free(s->full);
	bc_free(s);
}

void bc_svo_get_stats(const struct bc_svo *s, struct bc_svo_stats *st)
{
	*st = s->stats;
}

const struct bc_svo_rpn *bc_svo_rpn(const struct bc_svo *s)
{
	return s->rpn;
}

void bc_svo_bounds(const struct bc_svo *s, float lo[3], float hi[3])
{
	memcpy(lo, s->lo, sizeof(s->lo));
	memcpy(hi, s->hi, sizeof(s->hi));
}

/* ---- Queries ------------------------------------------------------------- */

static void fill_ref(const struct bc_svo *s, const struct bc__svo_leaf *lf,
                     struct bc_svo_leaf_ref *ref)
{
	ref->state = (enum bc_svo_state)lf->state;
	ref->mask.pairs = s->pool.v ? s->pool.v + 2u * (size_t)lf->off : NULL;
	ref->mask.nwords = lf->npairs;
	ref->nterms = lf->nterms;
	ref->depth = lf->depth;
	ref->value = lf->value;
}

bool bc_svo_locate(const struct bc_svo *s, const float p[3],
                   struct bc_svo_leaf_ref *ref)
{
	float lo[3], hi[3];
	uint32_t node = 0;
	for (int i = 0; i < 3; i++) {
		if (!(p[i] >= s->lo[i] && p[i] <= s->hi[i])) {
			return false;
		}
		lo[i] = s->lo[i];
		hi[i] = s->hi[i];
	}
	while (s->nodes[node].child) {
		uint32_t c = 0;
		/* The same midpoints as the build computed, chosen without
		 * branches: random points make every octant choice a
		 * coin toss the branch predictor would lose. */
		for (int i = 0; i < 3; i++) {
			float mid = 0.5f * (lo[i] + hi[i]);
			uint32_t up = p[i] >= mid;
			c |= up << i;
			lo[i] = up ? mid : lo[i];
			hi[i] = up ? hi[i] : mid;
		}
		node = s->nodes[node].child + c;
	}
	fill_ref(s, &s->leaves[s->nodes[node].leaf], ref);
	memcpy(ref->lo, lo, sizeof(lo));
	memcpy(ref->hi, hi, sizeof(hi));
	return true;
}

static float eval(const struct bc_svo *s, const float p[3], uint32_t *prim)
{
	struct bc_svo_leaf_ref ref;
	if (!bc_svo_locate(s, p, &ref)) {
		return prim ? bc_svo_cmask_eval_id(s->rpn, s->full_c, p, prim)
		            : bc_svo_cmask_eval(s->rpn, s->full_c, p);
	}
	if (ref.state != BC_SVO_STATE_ACTIVE) {
		if (prim) {
			*prim = BC_NONE;
		}
		return ref.value;
	}
	return prim ? bc_svo_cmask_eval_id(s->rpn, ref.mask, p, prim)
	            : bc_svo_cmask_eval(s->rpn, ref.mask, p);
}

float bc_svo_eval(const struct bc_svo *s, const float p[3])
{
	return eval(s, p, NULL);
}

float bc_svo_eval_id(const struct bc_svo *s, const float p[3], uint32_t *prim)
{
	return eval(s, p, prim);
}
