/*
 * Field evaluation on the linearized tree: full bottom-up evaluation (the
 * reference), and the sparse bottom-up traversal over a set of active
 * primitives (Zanni 2024, §5) that builds a pruned tree view (§6.2).
 *
 * The sparse traversal. The paper's text omits its Algorithm 2; this is our
 * formulation. A primitive outside the query volume's ABV set is "missing":
 * its value is taken as +inf. Then an operator with one missing operand is a
 * selector: union passes the other operand through; intersection becomes
 * missing; difference passes its left operand and becomes missing when only
 * its right one is present. Active primitives are visited in post-order with
 * a stack of complete subtrees, each marked present or missing. After a
 * push, the top entry climbs: while its parent holds no other active
 * primitive (the parent's subtree starts after the entry below and ends
 * before the next active primitive), it stands for its parent -- becoming
 * missing if the edge kills. That climb is monotone, so jump pointers make it
 * O(log depth) (a left comb is one jump, not a walk). When the parent does
 * hold the entry below, both are its operands: the parent is evaluated (an
 * instruction) or selects. Entries that become missing take back the
 * instructions they had emitted, which are always the program's tail.
 */
#include "blobcast/blobtree.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

void bc_prim_record_long(uint32_t kind, const float *rec,
                         float out[4 * BC_PRIM_RECORD_VEC4])
{
	if (kind != BC_PRIM_SPHERE) {
		memcpy(out, rec, 4 * BC_PRIM_RECORD_VEC4 * sizeof(float));
		return;
	}
	memset(out, 0, 4 * BC_PRIM_RECORD_VEC4 * sizeof(float));
	for (int i = 0; i < 3; i++) {
		out[4 * i + i] = 1.0f;
		out[4 * i + 3] = -rec[i];
	}
	out[12] = rec[3];
}

static inline float eval_record(uint32_t kind, const float *rec,
                                const float p[3])
{
	if (kind == BC_PRIM_SPHERE) {
		return bc_prim_sdf(BC_PRIM_SPHERE, rec + 3, p[0] - rec[0],
		                   p[1] - rec[1], p[2] - rec[2]);
	}
	float x = rec[0] * p[0] + rec[1] * p[1] + rec[2] * p[2] + rec[3];
	float y = rec[4] * p[0] + rec[5] * p[1] + rec[6] * p[2] + rec[7];
	float z = rec[8] * p[0] + rec[9] * p[1] + rec[10] * p[2] + rec[11];
	return bc_prim_sdf((enum bc_prim)kind, rec + 12, x, y, z);
}

/* ---- unary and domain nodes ---------------------------------------------- */

void bc_domain_apply(uint32_t kind, const float *rec, float p[3])
{
	switch (kind) {
	case BC_OP_ELONGATE:
		for (int i = 0; i < 3; i++) {
			p[i] -= fminf(fmaxf(p[i], -rec[i]), rec[i]);
		}
		break;
	case BC_OP_TWIST: {
		/* Rotation about y by rate * y. */
		float a = rec[0] * p[1], c = cosf(a), s = sinf(a);
		float x = c * p[0] + s * p[2], z = -s * p[0] + c * p[2];
		p[0] = x;
		p[2] = z;
		break;
	}
	case BC_OP_BEND: {
		/* opCheapBend: the xy plane rotated by rate * x. */
		float a = rec[0] * p[0], c = cosf(a), s = sinf(a);
		float x = c * p[0] + s * p[1], y = -s * p[0] + c * p[1];
		p[0] = x;
		p[1] = y;
		break;
	}
	case BC_OP_MIRROR: {
		uint32_t mask = (uint32_t)rec[0];
		for (int i = 0; i < 3; i++) {
			if (mask & (1u << i)) {
				p[i] = fabsf(p[i]);
			}
		}
		break;
	}
	case BC_OP_REPEAT:
		/* opRepLim with count copies centred on the origin: the
		 * nearest copy's index, clamped to the grid. */
		for (int i = 0; i < 3; i++) {
			float n = rec[3 + i], o, id;
			if (!(n > 1.0f)) {
				continue;
			}
			o = 0.5f * (n - 1.0f);
			id = floorf(p[i] / rec[i] + o + 0.5f);
			id = fminf(fmaxf(id, 0.0f), n - 1.0f);
			p[i] -= rec[i] * (id - o);
		}
		break;
	case BC_OP_SCALE:
		for (int i = 0; i < 3; i++) {
			p[i] *= rec[1];
		}
		break;
	default:
		break;
	}
}

void bc_domain_map(const struct bc_lin *l, uint32_t d, const float p[3],
                   float out[3])
{
	uint32_t chain[BC_DOMAIN_MAX_CHAIN];
	uint32_t n = 0;
	out[0] = p[0];
	out[1] = p[1];
	out[2] = p[2];
	for (; d != BC_NONE && n < BC_DOMAIN_MAX_CHAIN; d = l->unary_dom[d]) {
		chain[n++] = d;
	}
	/* Outermost first. */
	while (n-- > 0) {
		uint32_t u = chain[n];
		bc_domain_apply(l->unary_kind[u],
		                l->param + 4u * (size_t)l->unary_param[u], out);
	}
}

float bc_unary_apply(uint32_t kind, const float *rec, float f, const float q[3])
{
	switch (kind) {
	case BC_OP_OFFSET:
		return f - rec[0];
	case BC_OP_ONION:
		return fabsf(f) - rec[0];
	case BC_OP_SCALE:
		return f * rec[0];
	case BC_OP_TWIST:
	case BC_OP_BEND: {
		/* Beyond the radius R of its child's ABVs the value is scaled
		 * by L(R) / L(r) (continuous at R): the map's own bound grows
		 * with the distance r from the axis, so a step of value / L
		 * stays safe out there; the value stays above the ROI bound
		 * (docs/scene-format.md). */
		float r = kind == BC_OP_TWIST
		              ? sqrtf(q[0] * q[0] + q[2] * q[2])
		              : sqrtf(q[0] * q[0] + q[1] * q[1]);
		if (r > rec[1] && f > 0.0f) {
			return f * bc_unary_own_lip(kind, rec[0], rec[1]) /
			       bc_unary_own_lip(kind, rec[0], r);
		}
		return f;
	}
	default:
		return f;
	}
}

float bc_unary_value(const struct bc_lin *l, uint32_t u, float f,
                     const float p[3])
{
	uint32_t kind = l->unary_kind[u];
	float q[3] = {0.0f, 0.0f, 0.0f};
	if (bc_unary_reads_point(kind)) {
		bc_domain_map(l, l->unary_dom[u], p, q);
	}
	return bc_unary_apply(kind, l->param + 4u * (size_t)l->unary_param[u],
	                      f, q);
}

/* The point mapped through the domain chain from d last (d the innermost
 * domain node; BC_NONE: none yet). The leaves under one innermost domain
 * node share its chain and come in a row, so an evaluation maps the point
 * once per such run of leaves rather than once per primitive (a nested
 * domain node in between starts another run). */
struct dom_cache {
	uint32_t d;
	float q[3];
};

/* Field of the leaf at slot s: its point mapped through the domain nodes
 * around it (through c), then its own record. */
static inline float eval_leaf(const struct bc_lin *l, uint32_t s, uint32_t kind,
                              const float *rec, const float p[3],
                              struct dom_cache *c)
{
	if (l->nunary && l->dom[s] != BC_NONE) {
		if (c->d != l->dom[s]) {
			c->d = l->dom[s];
			bc_domain_map(l, c->d, p, c->q);
		}
		return eval_record(kind, rec, c->q);
	}
	return eval_record(kind, rec, p);
}

/* Slot s's value through its wrappers, innermost first. */
static inline float wrap_value(const struct bc_lin *l, uint32_t s, float f,
                               const float p[3])
{
	if (!l->nunary) {
		return f;
	}
	for (uint32_t u = l->wrap[s]; u != BC_NONE; u = l->unary_outer[u]) {
		f = bc_unary_value(l, u, f, p);
	}
	return f;
}

float bc_eval_prim(const struct bc_lin *l, uint32_t k, const float p[3])
{
	uint32_t s = l->prim_slot[k];
	struct dom_cache c = {BC_NONE, {0.0f, 0.0f, 0.0f}};
	return eval_leaf(l, s, bc_lin_kind(l, s), bc_lin_param(l, s), p, &c);
}

/* Which operand an operator's value follows, for colours and ids: the one
 * with the smaller value for unions, the larger for intersections, and for
 * differences the left unless the negated right one wins. */
static inline bool follows_right(enum bc_op op, float f0, float f1)
{
	switch (bc_op_class(op)) {
	case BC_OPCLASS_UNION:
		return f1 < f0;
	case BC_OPCLASS_INTERSECTION:
		return f1 > f0;
	case BC_OPCLASS_DIFFERENCE:
	default:
		return -f1 > f0;
	}
}

static float full(const struct bc_lin *l, const float p[3], uint32_t *prim)
{
	float val[BC_EVAL_STACK];
	uint32_t who[BC_EVAL_STACK];
	uint32_t sp = 0;
	struct dom_cache c = {BC_NONE, {0.0f, 0.0f, 0.0f}};
	for (uint32_t s = 0; s < l->count; s++) {
		uint32_t kind = bc_lin_kind(l, s);
		const float *rec = bc_lin_param(l, s);
		if (bc_lin_is_leaf(l, s)) {
			val[sp] = eval_leaf(l, s, kind, rec, p, &c);
			who[sp++] = bc_lin_leaf_prim(l, s);
		} else {
			float f1 = val[--sp];
			float f0 = val[sp - 1];
			val[sp - 1] = bc_op_eval((enum bc_op)kind, rec[0],
			                         rec[1], f0, f1);
			if (prim && follows_right((enum bc_op)kind, f0, f1)) {
				who[sp - 1] = who[sp];
			}
		}
		val[sp - 1] = wrap_value(l, s, val[sp - 1], p);
	}
	if (prim) {
		*prim = sp ? who[0] : BC_NONE;
	}
	return sp ? val[0] : INFINITY;
}

float bc_eval_full(const struct bc_lin *l, const float p[3])
{
	return full(l, p, NULL);
}

float bc_eval_full_id(const struct bc_lin *l, const float p[3], uint32_t *prim)
{
	return full(l, p, prim);
}

/* ---- views -------------------------------------------------------------- */

void bc_view_init(struct bc_view *v)
{
	memset(v, 0, sizeof(*v));
}

void bc_view_finish(struct bc_view *v)
{
	if (v) {
		bc_free(v->instr);
		memset(v, 0, sizeof(*v));
	}
}

static int reserve(struct bc_view *v, uint32_t n)
{
	struct bc_view_instr *grown;
	uint32_t cap = v->cap ? v->cap : 64;
	if (n <= v->cap) {
		return 0;
	}
	while (cap < n) {
		cap *= 2;
	}
	grown = bc_reallocarray(v->instr, cap, sizeof(*grown));
	if (!grown) {
		return BC_ENOMEM;
	}
	v->instr = grown;
	v->cap = cap;
	return 0;
}

struct entry {
	uint32_t slot;
	uint32_t start; /* first instruction of its code */
	bool missing;
};

static void emit(struct bc_view *v, const struct bc_lin *l, uint32_t s)
{
	struct bc_view_instr *in = &v->instr[v->n++];
	in->slot = s;
	in->param = l->node[2 * s + 1];
	in->kind = (uint16_t)bc_lin_kind(l, s);
	in->leaf = bc_lin_is_leaf(l, s) ? 1 : 0;
	in->pad = 0;
}

/* Emits the value-changing wrappers of slot s, innermost first. */
static void emit_wraps(struct bc_view *v, const struct bc_lin *l, uint32_t s)
{
	if (!l->nunary) {
		return;
	}
	for (uint32_t u = l->wrap[s]; u != BC_NONE; u = l->unary_outer[u]) {
		struct bc_view_instr *in;
		if (!bc_op_has_value((enum bc_op)l->unary_kind[u])) {
			continue;
		}
		in = &v->instr[v->n++];
		in->slot = u;
		in->param = l->unary_param[u];
		in->kind = (uint16_t)l->unary_kind[u];
		in->leaf = BC_VIEW_UNARY;
		in->pad = 0;
	}
}

/* Does slot a carry a value-changing wrapper (a climb must stop there)? */
static inline bool value_wrapped(const struct bc_lin *l, uint32_t x, uint32_t a)
{
	return l->nunary && l->ucount[x] != l->ucount[a];
}

/* Can the entry climb to ancestor a? a must be complete (before the next
 * active slot q) and hold nothing of the entry below (first >= lo). */
static inline bool may_climb(const struct bc_lin *l, uint32_t a, uint32_t q,
                             uint32_t lo)
{
	return a < q && bc_lin_first(l, a) >= lo;
}

/* Combines the two top entries as the operands of slot a (both complete). */
static void combine(struct bc_view *v, const struct bc_lin *l,
                    struct entry *left, const struct entry *right, uint32_t a)
{
	enum bc_op_class cls = bc_op_class((enum bc_op)bc_lin_kind(l, a));
	bool missing;
	if (!left->missing && !right->missing) {
		emit(v, l, a);
		missing = false;
	} else if (left->missing && right->missing) {
		missing = true;
	} else if (left->missing) {
		/* Only the right operand: unions pass it on. */
		missing = cls != BC_OPCLASS_UNION;
	} else {
		/* Only the left operand: intersections lose it. */
		missing = cls == BC_OPCLASS_INTERSECTION;
	}
	if (missing) {
		v->n = left->start;
	} else {
		emit_wraps(v, l, a);
	}
	left->slot = a;
	left->missing = missing;
}

/* The entry has climbed to slot x: it becomes missing when an edge on the
 * way kills its operand. */
static void settle(struct bc_view *v, const struct bc_lin *l, struct entry *top,
                   uint32_t x)
{
	if (x != top->slot &&
	    bc_lin_kills(l, top->slot) != bc_lin_kills(l, x) && !top->missing) {
		top->missing = true;
		v->n = top->start;
	}
	top->slot = x;
}

int bc_view_build(struct bc_view *v, const struct bc_lin *l,
                  const uint32_t *active, uint32_t n)
{
	struct entry st[BC_EVAL_STACK];
	uint32_t sp = 0, depth = 0;
	int rc;
	bool empty;
	v->n = 0;
	v->stack = 0;
	v->empty = true;
	if (!l || n == 0) {
		return 0;
	}
	/* At most 2n - 1 instructions: n leaves and n - 1 operators, and the
	 * unary nodes' instructions (each at most once). */
	if ((rc = reserve(v, 2 * n + l->nunary))) {
		return rc;
	}
	for (uint32_t i = 0; i < n; i++) {
		uint32_t k = active[i];
		uint32_t q;
		if (k >= l->nprims || (i > 0 && k <= active[i - 1])) {
			v->n = 0;
			return BC_EINVAL;
		}
		q = (i + 1 < n) ? l->prim_slot[active[i + 1]] : UINT32_MAX;
		if (i + 1 < n && active[i + 1] >= l->nprims) {
			v->n = 0;
			return BC_EINVAL;
		}
		if (sp >= BC_EVAL_STACK) {
			/* Unreachable for trees within the depth limit. */
			v->n = 0;
			return BC_EDEPTH;
		}
		st[sp].slot = l->prim_slot[k];
		st[sp].start = v->n;
		st[sp].missing = false;
		sp++;
		emit(v, l, l->prim_slot[k]);
		emit_wraps(v, l, l->prim_slot[k]);
		for (;;) {
			struct entry *top = &st[sp - 1];
			uint32_t lo = sp >= 2 ? st[sp - 2].slot + 1 : 0;
			uint32_t x = top->slot, a;
			/* The climb ends at the highest ancestor below q
			 * that holds nothing of the entry below. When that is
			 * q - 1, take it at once: in post-order, q - 1 is an
			 * ancestor of x exactly when its subtree starts at or
			 * before x, and no ancestor below q is higher. In an
			 * n-ary operator's comb (the usual big scene) this is
			 * every climb between two active operands, which the
			 * pointers below took in two dozen steps at a
			 * million primitives, each a cache miss. */
			if (q != UINT32_MAX && q - 1 > x) {
				uint32_t c = q - 1, fc = bc_lin_first(l, c);
				if (fc <= x && fc >= lo &&
				    !value_wrapped(l, x, c)) {
					x = c;
				}
			}
			/* Climb through ancestors that hold no other operand:
			 * the fast index first (whole same-side runs), then
			 * the jump pointer, then the parent. No shortcut
			 * passes a slot with a value-changing wrapper: the
			 * climb stops there to emit it. */
			for (;;) {
				uint32_t j = l->fast[x];
				if (j != BC_NONE && may_climb(l, j, q, lo) &&
				    !value_wrapped(l, x, j)) {
					x = j;
					continue;
				}
				j = l->jump[x];
				if (j != BC_NONE && may_climb(l, j, q, lo) &&
				    !value_wrapped(l, x, j)) {
					x = j;
					continue;
				}
				a = bc_lin_parent(l, x);
				if (a != BC_NONE && may_climb(l, a, q, lo)) {
					bool wrapped = value_wrapped(l, x, a);
					x = a;
					if (wrapped) {
						settle(v, l, top, x);
						if (!top->missing) {
							emit_wraps(v, l, x);
						}
					}
					continue;
				}
				break;
			}
			settle(v, l, top, x);
			a = bc_lin_parent(l, x);
			if (a == BC_NONE || a >= q) {
				break;
			}
			/* The parent holds the entry below: both operands. */
			combine(v, l, &st[sp - 2], top, a);
			sp--;
		}
	}
	empty = sp == 0 || st[0].missing;
	v->empty = empty;
	if (empty) {
		v->n = 0;
	}
	/* The evaluation stack the program needs. */
	for (uint32_t i = 0; i < v->n; i++) {
		if (v->instr[i].leaf == BC_VIEW_UNARY) {
			continue;
		}
		depth = v->instr[i].leaf ? depth + 1 : depth - 1;
		if (depth > v->stack) {
			v->stack = depth;
		}
	}
	return 0;
}

static float run(const struct bc_view *v, const struct bc_lin *l,
                 const float p[3], uint32_t *prim)
{
	float val[BC_EVAL_STACK];
	uint32_t who[BC_EVAL_STACK];
	uint32_t sp = 0;
	struct dom_cache c = {BC_NONE, {0.0f, 0.0f, 0.0f}};
	if (v->empty || v->n == 0) {
		if (prim) {
			*prim = BC_NONE;
		}
		return INFINITY;
	}
	for (uint32_t i = 0; i < v->n; i++) {
		const struct bc_view_instr *in = &v->instr[i];
		const float *rec = l->param + 4u * (size_t)in->param;
		if (in->leaf == BC_VIEW_UNARY) {
			val[sp - 1] =
			    bc_unary_value(l, in->slot, val[sp - 1], p);
		} else if (in->leaf) {
			val[sp] = eval_leaf(l, in->slot, in->kind, rec, p, &c);
			who[sp++] = bc_lin_leaf_prim(l, in->slot);
		} else {
			float f1 = val[--sp];
			float f0 = val[sp - 1];
			val[sp - 1] = bc_op_eval((enum bc_op)in->kind, rec[0],
			                         rec[1], f0, f1);
			if (prim &&
			    follows_right((enum bc_op)in->kind, f0, f1)) {
				who[sp - 1] = who[sp];
			}
		}
	}
	if (prim) {
		*prim = who[0];
	}
	return val[0];
}

float bc_view_eval(const struct bc_view *v, const struct bc_lin *l,
                   const float p[3])
{
	return run(v, l, p, NULL);
}

float bc_view_eval_id(const struct bc_view *v, const struct bc_lin *l,
                      const float p[3], uint32_t *prim)
{
	return run(v, l, p, prim);
}

float bc_eval_sparse(const struct bc_lin *l, const uint32_t *active, uint32_t n,
                     struct bc_view *scratch, const float p[3])
{
	if (bc_view_build(scratch, l, active, n)) {
		return NAN;
	}
	return bc_view_eval(scratch, l, p);
}
