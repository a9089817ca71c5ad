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
	bc_free(l->lead);
	bc_free(l->fast);
	bc_free(l->jump);
	bc_free(l->kills);
	bc_free(l->marks);
	bc_free(l->depth);
	bc_free(l->node_id);
	bc_free(l->roi_lo);
	bc_free(l->roi_hi);
	bc_free(l->prim_slot);
	bc_free(l->abv);
	bc_free(l->sabv);
	bc_free(l->color);
	bc_free(l->param);
	bc_free(l->wrap);
	bc_free(l->wrap_top);
	bc_free(l->dom);
	bc_free(l->ucount);
	bc_free(l->unary_slot);
	bc_free(l->unary_outer);
	bc_free(l->unary_inner);
	bc_free(l->unary_dom);
	bc_free(l->unary_param);
	bc_free(l->unary_kind);
	bc_free(l->unary_id);
	memset(l, 0, sizeof(*l));
}

/* The parts of l's arrays the fill writes, backed by memory at once
 * (bc_populate): a million-primitive layout is about 300 MB, and a fault
 * per page of it cost more than the fill on a virtual machine. */
static void populate(struct bc_lin *l)
{
	size_t n = l->count, np = l->nprims;
	uint32_t *const per_node[] = {
	    l->lead,    l->fast, l->jump,     l->kills, l->depth,
	    l->node_id, l->wrap, l->wrap_top, l->dom,   l->ucount};
	bc_populate(l->node, 2 * n * sizeof(uint32_t));
	for (size_t i = 0; i < sizeof(per_node) / sizeof(per_node[0]); i++) {
		if (per_node[i]) {
			bc_populate(per_node[i], n * sizeof(uint32_t));
		}
	}
	if (l->roi_lo) {
		bc_populate(l->roi_lo, n * sizeof(float));
	}
	bc_populate(l->roi_hi, n * sizeof(float));
	bc_populate(l->prim_slot, np * sizeof(uint32_t));
	if (l->abv) {
		bc_populate(l->abv, np * sizeof(struct bc_abv));
	} else {
		bc_populate(l->sabv, np * sizeof(*l->sabv));
	}
	bc_populate(l->color, np * sizeof(*l->color));
	bc_populate(l->param, 4 * (size_t)l->nparam * sizeof(float));
}

int bc__lin_alloc(struct bc_lin *l, uint32_t nprims, uint32_t nspheres,
                  uint32_t nops, bool unary, bool kills)
{
	size_t count = nprims ? 2u * (size_t)nprims - 1u : 0u;
	/* Room for every operator to be unary (the larger record); nparam
	 * becomes what the fill uses. */
	size_t nparam = (size_t)bc__prim_recs(nprims, nspheres) +
	                (size_t)BC_UNARY_RECORD_VEC4 * nops;
	/* Spheres alone, which no unary node maps: sphere ABVs alone. */
	bool sabv = nspheres == nprims && !unary;
	size_t nun = nops ? nops : 1u;
	memset(l, 0, sizeof(*l));
	if (nprims == 0) {
		return 0;
	}
	l->count = (uint32_t)count;
	l->nprims = nprims;
	l->nparam = (uint32_t)nparam;
	count = bc__lin_room(count);
	nparam = bc__lin_room(nparam);
	l->node = bc_calloc(2 * count, sizeof(uint32_t));
	l->lead = bc_malloc(count * sizeof(uint32_t));
	l->fast = bc_malloc(count * sizeof(uint32_t));
	l->jump = bc_malloc(count * sizeof(uint32_t));
	if (kills || unary) {
		/* Without either every r- is 0. */
		l->roi_lo = bc_malloc(count * sizeof(float));
		if (!l->roi_lo) {
			bc__lin_free(l);
			return BC_ENOMEM;
		}
	}
	if (kills) {
		l->kills = bc_malloc(count * sizeof(uint32_t));
		if (!l->kills) {
			bc__lin_free(l);
			return BC_ENOMEM;
		}
	}
	l->marks = bc_calloc((count + 63u) / 64u, sizeof(uint64_t));
	l->depth = bc_malloc(count * sizeof(uint32_t));
	l->node_id = bc_malloc(count * sizeof(uint32_t));
	l->roi_hi = bc_malloc(count * sizeof(float));
	l->prim_slot = bc_malloc(bc__lin_room(nprims) * sizeof(uint32_t));
	if (sabv) {
		l->sabv = bc_calloc(bc__lin_room(nprims), sizeof(*l->sabv));
	} else {
		l->abv = bc_calloc(bc__lin_room(nprims), sizeof(struct bc_abv));
	}
	l->color = bc_malloc(bc__lin_room(nprims) * sizeof(*l->color));
	l->param = bc_calloc(4 * nparam, sizeof(float));
	if (unary) {
		/* 16 bytes a slot, 32 a primitive: none for the many
		 * scenes without unary nodes. */
		l->wrap = bc_malloc(count * sizeof(uint32_t));
		l->wrap_top = bc_malloc(count * sizeof(uint32_t));
		l->dom = bc_malloc(count * sizeof(uint32_t));
		l->ucount = bc_malloc(count * sizeof(uint32_t));
		if (!l->wrap || !l->wrap_top || !l->dom || !l->ucount) {
			bc__lin_free(l);
			return BC_ENOMEM;
		}
	}
	l->unary_slot = bc_malloc(nun * sizeof(uint32_t));
	l->unary_outer = bc_malloc(nun * sizeof(uint32_t));
	l->unary_inner = bc_malloc(nun * sizeof(uint32_t));
	l->unary_dom = bc_malloc(nun * sizeof(uint32_t));
	l->unary_param = bc_malloc(nun * sizeof(uint32_t));
	l->unary_kind = bc_malloc(nun * sizeof(uint32_t));
	l->unary_id = bc_malloc(nun * sizeof(uint32_t));
	if (!l->unary_slot || !l->unary_outer || !l->unary_inner ||
	    !l->unary_dom || !l->unary_param || !l->unary_kind ||
	    !l->unary_id) {
		bc__lin_free(l);
		return BC_ENOMEM;
	}
	if (!l->node || !l->lead || !l->fast || !l->jump || !l->marks ||
	    !l->depth || !l->node_id || !l->roi_hi || !l->prim_slot ||
	    (!l->abv && !l->sabv) || !l->color || !l->param) {
		bc__lin_free(l);
		return BC_ENOMEM;
	}
	populate(l);
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
		out[r] =
		    m[r][0] * in[0] + m[r][1] * in[1] + m[r][2] * in[2] + t[r];
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

/* World-to-local affine rows (R^T, -R^T t) and packed shape data; for a
 * sphere its centre and radius (bc_prim_record_vec4). */
static void write_prim_record(float *rec, const struct bc_prim_data *p)
{
	float m[3][3];
	if (p->kind == BC_PRIM_SPHERE) {
		memcpy(rec, p->translate, sizeof(p->translate));
		rec[3] = p->params[0];
		return;
	}
	quat_matrix(p->rotate, m);
	for (int i = 0; i < 3; i++) {
		/* Row i of R^T is column i of R: local axis i in world. */
		rec[4 * i + 0] = m[0][i];
		rec[4 * i + 1] = m[1][i];
		rec[4 * i + 2] = m[2][i];
		rec[4 * i + 3] =
		    -(m[0][i] * p->translate[0] + m[1][i] * p->translate[1] +
		      m[2][i] * p->translate[2]);
	}
	bc_prim_pack(p, rec + 12);
}

void bc__unary_record(float *rec, const struct bc_tree *t,
                      const struct bc__node *n)
{
	const float *u = bc__uparam(t, n);
	memset(rec, 0, 4 * BC_UNARY_RECORD_VEC4 * sizeof(float));
	memcpy(rec, u, BC_UNARY_MAX_PARAMS * sizeof(float));
	switch (n->u.op.kind) {
	case BC_OP_TWIST:
	case BC_OP_BEND:
		rec[1] = 0.0f;
		rec[2] = 1.0f;
		break;
	case BC_OP_SCALE:
		rec[1] = 1.0f / u[0];
		break;
	default:
		break;
	}
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

void bc__lin_set_parent(struct bc_lin *l, uint32_t child, uint32_t parent,
                        bool left)
{
	uint32_t w =
	    l->node[2 * child] & ~(BC_WORD_LEFT | BC_WORD_ANCESTOR_MASK);
	w |= (left ? BC_WORD_LEFT : 0u) | (parent & BC_WORD_ANCESTOR_MASK);
	l->node[2 * child] = w;
}

static const float default_color[3] = {0.78f, 0.78f, 0.80f};

/* ---- filling ------------------------------------------------------------ */

static void slot_init(struct bc_lin *l, uint32_t s)
{
	if (!l->wrap) {
		return; /* no unary node: none kept */
	}
	l->wrap[s] = BC_NONE;
	l->wrap_top[s] = BC_NONE;
	l->dom[s] = BC_NONE;
	l->ucount[s] = 0;
}

/* Unary node u (just completed) wraps slot s, outside its earlier
 * wrappers. */
static void add_wrapper(struct bc_lin *l, uint32_t u, uint32_t s)
{
	l->unary_slot[u] = s;
	l->unary_outer[u] = BC_NONE;
	l->unary_inner[u] = l->wrap_top[s];
	l->unary_dom[u] = BC_NONE;
	if (l->wrap_top[s] != BC_NONE) {
		l->unary_outer[l->wrap_top[s]] = u;
	} else {
		l->wrap[s] = u;
	}
	l->wrap_top[s] = u;
}

static void emit_leaf(struct bc_tree *t, struct bc__fill *fs, uint32_t n)
{
	struct bc__node *nd = &t->pool[n];
	struct bc__lay *y = &t->lay[n];
	struct bc_lin *l = fs->l;
	uint32_t s = fs->slot++;
	struct bc_prim_data pd;
	bc__prim_read(t, nd, &pd);
	y->slot = s;
	bc__lay_mark(t, y);
	bc__lay_prim(y, fs->prim++);
	y->param = fs->param;
	fs->param += bc_prim_record_vec4((uint32_t)pd.kind);
	set_word(l, s, true, (uint32_t)pd.kind);
	l->node[2 * s + 1] = y->param;
	l->lead[s] = y->prim;
	l->node_id[s] = nd->id;
	l->prim_slot[y->prim] = s;
	slot_init(l, s);
	write_prim_record(l->param + 4u * (size_t)y->param, &pd);
	memcpy(l->color[y->prim], pd.has_color ? pd.color : default_color,
	       sizeof(l->color[0]));
}

/* Folds operator p's subtree so far (top slot left) with its next child
 * c, just emitted (top slot right): the binary node ((...) op c). */
void bc__lin_fold(struct bc_lin *l, const struct bc__node *p, uint32_t param,
                  uint32_t left, uint32_t right, uint32_t o)
{
	bc__lin_set_parent(l, left, o, true);
	bc__lin_set_parent(l, right, o, false);
	set_word(l, o, false, op_type_byte(p->u.op.kind));
	l->node[2 * o + 1] = param;
	l->lead[o] = bc_lin_first(l, left);
	l->node_id[o] = p->id;
	slot_init(l, o);
}

static void emit_fold(struct bc_tree *t, struct bc__fill *fs, uint32_t p,
                      uint32_t c)
{
	uint32_t o = fs->slot++;
	bc__lin_fold(fs->l, &t->pool[p], t->lay[p].param, t->lay[p].slot,
	             t->lay[c].slot, o);
	t->lay[p].slot = o;
}

/*
 * Emits the model in post-order without recursion (any depth): down the
 * first children, a leaf, then up through parent links. An operator's
 * record is written on the way down (pre-order, as parameter offsets always
 * were); each child after its first is folded in as soon as it is complete,
 * so an operator's slot is final when its last child is.
 */
void bc__lin_emit(struct bc_tree *t, struct bc__fill *fs, uint32_t top)
{
	uint32_t n = top;
	for (;;) {
		while (t->pool[n].is_op) {
			struct bc__node *nd = &t->pool[n];
			struct bc__lay *y = &t->lay[n];
			y->param = fs->param;
			bc__lay_mark(t, y);
			if (bc__node_unary(nd)) {
				struct bc_lin *l = fs->l;
				nd->u.unary = fs->unary++;
				fs->param += BC_UNARY_RECORD_VEC4;
				bc__unary_record(
				    l->param + 4u * (size_t)y->param, t, nd);
				l->unary_param[nd->u.unary] = y->param;
				l->unary_kind[nd->u.unary] =
				    (uint32_t)nd->u.op.kind;
				l->unary_id[nd->u.unary] = nd->id;
			} else {
				fs->param += BC_OP_RECORD_VEC4;
				write_op_record(fs->l->param +
				                    4u * (size_t)y->param,
				                &nd->u.op);
			}
			n = nd->u.first_child;
		}
		emit_leaf(t, fs, n);
		for (;;) {
			uint32_t p = t->pool[n].parent;
			if (n == top) {
				return;
			}
			if (t->pool[p].u.first_child == n) {
				t->lay[p].slot = t->lay[n].slot;
				if (bc__node_unary(&t->pool[p])) {
					add_wrapper(fs->l, t->pool[p].u.unary,
					            t->lay[p].slot);
				}
			} else {
				emit_fold(t, fs, p, n);
			}
			if (t->pool[n].next != BC_NONE) {
				n = t->pool[n].next;
				break;
			}
			n = p;
		}
	}
}

/* ROI of slot s's value (outside its wrappers) from its parent's (eq.
 * 13-16), and its kill count. */
static void propagate_base(struct bc_lin *l, uint32_t s)
{
	uint32_t a = bc_lin_parent(l, s);
	bool left = (l->node[2 * s] & BC_WORD_LEFT) != 0;
	const float *rec;
	enum bc_op op;
	float ro, lo, hi;
	if (a == BC_NONE) {
		if (l->roi_lo) {
			l->roi_lo[s] = 0.0f;
		}
		l->roi_hi[s] = 0.0f;
		if (l->kills) {
			l->kills[s] = 0;
		}
		return;
	}
	op = (enum bc_op)bc_lin_kind(l, a);
	rec = bc_lin_param(l, a);
	ro = bc_op_is_smooth(op) ? rec[1] : 0.0f;
	lo = bc_lin_roi_lo(l, a);
	hi = l->roi_hi[a];
	bc__roi_operand(op, ro, left, &lo, &hi);
	if (l->roi_lo) {
		l->roi_lo[s] = lo;
	}
	l->roi_hi[s] = hi;
	/* An intersection's operand, or a difference's right one (present
	 * alone, it leaves the left missing, which makes the difference
	 * missing), kills its operator. */
	if (l->kills) {
		l->kills[s] = l->kills[a] +
		              (bc_op_class(op) == BC_OPCLASS_INTERSECTION ||
		               (bc_op_class(op) != BC_OPCLASS_UNION && !left));
	}
}

void bc__roi_operand(enum bc_op op, float ro, bool left, float *lo, float *hi)
{
	float l = *lo, h = *hi;
	switch (bc_op_class(op)) {
	case BC_OPCLASS_UNION:
		*hi = fmaxf(h, ro);
		break;
	case BC_OPCLASS_INTERSECTION:
		*lo = fminf(l, -ro);
		break;
	case BC_OPCLASS_DIFFERENCE:
	default:
		if (left) {
			*lo = fminf(l, -ro);
		} else {
			/* The right operand is negated: its ROI flips. */
			*lo = -h;
			*hi = fmaxf(-l, ro);
		}
		break;
	}
}

void bc__roi_unary(enum bc_op kind, const float *rec, float *lo, float *hi)
{
	switch (kind) {
	case BC_OP_OFFSET:
		*lo = fminf(*lo, *lo + rec[0]);
		*hi = fmaxf(*hi + rec[0], 0.0f);
		break;
	case BC_OP_ONION:
		*hi = *hi + rec[0];
		*lo = fminf(*lo, -*hi);
		break;
	case BC_OP_SCALE:
		*lo *= rec[1];
		*hi *= rec[1];
		break;
	default:
		break;
	}
}

/*
 * Slot s's wrappers, outermost first: the ROI each one's child sees (a
 * unary node's child matters where the node's value does), the domain
 * node around each, and then the slot's own. ROI rules (docs): offset a
 * shifts by a (r+ kept >= 0: a larger r+ only grows ABVs); onion t makes
 * [-(r+ + t), r+ + t]; scale s divides by s; the domain nodes keep it.
 */
static void propagate(struct bc_lin *l, uint32_t s)
{
	uint32_t a = bc_lin_parent(l, s);
	uint32_t d;
	float lo, hi;
	propagate_base(l, s);
	if (!l->wrap) {
		return; /* no unary node: the base rules are all */
	}
	d = a == BC_NONE ? BC_NONE : l->dom[a];
	l->ucount[s] = 0;
	if (a != BC_NONE) {
		uint32_t w = l->wrap[a];
		l->ucount[s] = l->ucount[a];
		for (; w != BC_NONE; w = l->unary_outer[w]) {
			if (bc_op_has_value((enum bc_op)l->unary_kind[w])) {
				l->ucount[s]++;
				break;
			}
		}
	}
	lo = l->roi_lo[s];
	hi = l->roi_hi[s];
	for (uint32_t u = l->wrap_top[s]; u != BC_NONE; u = l->unary_inner[u]) {
		float *rec = l->param + 4u * (size_t)l->unary_param[u];
		enum bc_op kind = (enum bc_op)l->unary_kind[u];
		l->unary_dom[u] = d;
		bc__roi_unary(kind, rec, &lo, &hi);
		if (kind == BC_OP_TWIST || kind == BC_OP_BEND) {
			rec[3] = hi;
		}
		if (bc_op_is_domain(kind)) {
			d = u;
		}
	}
	l->roi_lo[s] = lo;
	l->roi_hi[s] = hi;
	l->dom[s] = d;
}

void bc__lin_link(struct bc_lin *l, uint32_t s)
{
	propagate(l, s);
	bc__lin_pointers(l, s);
}

void bc__lin_propagate(struct bc_lin *l, uint32_t s)
{
	propagate(l, s);
}

void bc__lin_pointers_down(struct bc_lin *l, uint32_t lo, uint32_t top)
{
	for (uint32_t s = top + 1; s-- > lo;) {
		bc__lin_pointers(l, s);
	}
}

void bc__lin_pointers(struct bc_lin *l, uint32_t s)
{
	uint32_t a = bc_lin_parent(l, s);
	if (a == BC_NONE) {
		l->depth[s] = 0;
		l->jump[s] = BC_NONE;
		l->fast[s] = BC_NONE;
		return;
	}
	l->depth[s] = l->depth[a] + 1;
	/* The run of same-side edges continues through a when a sits on the
	 * same side of its own parent. */
	l->fast[s] = a;
	if (bc_lin_parent(l, a) != BC_NONE &&
	    ((l->node[2 * a] ^ l->node[2 * s]) & BC_WORD_LEFT) == 0) {
		l->fast[s] = l->fast[a];
	}
	/* Myers' rule: jump twice as far when the parent's jump and its
	 * jump's jump span equal lengths. */
	l->jump[s] = a;
	if (l->jump[a] != BC_NONE) {
		uint32_t j1 = l->jump[a];
		uint32_t j2 = l->jump[j1];
		if (j2 != BC_NONE &&
		    l->depth[a] - l->depth[j1] == l->depth[j1] - l->depth[j2]) {
			l->jump[s] = j2;
		}
	}
}

/* ---- domain nodes: bounds and Lipschitz -------------------------------- */

/* The Lipschitz bound of twist (rate k) and bend within radius r of their
 * axis. Twist q = R_y(k y) p has Jacobian R (I + k J(x,z) e_y^T) whose
 * largest singular value is (m + sqrt(m^2 + 4)) / 2, m = |k| r; bend's
 * R_z(k x) (I + k J(x,y) e_x^T) is bounded by 1 + |k| r (the triangle
 * inequality; attained at y = -r). */
float bc_unary_own_lip(uint32_t kind, float rate, float r)
{
	float m = fabsf(rate) * r;
	if (kind == BC_OP_TWIST) {
		return 0.5f * (m + sqrtf(m * m + 4.0f));
	}
	return 1.0f + m;
}

static void abv_set_box(struct bc_abv *abv, const float lo[3],
                        const float hi[3])
{
	memset(abv, 0, sizeof(*abv));
	abv->shape = BC_ABV_BOX;
	for (int i = 0; i < 3; i++) {
		abv->center[i] = 0.5f * (lo[i] + hi[i]);
		abv->half[i] = 0.5f * (hi[i] - lo[i]);
		abv->axis[i][i] = 1.0f;
	}
}

/*
 * Maps a bounding shape from domain node u's child frame to its own input
 * frame: a shape containing every point p whose mapped point lies in the
 * given one (the preimage). Scale is exact (the shape scaled); the others
 * take the shape's AABB: elongate grows each side by h (away from 0);
 * mirror spans [-hi, hi] on its axes; repeat is the union of the copies'
 * boxes; twist and bend preserve the distance to their axis (y, z), so the
 * preimage lies in the cylinder of the box's largest radius, whose height
 * is the box's. Returns that radius for twist and bend (0 otherwise).
 */
float bc__abv_preimage(enum bc_op kind, const float *rec, struct bc_abv *abv)
{
	float lo[3], hi[3], r = 0.0f;
	if (kind == BC_OP_SCALE) {
		float f = rec[0];
		for (int i = 0; i < 3; i++) {
			abv->center[i] *= f;
			/* A capsule's end or a box's half extents: one field
			 * (struct bc_abv's union), scaled once. */
			abv->end[i] *= f;
		}
		abv->radius *= f;
		return 0.0f;
	}
	bc_abv_aabb(abv, lo, hi);
	switch (kind) {
	case BC_OP_ELONGATE:
		for (int i = 0; i < 3; i++) {
			lo[i] = lo[i] > 0.0f ? lo[i] + rec[i] : lo[i] - rec[i];
			hi[i] = hi[i] < 0.0f ? hi[i] - rec[i] : hi[i] + rec[i];
		}
		break;
	case BC_OP_MIRROR: {
		uint32_t mask = (uint32_t)rec[0];
		for (int i = 0; i < 3; i++) {
			if (mask & (1u << i)) {
				float m = fmaxf(hi[i], 0.0f);
				lo[i] = -m;
				hi[i] = m;
			}
		}
		break;
	}
	case BC_OP_REPEAT:
		for (int i = 0; i < 3; i++) {
			float half = 0.5f * (rec[3 + i] - 1.0f) * rec[i];
			lo[i] -= half;
			hi[i] += half;
		}
		break;
	case BC_OP_TWIST:
	case BC_OP_BEND: {
		/* Axes of the rotation plane: x and z (twist), x and y. */
		int a = 0, b = kind == BC_OP_TWIST ? 2 : 1;
		float ma = fmaxf(fabsf(lo[a]), fabsf(hi[a]));
		float mb = fmaxf(fabsf(lo[b]), fabsf(hi[b]));
		r = sqrtf(ma * ma + mb * mb);
		lo[a] = lo[b] = -r;
		hi[a] = hi[b] = r;
		break;
	}
	default:
		break;
	}
	abv_set_box(abv, lo, hi);
	return r;
}

void bc__lin_place_abv(struct bc_tree *t, struct bc_lin *l, uint32_t k,
                       const struct bc_prim_data *p)
{
	float lo[3], hi[3];
	uint32_t s = l->prim_slot[k];
	struct bc_abv a;
	bc__abv_place(p, l->roi_hi[s], &a);
	for (uint32_t d = bc_lin_dom(l, s); d != BC_NONE; d = l->unary_dom[d]) {
		float *rec = l->param + 4u * (size_t)l->unary_param[d];
		float r =
		    bc__abv_preimage((enum bc_op)l->unary_kind[d], rec, &a);
		if ((l->unary_kind[d] == BC_OP_TWIST ||
		     l->unary_kind[d] == BC_OP_BEND) &&
		    r > rec[1]) {
			rec[1] = r;
		}
	}
	bc__lin_set_abv(l, k, &a);
	bc_abv_aabb(&a, lo, hi);
	for (int i = 0; i < 3; i++) {
		l->lo[i] = fminf(l->lo[i], lo[i]);
		l->hi[i] = fmaxf(l->hi[i], hi[i]);
	}
	(void)t;
}

void bc__lin_set_abv(struct bc_lin *l, uint32_t k, const struct bc_abv *a)
{
	if (l->abv) {
		l->abv[k] = *a;
		return;
	}
	/* Spheres alone (bc__lin_alloc): a sphere's ABV is a sphere. Any
	 * other shape would be kept as the sphere around its box. */
	if (a->shape == BC_ABV_SPHERE) {
		memcpy(l->sabv[k], a->center, sizeof(a->center));
		l->sabv[k][3] = a->radius;
	} else {
		float lo[3], hi[3], e2 = 0.0f;
		bc_abv_aabb(a, lo, hi);
		for (int i = 0; i < 3; i++) {
			float e = 0.5f * (hi[i] - lo[i]);
			l->sabv[k][i] = lo[i] + e;
			e2 += e * e;
		}
		l->sabv[k][3] = sqrtf(e2);
	}
}

void bc__lin_update_size(struct bc_lin *l)
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
			n = t->pool[n].u.first_child;
		}
		struct bc_prim_data pd;
		bc__prim_read(t, &t->pool[n], &pd);
		bc__lin_place_abv(t, l, bc__prim(t, &t->pool[n]), &pd);
		while (n != top && t->pool[n].next == BC_NONE) {
			n = t->pool[n].parent;
		}
		if (n == top) {
			return;
		}
		n = t->pool[n].next;
	}
}

static bool is_bend(const struct bc_lin *l, uint32_t u)
{
	return l->unary_kind[u] == BC_OP_TWIST ||
	       l->unary_kind[u] == BC_OP_BEND;
}

/* The Lipschitz bounds of twist and bend (their radii R known): each
 * node's L is the largest product of the own bounds from a primitive up to
 * and including it; the tree's is the largest product over whole paths. */
static void compute_lips(struct bc_lin *l)
{
	l->lip = 1.0f;
	for (uint32_t u = 0; u < l->nunary; u++) {
		if (is_bend(l, u)) {
			l->param[4u * (size_t)l->unary_param[u] + 2] = 1.0f;
		}
	}
	for (uint32_t k = 0; k < l->nprims; k++) {
		float prod = 1.0f;
		for (uint32_t d = bc_lin_dom(l, l->prim_slot[k]); d != BC_NONE;
		     d = l->unary_dom[d]) {
			float *rec = l->param + 4u * (size_t)l->unary_param[d];
			if (!is_bend(l, d)) {
				continue;
			}
			prod *=
			    bc_unary_own_lip(l->unary_kind[d], rec[0], rec[1]);
			rec[2] = fmaxf(rec[2], prod);
		}
		l->lip = fmaxf(l->lip, prod);
	}
}

static void place_all_abvs(struct bc_tree *t, struct bc_lin *l)
{
	for (int i = 0; i < 3; i++) {
		l->lo[i] = INFINITY;
		l->hi[i] = -INFINITY;
	}
	for (uint32_t u = 0; u < l->nunary; u++) {
		if (is_bend(l, u)) {
			l->param[4u * (size_t)l->unary_param[u] + 1] = 0.0f;
		}
	}
	place_subtree(t, l, t->root);
	bc__lin_update_size(l);
	compute_lips(l);
}

bool bc__lin_prim_bends(const struct bc_tree *t, const struct bc__node *n)
{
	const struct bc_lin *l = &t->lin;
	for (uint32_t d = bc_lin_dom(l, bc__lay(t, n)->slot); d != BC_NONE;
	     d = l->unary_dom[d]) {
		if (is_bend(l, d)) {
			return true;
		}
	}
	return false;
}

void bc__lin_fill(struct bc_tree *t, struct bc_lin *l)
{
	struct bc__fill fs = {.l = l};
	uint32_t root, depth = 0, most = 0;
	l->nesting = bc__measure(t, t->root);
	bc__lin_emit(t, &fs, t->root);
	l->nunary = fs.unary;
	l->nparam = fs.param;
	l->lip = 1.0f;
	root = t->lay[t->root].slot;
	l->node[2 * root] &= ~(BC_WORD_LEFT | BC_WORD_ANCESTOR_MASK);
	l->node[2 * root] |= BC_WORD_NO_ANCESTOR;

	/* Parents come after children: walk down from the root. */
	for (uint32_t s = l->count; s-- > 0;) {
		bc__lin_link(l, s);
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
	const struct bc__lay *y = bc__lay(t, n);
	struct bc_prim_data pd;
	bc__prim_read(t, n, &pd);
	write_prim_record(l->param + 4u * (size_t)y->param, &pd);
	memcpy(l->color[y->prim], pd.has_color ? pd.color : default_color,
	       sizeof(l->color[0]));
	if (bc__lin_prim_bends(t, n)) {
		/* Its twist and bend ancestors' radii (and so bounds) may
		 * shrink as well as grow: recomputed over the tree. */
		place_all_abvs(t, l);
		return;
	}
	bc__lin_place_abv(t, l, y->prim, &pd);
	bc__lin_update_size(l);
}

void bc__lin_update_op(struct bc_tree *t, const struct bc__node *n)
{
	struct bc_lin *l = &t->lin;
	const struct bc__lay *y = bc__lay(t, n);
	uint32_t o = y->slot, first = bc_lin_first(l, y->slot);
	uint32_t type = op_type_byte(n->u.op.kind);
	/* The fold's slots: the top, then down the chain of left children. */
	for (uint32_t i = 0; i + 1 < n->u.nchildren; i++) {
		set_word(l, o, false, type);
		o = bc_lin_first(l, o - 1) - 1;
	}
	write_op_record(l->param + 4u * (size_t)y->param, &n->u.op);
	for (uint32_t s = y->slot; s-- > first;) {
		propagate(l, s);
	}
	place_subtree(t, l, (uint32_t)(n - t->pool));
	bc__lin_update_size(l);
	if (l->nunary) {
		/* Twist and bend radii only grew (conservative): their
		 * bounds follow. */
		compute_lips(l);
	}
}

void bc__lin_update_unary(struct bc_tree *t, const struct bc__node *n)
{
	struct bc_lin *l = &t->lin;
	const struct bc__lay *y = bc__lay(t, n);
	uint32_t first = bc_lin_first(l, y->slot);
	l->unary_kind[n->u.unary] = (uint32_t)n->u.op.kind;
	bc__unary_record(l->param + 4u * (size_t)y->param, t, n);
	for (uint32_t s = y->slot + 1; s-- > first;) {
		propagate(l, s);
	}
	/* Radii and Lipschitz bounds of twist and bend depend on ABVs
	 * anywhere below them: recomputed with every ABV (O(n)). */
	place_all_abvs(t, l);
}
