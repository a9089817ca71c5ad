/*
 * The linearized blobtree (Zanni 2024, §5 and §7): post-order slots with the
 * GPU node word and parameter records, subtree extents, jump pointers for
 * sparse traversal, ROI propagation (eq. 13-16) and the ABVs that follow
 * from it. Also the in-place updates that parameter edits make.
 *
 * Ancestor shortcuts: the paper's fast ancestor index (§5) jumps to the top
 * of the run of same-side edges above a node -- one step up a whole left
 * comb. Zig-zag paths defeat it, so each slot also has a skew-binary jump
 * pointer (Myers 1983): any monotone climb (the sparse traversal climbs while
 * an ancestor holds no other active operand) then finishes in O(log depth)
 * steps whatever the tree's shape. The climb tries the fast index first.
 */
#include "tree_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

void bc__lin_free(struct bc_lin *l)
{
	bc_free(l->node);
	bc_free(l->first);
	bc_free(l->fast);
	bc_free(l->jump);
	bc_free(l->kills);
	bc_free(l->depth);
	bc_free(l->node_id);
	bc_free(l->prim_of);
	bc_free(l->roi);
	bc_free(l->prim_slot);
	bc_free(l->abv);
	bc_free(l->color);
	bc_free(l->param);
	memset(l, 0, sizeof(*l));
}

int bc__lin_alloc(struct bc_lin *l, uint32_t nprims, uint32_t nops)
{
	size_t count = nprims ? 2u * (size_t)nprims - 1u : 0u;
	size_t nparam = (size_t)BC_PRIM_RECORD_VEC4 * nprims +
			(size_t)BC_OP_RECORD_VEC4 * nops;
	memset(l, 0, sizeof(*l));
	if (nprims == 0) {
		return 0;
	}
	l->count = (uint32_t)count;
	l->nprims = nprims;
	l->nparam = (uint32_t)nparam;
	l->node = bc_calloc(2 * count, sizeof(uint32_t));
	l->first = bc_malloc(count * sizeof(uint32_t));
	l->fast = bc_malloc(count * sizeof(uint32_t));
	l->jump = bc_malloc(count * sizeof(uint32_t));
	l->kills = bc_malloc(count * sizeof(uint32_t));
	l->depth = bc_malloc(count * sizeof(uint32_t));
	l->node_id = bc_malloc(count * sizeof(uint32_t));
	l->prim_of = bc_malloc(count * sizeof(uint32_t));
	l->roi = bc_malloc(2 * count * sizeof(float));
	l->prim_slot = bc_malloc(nprims * sizeof(uint32_t));
	l->abv = bc_calloc(nprims, sizeof(struct bc_abv));
	l->color = bc_malloc(nprims * sizeof(*l->color));
	l->param = bc_calloc(4 * nparam, sizeof(float));
	if (!l->node || !l->first || !l->fast || !l->jump || !l->kills ||
	    !l->depth ||
	    !l->node_id || !l->prim_of || !l->roi || !l->prim_slot ||
	    !l->abv || !l->color || !l->param) {
		bc__lin_free(l);
		return BC_ENOMEM;
	}
	return 0;
}

/* ---- transforms and records -------------------------------------------- */

/* Rotation matrix of a unit quaternion (x, y, z, w): m[r][c]. */
static void quat_matrix(const float q[4], float m[3][3])
{
	float x = q[0], y = q[1], z = q[2], w = q[3];
	m[0][0] = 1.0f - 2.0f * (y * y + z * z);
	m[0][1] = 2.0f * (x * y - z * w);
	m[0][2] = 2.0f * (x * z + y * w);
	m[1][0] = 2.0f * (x * y + z * w);
	m[1][1] = 1.0f - 2.0f * (x * x + z * z);
	m[1][2] = 2.0f * (y * z - x * w);
	m[2][0] = 2.0f * (x * z - y * w);
	m[2][1] = 2.0f * (y * z + x * w);
	m[2][2] = 1.0f - 2.0f * (x * x + y * y);
}

static void to_world(const float m[3][3], const float t[3], const float in[3],
		     float out[3])
{
	for (int r = 0; r < 3; r++) {
		out[r] = m[r][0] * in[0] + m[r][1] * in[1] + m[r][2] * in[2] +
			 t[r];
	}
}

void bc__abv_place(const struct bc_prim_data *p, float offset,
		   struct bc_abv *abv)
{
	struct bc_abv local;
	float m[3][3];
	bc_prim_bound(p, &local);
	quat_matrix(p->rotate, m);
	*abv = local;
	to_world(m, p->translate, local.center, abv->center);
	switch (local.shape) {
	case BC_ABV_SPHERE:
		abv->radius = local.radius + offset;
		break;
	case BC_ABV_CAPSULE:
		to_world(m, p->translate, local.end, abv->end);
		abv->radius = local.radius + offset;
		break;
	case BC_ABV_BOX:
	default:
		/* Local box axes are the local frame's (bc_prim_bound); the
		 * offset box contains the rounded offset of the box. */
		for (int i = 0; i < 3; i++) {
			float a[3] = {m[0][0] * local.axis[i][0] +
					      m[0][1] * local.axis[i][1] +
					      m[0][2] * local.axis[i][2],
				      m[1][0] * local.axis[i][0] +
					      m[1][1] * local.axis[i][1] +
					      m[1][2] * local.axis[i][2],
				      m[2][0] * local.axis[i][0] +
					      m[2][1] * local.axis[i][1] +
					      m[2][2] * local.axis[i][2]};
			memcpy(abv->axis[i], a, sizeof(a));
			abv->half[i] = local.half[i] + offset;
		}
		break;
	}
}

/* World-to-local affine rows (R^T, -R^T t) and packed shape data. */
static void write_prim_record(float *rec, const struct bc_prim_data *p)
{
	float m[3][3];
	quat_matrix(p->rotate, m);
	for (int i = 0; i < 3; i++) {
		/* Row i of R^T is column i of R: local axis i in world. */
		rec[4 * i + 0] = m[0][i];
		rec[4 * i + 1] = m[1][i];
		rec[4 * i + 2] = m[2][i];
		rec[4 * i + 3] = -(m[0][i] * p->translate[0] +
				   m[1][i] * p->translate[1] +
				   m[2][i] * p->translate[2]);
	}
	bc_prim_pack(p, rec + 12);
}

static void write_op_record(float *rec, const struct bc_op_data *op)
{
	rec[0] = op->blend;
	rec[1] = op->range;
	rec[2] = 0.0f;
	rec[3] = 0.0f;
}

static uint32_t op_type_byte(enum bc_op kind)
{
	/* ignoreMod(2) isUnary(1) nodeop(5). */
	return ((uint32_t)bc_op_class(kind) << 6) | ((uint32_t)kind & 0x1fu);
}

static void set_word(struct bc_lin *l, uint32_t slot, bool leaf, uint32_t type)
{
	uint32_t w = l->node[2 * slot];
	w &= BC_WORD_LEFT | BC_WORD_ANCESTOR_MASK;
	w |= (leaf ? BC_WORD_LEAF : 0u) |
	     ((type & BC_WORD_TYPE_MASK) << BC_WORD_TYPE_SHIFT);
	l->node[2 * slot] = w;
}

static void set_parent(struct bc_lin *l, uint32_t child, uint32_t parent,
		       bool left)
{
	uint32_t w = l->node[2 * child] &
		     ~(BC_WORD_LEFT | BC_WORD_ANCESTOR_MASK);
	w |= (left ? BC_WORD_LEFT : 0u) | (parent & BC_WORD_ANCESTOR_MASK);
	l->node[2 * child] = w;
}

static const float default_color[3] = {0.78f, 0.78f, 0.80f};

/* ---- filling ------------------------------------------------------------ */

struct fill_state {
	struct bc_lin *l;
	uint32_t slot, prim, param;
};

static void emit_leaf(struct bc_tree *t, struct fill_state *fs, uint32_t n)
{
	struct bc__node *nd = &t->pool[n];
	struct bc_lin *l = fs->l;
	uint32_t s = fs->slot++;
	nd->slot = s;
	nd->prim = fs->prim++;
	nd->param = fs->param;
	fs->param += BC_PRIM_RECORD_VEC4;
	set_word(l, s, true, (uint32_t)nd->u.prim.kind);
	l->node[2 * s + 1] = nd->param;
	l->first[s] = s;
	l->node_id[s] = nd->id;
	l->prim_of[s] = nd->prim;
	l->prim_slot[nd->prim] = s;
	write_prim_record(l->param + 4u * (size_t)nd->param, &nd->u.prim);
	memcpy(l->color[nd->prim],
	       nd->u.prim.has_color ? nd->u.prim.color : default_color,
	       sizeof(l->color[0]));
}

/* Folds operator p's subtree so far (top slot p->slot) with its next child
 * c, just emitted: the binary node ((...) op c). */
static void emit_fold(struct fill_state *fs, struct bc__node *p,
                      const struct bc__node *c)
{
	struct bc_lin *l = fs->l;
	uint32_t left = p->slot, right = c->slot, o = fs->slot++;
	set_parent(l, left, o, true);
	set_parent(l, right, o, false);
	set_word(l, o, false, op_type_byte(p->u.op.kind));
	l->node[2 * o + 1] = p->param;
	l->first[o] = l->first[left];
	l->node_id[o] = p->id;
	l->prim_of[o] = BC_NONE;
	p->slot = o;
}

/*
 * Emits the model in post-order without recursion (any depth): down the
 * first children, a leaf, then up through parent links. An operator's
 * record is written on the way down (pre-order, as parameter offsets always
 * were); each child after its first is folded in as soon as it is complete,
 * so an operator's slot is final when its last child is.
 */
static void emit_all(struct bc_tree *t, struct fill_state *fs, uint32_t top)
{
	uint32_t n = top;
	for (;;) {
		while (t->pool[n].is_op) {
			struct bc__node *nd = &t->pool[n];
			nd->param = fs->param;
			fs->param += BC_OP_RECORD_VEC4;
			write_op_record(fs->l->param + 4u * (size_t)nd->param,
			                &nd->u.op);
			n = nd->first_child;
		}
		emit_leaf(t, fs, n);
		for (;;) {
			uint32_t p = t->pool[n].parent;
			if (n == top) {
				return;
			}
			if (t->pool[p].first_child == n) {
				t->pool[p].slot = t->pool[n].slot;
			} else {
				emit_fold(fs, &t->pool[p], &t->pool[n]);
			}
			if (t->pool[n].next != BC_NONE) {
				n = t->pool[n].next;
				break;
			}
			n = p;
		}
	}
}

/* ROI of slot s from its parent's (eq. 13-16), and its kill count. */
static void propagate(struct bc_lin *l, uint32_t s)
{
	uint32_t a = bc_lin_parent(l, s);
	bool left = (l->node[2 * s] & BC_WORD_LEFT) != 0;
	const float *rec;
	enum bc_op op;
	float ro, lo, hi;
	if (a == BC_NONE) {
		l->roi[2 * s] = 0.0f;
		l->roi[2 * s + 1] = 0.0f;
		l->kills[s] = 0;
		return;
	}
	op = (enum bc_op)bc_lin_kind(l, a);
	rec = bc_lin_param(l, a);
	ro = bc_op_is_smooth(op) ? rec[1] : 0.0f;
	lo = l->roi[2 * a];
	hi = l->roi[2 * a + 1];
	l->kills[s] = l->kills[a];
	switch (bc_op_class(op)) {
	case BC_OPCLASS_UNION:
		l->roi[2 * s] = lo;
		l->roi[2 * s + 1] = fmaxf(hi, ro);
		break;
	case BC_OPCLASS_INTERSECTION:
		l->roi[2 * s] = fminf(lo, -ro);
		l->roi[2 * s + 1] = hi;
		l->kills[s]++;
		break;
	case BC_OPCLASS_DIFFERENCE:
	default:
		if (left) {
			l->roi[2 * s] = fminf(lo, -ro);
			l->roi[2 * s + 1] = hi;
		} else {
			/* The right operand is negated: its ROI flips. */
			l->roi[2 * s] = -hi;
			l->roi[2 * s + 1] = fmaxf(-lo, ro);
			/* Present alone, a right operand leaves the left
			 * missing, which makes the difference missing. */
			l->kills[s]++;
		}
		break;
	}
}

static void place_abv(struct bc_tree *t, struct bc_lin *l, uint32_t k,
		      const struct bc_prim_data *p)
{
	float lo[3], hi[3];
	bc__abv_place(p, l->roi[2 * l->prim_slot[k] + 1], &l->abv[k]);
	bc_abv_aabb(&l->abv[k], lo, hi);
	for (int i = 0; i < 3; i++) {
		l->lo[i] = fminf(l->lo[i], lo[i]);
		l->hi[i] = fmaxf(l->hi[i], hi[i]);
	}
	(void)t;
}

static void update_size(struct bc_lin *l)
{
	float dx = l->hi[0] - l->lo[0], dy = l->hi[1] - l->lo[1],
	      dz = l->hi[2] - l->lo[2];
	l->size = sqrtf(dx * dx + dy * dy + dz * dz);
}

/* Places the ABVs of pool node top's subtree (ROIs must be known): its
 * leaves in order, through parent links (no recursion). */
static void place_subtree(struct bc_tree *t, struct bc_lin *l, uint32_t top)
{
	uint32_t n = top;
	for (;;) {
		while (t->pool[n].is_op) {
			n = t->pool[n].first_child;
		}
		place_abv(t, l, t->pool[n].prim, &t->pool[n].u.prim);
		while (n != top && t->pool[n].next == BC_NONE) {
			n = t->pool[n].parent;
		}
		if (n == top) {
			return;
		}
		n = t->pool[n].next;
	}
}

static void place_all_abvs(struct bc_tree *t, struct bc_lin *l)
{
	for (int i = 0; i < 3; i++) {
		l->lo[i] = INFINITY;
		l->hi[i] = -INFINITY;
	}
	place_subtree(t, l, t->root);
	update_size(l);
}

void bc__lin_fill(struct bc_tree *t, struct bc_lin *l)
{
	struct fill_state fs = {.l = l};
	uint32_t root, depth = 0, most = 0;
	l->nesting = bc__measure(t, t->root);
	emit_all(t, &fs, t->root);
	root = t->pool[t->root].slot;
	l->node[2 * root] &= ~(BC_WORD_LEFT | BC_WORD_ANCESTOR_MASK);
	l->node[2 * root] |= BC_WORD_NO_ANCESTOR;

	/* Parents come after children: walk down from the root. */
	for (uint32_t s = l->count; s-- > 0;) {
		uint32_t a = bc_lin_parent(l, s);
		propagate(l, s);
		if (a == BC_NONE) {
			l->depth[s] = 0;
			l->jump[s] = BC_NONE;
			l->fast[s] = BC_NONE;
			continue;
		}
		l->depth[s] = l->depth[a] + 1;
		/* The run of same-side edges continues through a when a sits
		 * on the same side of its own parent. */
		l->fast[s] = a;
		if (bc_lin_parent(l, a) != BC_NONE &&
		    ((l->node[2 * a] ^ l->node[2 * s]) & BC_WORD_LEFT) == 0) {
			l->fast[s] = l->fast[a];
		}
		/* Myers' rule: jump twice as far when the parent's jump and
		 * its jump's jump span equal lengths. */
		l->jump[s] = a;
		if (l->jump[a] != BC_NONE) {
			uint32_t j1 = l->jump[a];
			uint32_t j2 = l->jump[j1];
			if (j2 != BC_NONE &&
			    l->depth[a] - l->depth[j1] ==
				    l->depth[j1] - l->depth[j2]) {
				l->jump[s] = j2;
			}
		}
	}
	for (uint32_t s = 0; s < l->count; s++) {
		depth += bc_lin_is_leaf(l, s) ? 1u : 0u;
		if (!bc_lin_is_leaf(l, s)) {
			depth--;
		}
		if (depth > most) {
			most = depth;
		}
	}
	l->stack = most;
	place_all_abvs(t, l);
}

void bc__lin_update_prim(struct bc_tree *t, const struct bc__node *n)
{
	struct bc_lin *l = &t->lin;
	write_prim_record(l->param + 4u * (size_t)n->param, &n->u.prim);
	memcpy(l->color[n->prim],
	       n->u.prim.has_color ? n->u.prim.color : default_color,
	       sizeof(l->color[0]));
	place_abv(t, l, n->prim, &n->u.prim);
	update_size(l);
}

void bc__lin_update_op(struct bc_tree *t, const struct bc__node *n)
{
	struct bc_lin *l = &t->lin;
	uint32_t o = n->slot, first = l->first[n->slot];
	uint32_t type = op_type_byte(n->u.op.kind);
	/* The fold's slots: the top, then down the chain of left children. */
	for (uint32_t i = 0; i + 1 < n->nchildren; i++) {
		set_word(l, o, false, type);
		o = l->first[o - 1] - 1;
	}
	write_op_record(l->param + 4u * (size_t)n->param, &n->u.op);
	for (uint32_t s = n->slot; s-- > first;) {
		propagate(l, s);
	}
	place_subtree(t, l, (uint32_t)(n - t->pool));
	update_size(l);
}
