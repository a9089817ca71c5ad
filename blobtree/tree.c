/*
 * The editable blobtree model: a pool of n-ary nodes with stable ids, the
 * pre-order builder, read access, and edits.
 *
 * Structural edits keep a strict order so that a failure changes nothing:
 * first everything that can fail (validation, the new linearized arrays,
 * pool and id-map room) is done or reserved, then the model is changed and
 * the new layout filled, which cannot fail.
 */
#include "tree_impl.h"

#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/scene.h"

/* ---- id map ------------------------------------------------------------- */

static uint32_t hash_id(uint32_t id)
{
	/* A 32-bit finalizer (murmur3's) spreads sequential ids. */
	id ^= id >> 16;
	id *= 0x85ebca6bu;
	id ^= id >> 13;
	id *= 0xc2b2ae35u;
	id ^= id >> 16;
	return id;
}

uint32_t bc__map_find(const struct bc__idmap *m, uint32_t id)
{
	if (!m->count || id == 0) {
		return BC_NONE;
	}
	for (uint32_t i = hash_id(id) & (m->cap - 1);;
	     i = (i + 1) & (m->cap - 1)) {
		if (m->keys[i] == id) {
			return m->vals[i];
		}
		if (m->keys[i] == 0) {
			return BC_NONE;
		}
	}
}

void bc__map_put_nogrow(struct bc__idmap *m, uint32_t id, uint32_t val)
{
	uint32_t i = hash_id(id) & (m->cap - 1);
	while (m->keys[i] != 0 && m->keys[i] != id) {
		i = (i + 1) & (m->cap - 1);
	}
	if (m->keys[i] == 0) {
		m->count++;
	}
	m->keys[i] = id;
	m->vals[i] = val;
}

/* Makes room for `more` insertions at load <= 1/2. */
int bc__map_reserve(struct bc__idmap *m, uint32_t more)
{
	uint64_t need = ((uint64_t)m->count + more) * 2u;
	uint32_t cap = m->cap ? m->cap : 16;
	struct bc__idmap bigger;
	if (need <= m->cap) {
		return 0;
	}
	while (cap < need) {
		if (cap >= (1u << 30)) {
			return BC_ELIMIT;
		}
		cap *= 2;
	}
	bigger.cap = cap;
	bigger.count = 0;
	bigger.keys = bc_calloc(cap, sizeof(uint32_t));
	bigger.vals = bc_calloc(cap, sizeof(uint32_t));
	if (!bigger.keys || !bigger.vals) {
		bc_free(bigger.keys);
		bc_free(bigger.vals);
		return BC_ENOMEM;
	}
	for (uint32_t i = 0; i < m->cap; i++) {
		if (m->keys[i]) {
			bc__map_put_nogrow(&bigger, m->keys[i], m->vals[i]);
		}
	}
	bc_free(m->keys);
	bc_free(m->vals);
	*m = bigger;
	return 0;
}

/* Linear-probing deletion with backward shift: no tombstones. */
void bc__map_del(struct bc__idmap *m, uint32_t id)
{
	uint32_t mask = m->cap - 1, i, j;
	if (!m->cap || id == 0) {
		return;
	}
	for (i = hash_id(id) & mask; m->keys[i] != id; i = (i + 1) & mask) {
		if (m->keys[i] == 0) {
			return;
		}
	}
	m->count--;
	for (j = (i + 1) & mask; m->keys[j] != 0; j = (j + 1) & mask) {
		uint32_t home = hash_id(m->keys[j]) & mask;
		/* Move j back to i unless its home lies cyclically in (i, j].
		 */
		bool stays = (i <= j) ? (i < home && home <= j)
		                      : (i < home || home <= j);
		if (!stays) {
			m->keys[i] = m->keys[j];
			m->vals[i] = m->vals[j];
			i = j;
		}
	}
	m->keys[i] = 0;
}

/* ---- pool --------------------------------------------------------------- */

/* The room an array of `have` entries grows to for `need` (doubling, from
 * 64): *cap, 0 when it holds them already; BC_ELIMIT past what a tree
 * can hold. */
static int grown_cap(uint32_t have, uint64_t need, uint32_t *cap)
{
	*cap = 0;
	if (need <= have) {
		return 0;
	}
	if (need > 2u * (uint64_t)BC_TREE_MAX_NODES) {
		return BC_ELIMIT;
	}
	*cap = have ? have : 64;
	while (*cap < need) {
		*cap *= 2;
	}
	return 0;
}

/* Room for a chunk of the xpar store (struct bc_tree) for each of the
 * pool's cap nodes: any of them may come to need one (a primitive of two
 * or more parameters, or rotated, or a unary node), and each takes one at
 * most, so that a chunk is there whenever a node asks (xpar_take). Room
 * nobody writes costs address space only. */
static int xpar_reserve(struct bc_tree *t, uint32_t cap)
{
	float *grown;
	if (cap <= t->xpar_cap) {
		return 0;
	}
	grown =
	    bc_reallocarray(t->xpar, cap, BC__XPAR_FLOATS * sizeof(*t->xpar));
	if (!grown) {
		return BC_ENOMEM;
	}
	t->xpar = grown;
	t->xpar_cap = cap;
	return 0;
}

static float *xpar_at(const struct bc_tree *t, uint32_t x)
{
	return &t->xpar[(size_t)x * BC__XPAR_FLOATS];
}

/* A chunk, from the free chain or the store's end (room reserved). */
static uint32_t xpar_take(struct bc_tree *t)
{
	uint32_t x;
	if (t->xpar_free != BC_NONE) {
		x = t->xpar_free;
		memcpy(&t->xpar_free, xpar_at(t, x), sizeof(t->xpar_free));
	} else {
		x = t->nxpar++;
	}
	return x;
}

const float *bc__uparam(const struct bc_tree *t, const struct bc__node *n)
{
	return xpar_at(t, n->xpar);
}

static int pool_reserve(struct bc_tree *t, uint32_t more)
{
	uint32_t free_count = 0, cap;
	struct bc__node *grown;
	int rc;
	for (uint32_t f = t->free_head; f != BC_NONE && free_count < more;
	     f = t->pool[f].next) {
		free_count++;
	}
	if ((rc = grown_cap(t->cap, (uint64_t)t->npool + (more - free_count),
	                    &cap)) ||
	    cap == 0 || (rc = xpar_reserve(t, cap))) {
		return rc;
	}
	if (!t->bare) {
		struct bc__lay *lay =
		    bc_reallocarray(t->lay, cap, sizeof(*t->lay));
		if (!lay) {
			return BC_ENOMEM;
		}
		t->lay = lay;
	}
	grown = bc_reallocarray(t->pool, cap, sizeof(*grown));
	if (!grown) {
		return BC_ENOMEM; /* lay larger than cap: harmless */
	}
	t->pool = grown;
	t->cap = cap;
	return 0;
}

int bc__tree_reserve(struct bc_tree *t, uint32_t nodes)
{
	int rc;
	if ((rc = pool_reserve(t, nodes))) {
		return rc;
	}
	/* Written whole by the build that follows: no fault per page. The
	 * id map grows with the nodes it holds (add_node), which are none
	 * when the ids follow the pool (bc__id_find). */
	bc_populate(t->pool + t->npool, (size_t)nodes * sizeof(*t->pool));
	if (t->lay) {
		bc_populate(t->lay + t->npool, (size_t)nodes * sizeof(*t->lay));
	}
	return 0;
}

/* Takes a node from the free chain or the end of the pool; room must have
 * been reserved. */
static uint32_t pool_take(struct bc_tree *t)
{
	uint32_t n;
	if (t->free_head != BC_NONE) {
		n = t->free_head;
		t->free_head = t->pool[n].next;
	} else {
		n = t->npool++;
	}
	memset(&t->pool[n], 0, sizeof(t->pool[n]));
	t->pool[n].parent = BC_NONE;
	t->pool[n].u.first_child = BC_NONE;
	t->pool[n].u.last_child = BC_NONE;
	t->pool[n].next = BC_NONE;
	t->pool[n].prev = BC_NONE;
	t->pool[n].live = true;
	t->pool[n].xpar = BC_NONE; /* no chunk until asked for */
	if (t->lay) {
		/* No splice to follow: its place is written before read. */
		memset(&t->lay[n], 0, sizeof(t->lay[n]));
		bc__lay_mark(t, &t->lay[n]);
	}
	return n;
}

static void kids_drop(struct bc_tree *t, uint32_t op, bool children);

static void pool_release(struct bc_tree *t, uint32_t n)
{
	if (t->pool[n].kids & BC__KIDS_OP) {
		/* Its children are gone, or going. */
		kids_drop(t, n, false);
	}
	if (t->pool[n].xpar != BC_NONE) {
		uint32_t x = t->pool[n].xpar;
		memcpy(xpar_at(t, x), &t->xpar_free, sizeof(x));
		t->xpar_free = x;
		t->pool[n].xpar = BC_NONE;
	}
	t->pool[n].live = false;
	t->pool[n].next = t->free_head;
	t->free_head = n;
}

static const float identity_rotation[4] = {0.0f, 0.0f, 0.0f, 1.0f};

/* Writes p into primitive node n: fresh, a node just taken; otherwise a
 * node of p's kind already. It takes a chunk of the xpar store (room
 * reserved with the pool) when p's kind has two or more parameters or p
 * a rotation other than the identity (bit for bit) and it has none, and
 * keeps one it has. */
static void prim_write(struct bc_tree *t, struct bc__node *n,
                       const struct bc_prim_data *p, bool fresh)
{
	struct bc__prim_room *r = &n->u.prim;
	bool chunk = bc_scene_prim_nfloats(p->kind) > 1 ||
	             memcmp(p->rotate, identity_rotation, sizeof(p->rotate));
	if (fresh) {
		n->xpar = BC_NONE;
	}
	if (chunk && n->xpar == BC_NONE) {
		n->xpar = xpar_take(t);
	}
	n->pkind = (uint8_t)p->kind;
	n->has_color = p->has_color;
	r->p0 = p->params[0];
	if (n->xpar != BC_NONE) {
		float *x = xpar_at(t, n->xpar);
		memcpy(x, &p->params[1], BC__XPAR_PARAMS * sizeof(float));
		memcpy(x + BC__XPAR_PARAMS, p->rotate, sizeof(p->rotate));
	}
	memcpy(r->translate, p->translate, sizeof(r->translate));
	memcpy(r->color, p->color, sizeof(r->color));
}

void bc__prim_read(const struct bc_tree *t, const struct bc__node *n,
                   struct bc_prim_data *out)
{
	const struct bc__prim_room *r = &n->u.prim;
	memset(out, 0, sizeof(*out));
	out->kind = (enum bc_prim)n->pkind;
	out->has_color = n->has_color;
	out->params[0] = r->p0;
	if (n->xpar != BC_NONE) {
		const float *x = xpar_at(t, n->xpar);
		memcpy(&out->params[1], x, BC__XPAR_PARAMS * sizeof(float));
		memcpy(out->rotate, x + BC__XPAR_PARAMS, sizeof(out->rotate));
	} else {
		memcpy(out->rotate, identity_rotation, sizeof(out->rotate));
	}
	memcpy(out->translate, r->translate, sizeof(r->translate));
	memcpy(out->color, r->color, sizeof(r->color));
}

/* Returns an id not in use (ids wrap around past 2^32-1, skipping 0). */
static uint32_t fresh_id(struct bc_tree *t)
{
	while (t->next_id == 0 || bc__id_find(t, t->next_id) != BC_NONE) {
		t->next_id++;
	}
	return t->next_id++;
}

/* Adds (sign 1) or takes away (-1) primitive p from the counts the scene
 * encoding follows (bc_tree_counts). */
static void count_prim(struct bc_tree *t, enum bc_prim kind, bool has_color,
                       int sign)
{
	uint32_t floats = bc_scene_prim_nfloats(kind);
	uint32_t sphere = kind == BC_PRIM_SPHERE ? 1u : 0u;
	if (sign > 0) {
		t->ncolored += has_color ? 1u : 0u;
		t->nfloats += floats;
		t->nspheres += sphere;
	} else {
		t->ncolored -= has_color ? 1u : 0u;
		t->nfloats -= floats;
		t->nspheres -= sphere;
	}
}

/* ---- create/destroy ----------------------------------------------------- */

static void tree_clear(struct bc_tree *t)
{
	bool bare = t->bare, nameless = t->nameless;
	bc_free(t->open);
	bc_free(t->pool);
	bc_free(t->lay);
	bc_free(t->xpar);
	bc_free(t->ids.keys);
	bc_free(t->ids.vals);
	for (uint32_t i = 0; i < t->nkids; i++) {
		bc_free(t->kids[i].at);
	}
	bc_free(t->kids);
	bc__lin_free(&t->lin);
	bc__names_free(&t->names);
	memset(t, 0, sizeof(*t));
	t->root = BC_NONE;
	t->free_head = BC_NONE;
	t->xpar_free = BC_NONE;
	t->next_id = 1;
	t->bare = bare;
	t->nameless = nameless;
}

struct bc_tree *bc_tree_create(void)
{
	struct bc_tree *t = bc_calloc(1, sizeof(*t));
	if (t) {
		t->root = BC_NONE;
		t->free_head = BC_NONE;
		t->xpar_free = BC_NONE;
		t->next_id = 1;
	}
	return t;
}

int bc_tree_set_layout(struct bc_tree *t, bool on)
{
	if (t->root != BC_NONE || t->building) {
		return BC_ESTATE;
	}
	t->bare = !on;
	return 0;
}

bool bc_tree_lays_out(const struct bc_tree *t)
{
	return !t->bare;
}

int bc_tree_set_names(struct bc_tree *t, bool keep)
{
	if (t->root != BC_NONE || t->building) {
		return BC_ESTATE;
	}
	t->nameless = !keep;
	return 0;
}

void bc_tree_destroy(struct bc_tree *t)
{
	if (!t) {
		return;
	}
	tree_clear(t);
	bc_free(t);
}

/* ---- positions among a wide operator's children (bare trees) ----------- */

static struct bc__kids *kids_of(const struct bc_tree *t, uint32_t op)
{
	if (!(t->pool[op].kids & BC__KIDS_OP)) {
		return NULL;
	}
	for (uint32_t i = 0; i < t->nkids; i++) {
		if (t->kids[i].op == op) {
			return &t->kids[i];
		}
	}
	return NULL;
}

/* Forgets op's index; its anchors' marks too when its children stay. */
static void kids_drop(struct bc_tree *t, uint32_t op, bool children)
{
	struct bc__kids *k = kids_of(t, op);
	if (!k) {
		return;
	}
	for (uint32_t i = 0; children && i < k->n; i++) {
		t->pool[k->at[i]].kids &= (uint8_t)~BC__KIDS_AT;
	}
	t->pool[op].kids &= (uint8_t)~BC__KIDS_OP;
	bc_free(k->at);
	*k = t->kids[--t->nkids];
}

/* Indexes operator op of a bare tree when it is wide (and not yet). Out
 * of memory it stays without: its children are then walked. */
static void kids_build(struct bc_tree *t, uint32_t op)
{
	uint32_t n = t->pool[op].u.nchildren, pos = 0, i = 0;
	struct bc__kids *k;
	uint32_t *at;
	if (!t->bare || n < BC__KIDS_MIN || (t->pool[op].kids & BC__KIDS_OP)) {
		return;
	}
	if (t->nkids == t->kids_cap) {
		uint32_t cap = t->kids_cap ? 2u * t->kids_cap : 4u;
		struct bc__kids *fresh =
		    bc_realloc(t->kids, (size_t)cap * sizeof(*fresh));
		if (!fresh) {
			return;
		}
		t->kids = fresh;
		t->kids_cap = cap;
	}
	k = &t->kids[t->nkids];
	k->cap = n / BC__KIDS_STEP + 16u;
	if (!(at = bc_malloc((size_t)k->cap * sizeof(*at)))) {
		return;
	}
	for (uint32_t c = t->pool[op].u.first_child; c != BC_NONE;
	     c = t->pool[c].next, pos++) {
		if (pos % BC__KIDS_STEP == 0) {
			at[i++] = c;
			t->pool[c].kids |= BC__KIDS_AT;
		}
	}
	k->op = op;
	k->n = i;
	k->at = at;
	t->nkids++;
	t->pool[op].kids |= BC__KIDS_OP;
}

/* Position of child c of the operator k indexes: counted back to the
 * anchor at or before it (the first child is anchor 0). */
static uint32_t kids_pos(const struct bc_tree *t, const struct bc__kids *k,
                         uint32_t c)
{
	uint32_t steps = 0, i = 0;
	while (!(t->pool[c].kids & BC__KIDS_AT) && t->pool[c].prev != BC_NONE) {
		c = t->pool[c].prev;
		steps++;
	}
	while (i < k->n && k->at[i] != c) {
		i++;
	}
	/* The first child is anchor 0, so i < k->n always; the bound keeps
	 * a broken index from reading past its anchors. */
	return i < k->n ? i * BC__KIDS_STEP + steps : steps;
}

/* Anchor i of k becomes node now. */
static void kids_move(struct bc_tree *t, struct bc__kids *k, uint32_t i,
                      uint32_t now)
{
	t->pool[k->at[i]].kids &= (uint8_t)~BC__KIDS_AT;
	t->pool[now].kids |= BC__KIDS_AT;
	k->at[i] = now;
}

/* A child was linked at position pos of the operator k indexes: every
 * anchor from pos on is now the child before it (the new child for the
 * anchor at pos), and a new last position of a multiple of the step
 * takes an anchor. */
static void kids_linked(struct bc_tree *t, struct bc__kids *k, uint32_t pos)
{
	const struct bc__node *p = &t->pool[k->op];
	for (uint32_t i = (pos + BC__KIDS_STEP - 1u) / BC__KIDS_STEP; i < k->n;
	     i++) {
		kids_move(t, k, i, t->pool[k->at[i]].prev);
	}
	if ((p->u.nchildren - 1u) / BC__KIDS_STEP + 1u > k->n) {
		if (k->n == k->cap) {
			uint32_t cap = 2u * k->cap;
			uint32_t *fresh =
			    bc_realloc(k->at, (size_t)cap * sizeof(*fresh));
			if (!fresh) {
				kids_drop(t, k->op, true);
				return;
			}
			k->at = fresh;
			k->cap = cap;
		}
		k->at[k->n++] = p->u.last_child;
		t->pool[p->u.last_child].kids |= BC__KIDS_AT;
	}
}

/* Child c of the operator k indexes is about to be unlinked: every
 * anchor from its position on becomes the child after it; one past the
 * new end goes. */
static void kids_unlinking(struct bc_tree *t, struct bc__kids *k, uint32_t c)
{
	uint32_t pos = kids_pos(t, k, c);
	for (uint32_t i = (pos + BC__KIDS_STEP - 1u) / BC__KIDS_STEP; i < k->n;
	     i++) {
		uint32_t next = t->pool[k->at[i]].next;
		if (next == BC_NONE) {
			t->pool[k->at[i]].kids &= (uint8_t)~BC__KIDS_AT;
			k->n = i;
			break;
		}
		kids_move(t, k, i, next);
	}
}

/* ---- model helpers ------------------------------------------------------ */

static void link_child(struct bc_tree *t, uint32_t parent, uint32_t before,
                       uint32_t child)
{
	struct bc__node *p = &t->pool[parent], *c = &t->pool[child];
	struct bc__kids *k = kids_of(t, parent);
	uint32_t pos = 0;
	if (k) {
		pos =
		    before == BC_NONE ? p->u.nchildren : kids_pos(t, k, before);
	}
	c->parent = parent;
	c->next = before;
	if (before == BC_NONE) {
		c->prev = p->u.last_child;
		if (p->u.last_child != BC_NONE) {
			t->pool[p->u.last_child].next = child;
		} else {
			p->u.first_child = child;
		}
		p->u.last_child = child;
	} else {
		c->prev = t->pool[before].prev;
		if (c->prev != BC_NONE) {
			t->pool[c->prev].next = child;
		} else {
			p->u.first_child = child;
		}
		t->pool[before].prev = child;
	}
	p->u.nchildren++;
	if (k) {
		kids_linked(t, k, pos);
	}
}

static void unlink_child(struct bc_tree *t, uint32_t child)
{
	struct bc__node *c = &t->pool[child];
	struct bc__node *p = &t->pool[c->parent];
	struct bc__kids *k = kids_of(t, c->parent);
	if (k) {
		kids_unlinking(t, k, child);
	}
	if (c->prev != BC_NONE) {
		t->pool[c->prev].next = c->next;
	} else {
		p->u.first_child = c->next;
	}
	if (c->next != BC_NONE) {
		t->pool[c->next].prev = c->prev;
	} else {
		p->u.last_child = c->prev;
	}
	p->u.nchildren--;
	if (k && p->u.nchildren < BC__KIDS_MIN / 2u) {
		kids_drop(t, c->parent, true);
	}
	c->parent = BC_NONE;
	c->next = BC_NONE;
	c->prev = BC_NONE;
}

/* Child number pos (pos < n) of parent, an operator of n >= 2 children
 * whose layout is current, found in the layout: down the fold's chain of
 * left operands from its top slot (bc__lin_update_op's walk), then the
 * node of the child's top slot (a unary wrapper's child's, climbed). A
 * step reads one entry of `first`, two slots below the last for leaf
 * children: a walk over 350 000 operands in the model's nodes (a cache
 * line each) took about 5 ms, and every INSERT in the middle of a wide
 * operator paid it (a bare tree has no layout: its wide operators keep
 * anchors instead, struct bc__kids). */
static uint32_t child_at_lin(const struct bc_tree *t, uint32_t parent,
                             uint32_t pos)
{
	const struct bc_lin *l = &t->lin;
	uint32_t n = t->pool[parent].u.nchildren;
	uint32_t f = bc__slot(t, &t->pool[parent]), top, c;
	for (uint32_t i = n - 1; i > (pos ? pos : 1u); i--) {
		f = bc_lin_first(l, f - 1) - 1;
	}
	/* f is the fold whose right operand is child pos (child 1 for pos
	 * 0, whose left operand child 0 is). */
	top = pos ? f - 1 : bc_lin_first(l, f - 1) - 1;
	c = bc__id_find(t, l->node_id[top]);
	while (c != BC_NONE && t->pool[c].parent != parent) {
		c = t->pool[c].parent;
	}
	return c;
}

/* Child number pos of parent, BC_NONE past the end: near the start
 * walked in the model, else in the layout from the end (appending to a
 * wide operator costs nothing). */
static uint32_t child_at(const struct bc_tree *t, uint32_t parent, uint32_t pos)
{
	uint32_t n = bc__nkids(&t->pool[parent]), c;
	const struct bc__kids *kids = kids_of(t, parent);
	if (pos >= n) {
		return BC_NONE;
	}
	if (kids) {
		/* A bare tree's wide operator: from the anchor before it. */
		c = kids->at[pos / BC__KIDS_STEP];
		for (uint32_t r = pos % BC__KIDS_STEP; r > 0; r--) {
			c = t->pool[c].next;
		}
		return c;
	}
	if (t->has_lin && !t->building && n >= 2) {
		if (pos >= n / 16) {
			return child_at_lin(t, parent, pos);
		}
	} else if (pos > n / 2) {
		c = t->pool[parent].u.last_child;
		for (uint32_t k = n - 1; k > pos; k--) {
			c = t->pool[c].prev;
		}
		return c;
	}
	c = t->pool[parent].u.first_child;
	while (c != BC_NONE && pos-- > 0) {
		c = t->pool[c].next;
	}
	return c;
}

/* Depth of node n (the root has depth 1). */
static uint32_t depth_of(const struct bc_tree *t, uint32_t n)
{
	uint32_t d = 0;
	for (; n != BC_NONE; n = t->pool[n].parent) {
		d++;
	}
	return d;
}

struct subtree_stats {
	uint32_t nodes, prims, ops, depth, spheres;
	uint32_t kill_ops; /* intersections and differences */
};

/*
 * The walks below visit a subtree without recursion or a stack: the model
 * links every node to its parent and next sibling, so "the next node in
 * pre-order" and "back up to the parent" are O(1) steps, and a tree
 * 2^20 levels deep costs no C stack.
 */

/* The node after n in pre-order within the subtree at top, BC_NONE at the
 * end; *depth follows the moves (down +1, up -k). */
static uint32_t preorder_next(const struct bc_tree *t, uint32_t n, uint32_t top,
                              uint32_t *depth)
{
	if (t->pool[n].is_op && t->pool[n].u.first_child != BC_NONE) {
		(*depth)++;
		return t->pool[n].u.first_child;
	}
	while (n != top) {
		if (t->pool[n].next != BC_NONE) {
			return t->pool[n].next;
		}
		n = t->pool[n].parent;
		(*depth)--;
	}
	return BC_NONE;
}

static void subtree_stats(const struct bc_tree *t, uint32_t top,
                          struct subtree_stats *st)
{
	uint32_t depth = 1;
	for (uint32_t n = top; n != BC_NONE;
	     n = preorder_next(t, n, top, &depth)) {
		st->nodes++;
		if (depth > st->depth) {
			st->depth = depth;
		}
		if (t->pool[n].is_op) {
			st->ops++;
			st->kill_ops +=
			    bc__op_kills(t->pool[n].u.op.kind) ? 1u : 0u;
		} else {
			st->prims++;
			st->spheres +=
			    t->pool[n].pkind == BC_PRIM_SPHERE ? 1u : 0u;
		}
	}
}

uint32_t bc__measure(struct bc_tree *t, uint32_t top)
{
	uint32_t n = top, depth = 1, most = 0;
	for (;;) {
		while (t->pool[n].is_op) {
			n = t->pool[n].u.first_child;
			depth++;
		}
		if (depth > most) {
			most = depth;
		}
		t->pool[n].need = 1;
		/* n is complete: finish every ancestor it completes. */
		for (;;) {
			uint32_t p;
			if (n == top) {
				return most;
			}
			if (t->pool[n].next != BC_NONE) {
				n = t->pool[n].next;
				break;
			}
			p = t->pool[n].parent;
			depth--;
			/* The fold ((c0 op c1) op c2)...: a right operand is
			 * evaluated above its left one. */
			{
				uint32_t c = t->pool[p].u.first_child;
				uint32_t need = t->pool[c].need;
				for (c = t->pool[c].next; c != BC_NONE;
				     c = t->pool[c].next) {
					if (t->pool[c].need + 1u > need) {
						need = t->pool[c].need + 1u;
					}
				}
				t->pool[p].need = bc__need(need);
			}
			n = p;
		}
	}
}

/* Frees the subtree at n (post-order, so each node's links are read before
 * it joins the free chain through .next). */
static void free_subtree(struct bc_tree *t, uint32_t top)
{
	uint32_t n = top;
	for (;;) {
		while (t->pool[n].is_op &&
		       t->pool[n].u.first_child != BC_NONE) {
			n = t->pool[n].u.first_child;
		}
		for (;;) {
			uint32_t next = t->pool[n].next, p = t->pool[n].parent;
			bool last = n == top;
			if (!last && p != BC_NONE) {
				/* Detach n so that its parent looks like a
				 * leaf once its last child is gone. */
				t->pool[p].u.first_child = next;
			}
			/* A replacement may already map this id to its
			 * own node. */
			if (bc__id_find(t, t->pool[n].id) == n) {
				bc__id_del(t, t->pool[n].id);
			}
			if (t->pool[n].is_op) {
				t->nops--;
				t->nunary_nodes -=
				    bc__node_unary(&t->pool[n]) ? 1u : 0u;
			} else {
				t->nprims--;
				count_prim(t, (enum bc_prim)t->pool[n].pkind,
				           t->pool[n].has_color, -1);
			}
			t->nnodes--;
			pool_release(t, n);
			if (last) {
				return;
			}
			if (next != BC_NONE) {
				n = next;
				break;
			}
			n = p;
		}
	}
}

/* Maps every id of the subtree at top to its node again (after a
 * replacement that shared some of them was undone; the map has room, since
 * it held them before). */
static void remap_ids(struct bc_tree *t, uint32_t top)
{
	uint32_t depth = 0;
	for (uint32_t n = top; n != BC_NONE;
	     n = preorder_next(t, n, top, &depth)) {
		bc__id_put(t, t->pool[n].id, n);
	}
}

static uint32_t is_domain_node(const struct bc__node *n)
{
	return bc__node_unary(n) && bc_op_is_domain(n->u.op.kind) ? 1u : 0u;
}

/* Most domain nodes on one path from the root to a primitive: a walk in
 * pre-order that counts the domain nodes above the node it is at, one up
 * going down into a domain node's child, one down climbing back into it
 * (nothing stored in the nodes). */
static uint32_t domain_chain(const struct bc_tree *t)
{
	uint32_t n = t->root, chain = 0, most = 0;
	for (;;) {
		const struct bc__node *nd = &t->pool[n];
		most = chain > most ? chain : most;
		if (nd->is_op && nd->u.first_child != BC_NONE) {
			chain += is_domain_node(nd);
			n = nd->u.first_child;
			continue;
		}
		while (n != t->root && t->pool[n].next == BC_NONE) {
			n = t->pool[n].parent;
			chain -= is_domain_node(&t->pool[n]);
		}
		if (n == t->root) {
			return most;
		}
		n = t->pool[n].next;
	}
}

static int need_error(const struct bc_tree *t, struct bc_errinfo *ei)
{
	uint32_t need = t->pool[t->root].need;
	return bc_errinfo_set(ei, BC_EDEPTH,
	                      "tree: evaluating it needs a stack of "
	                      "%u%s entries, more than %u (operators "
	                      "nested too deep in right operands; "
	                      "left-nested chains may be any depth)",
	                      need, need == BC__NEED_MAX ? " or more" : "",
	                      BC_EVAL_STACK);
}

/* Checks a tree's nesting and evaluation stack against the limits (the one
 * check shared by the builder and the grafting edits). */
static int check_shape(struct bc_tree *t, struct bc_errinfo *ei)
{
	uint32_t depth = bc__measure(t, t->root);
	if (domain_chain(t) > BC_DOMAIN_MAX_CHAIN) {
		return bc_errinfo_set(ei, BC_EDEPTH,
		                      "tree: more than %u domain nodes "
		                      "(elongate, twist, bend, mirror, repeat, "
		                      "scale) on one path",
		                      BC_DOMAIN_MAX_CHAIN);
	}
	if (depth > BC_TREE_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_EDEPTH,
		                      "tree: nesting deeper than %u levels",
		                      BC_TREE_MAX_DEPTH);
	}
	if (t->pool[t->root].need > BC_EVAL_STACK) {
		return need_error(t, ei);
	}
	return 0;
}

/* ---- keeping the measures along an edited path ------------------------- */

/* What child c adds to its parent's need: a right operand of the fold is
 * evaluated above the left one. */
static uint32_t need_in_parent(const struct bc_tree *t, uint32_t c)
{
	uint32_t p = t->pool[c].parent;
	return t->pool[c].need + (t->pool[p].u.first_child == c ? 0u : 1u);
}

/* Pool node m (measured) was linked: its ancestors' needs grow with what
 * it adds, and with what the old first child adds as the second. */
static void need_grow(struct bc_tree *t, uint32_t m)
{
	uint32_t c = m, p = t->pool[m].parent;
	while (p != BC_NONE) {
		uint32_t need = t->pool[p].need, v = need_in_parent(t, c);
		uint32_t next = t->pool[c].next;
		if (v > need) {
			need = v;
		}
		if (c == m && next != BC_NONE &&
		    t->pool[p].u.first_child == m &&
		    (v = need_in_parent(t, next)) > need) {
			need = v;
		}
		if (bc__need(need) == t->pool[p].need) {
			return;
		}
		t->pool[p].need = bc__need(need);
		c = p;
		p = t->pool[p].parent;
	}
}

/* A child of pool node a went (or moved up into it): a's need and its
 * ancestors' shrink to what their children need. A scan stops at the
 * first child that still needs the old value, so a wide operator costs
 * little. */
static void need_shrink(struct bc_tree *t, uint32_t a)
{
	while (a != BC_NONE) {
		uint32_t old = t->pool[a].need, need = 0;
		for (uint32_t c = t->pool[a].u.first_child;
		     c != BC_NONE && need < old; c = t->pool[c].next) {
			uint32_t v = need_in_parent(t, c);
			if (v > need) {
				need = v;
			}
		}
		if (bc__need(need) == old) {
			return;
		}
		t->pool[a].need = bc__need(need);
		a = t->pool[a].parent;
	}
}

/* Does some node sit at depth `target` or deeper (the root at 1)? Stops
 * at the first one found. */
static bool reaches(const struct bc_tree *t, uint32_t target)
{
	uint32_t depth = 1;
	for (uint32_t n = t->root; n != BC_NONE;
	     n = preorder_next(t, n, t->root, &depth)) {
		if (depth >= target) {
			return true;
		}
	}
	return false;
}

/* Can t (and the subtree sub grafted into it, when given) be edited by
 * splicing its layout (splice.c)? Not with unary nodes in either (the
 * splice reads sub's model, not its layout). A bare tree takes the same
 * path, measuring the model along the edited path only, and splices
 * nothing (the splice_* wrappers below). */
static bool splices(const struct bc_tree *t, const struct bc_tree *sub)
{
	return (t->bare || t->has_lin) && t->nunary_nodes == 0 &&
	       (!sub || sub->nunary_nodes == 0);
}

/* Does t's model hold an intersection or a difference? */
static bool model_kills(const struct bc_tree *t)
{
	for (uint32_t n = 0; n < t->npool; n++) {
		const struct bc__node *nd = &t->pool[n];
		if (nd->live && nd->is_op && bc__op_kills(nd->u.op.kind)) {
			return true;
		}
	}
	return false;
}

/* Layout arrays for nprims primitives (nspheres of them spheres) and nops
 * operators in *fresh, none for a bare tree (*fresh zeroed); kill counts
 * where t's model (nodes about to go included) or a subtree about to come
 * (sub_kills) has an intersection or a difference. Returns 0 or
 * BC_ENOMEM. */
static int lin_alloc(const struct bc_tree *t, struct bc_lin *fresh,
                     uint32_t nprims, uint32_t nspheres, uint32_t nops,
                     bool unary, bool sub_kills)
{
	if (t->bare) {
		memset(fresh, 0, sizeof(*fresh));
		return 0;
	}
	return bc__lin_alloc(fresh, nprims, nspheres, nops, unary,
	                     sub_kills || model_kills(t));
}

/* Vec4s of the records of sub's primitives and binary operators (a
 * splice sees no unary node). */
static uint32_t tree_recs(const struct bc_tree *sub)
{
	return (uint32_t)(bc__prim_recs(sub->nprims, sub->nspheres) +
	                  BC_OP_RECORD_VEC4 * (uint64_t)sub->nops);
}

/* The splices of splice.c, skipped by a bare tree (which has no layout to
 * splice; its edits only count). */
static bool splice_insert(struct bc_tree *t, uint32_t m, uint32_t px,
                          uint32_t rx)
{
	return t->bare ? false : bc__splice_insert(t, m, px, rx);
}
static bool splice_remove(struct bc_tree *t, uint32_t c)
{
	return t->bare ? false : bc__splice_remove(t, c);
}
static void splice_note(struct bc_tree *t, uint32_t c, struct bc__block *b)
{
	if (t->bare) {
		memset(b, 0, sizeof(*b));
	} else {
		bc__splice_note(t, c, b);
	}
}
static bool splice_replace(struct bc_tree *t, const struct bc__block *b,
                           uint32_t m, uint32_t px, uint32_t rx)
{
	return t->bare ? false : bc__splice_replace(t, b, m, px, rx);
}
static void splice_finish(struct bc_tree *t, bool touch)
{
	if (t->bare) {
		t->dirty.structure = true;
		t->dirty.edits++;
	} else {
		t->lin.nesting = t->nesting;
		bc__splice_finish(t, touch);
	}
}

/* Replaces t's layout with one built for the model's current counts. The
 * arrays must have been allocated (into fresh) before the model changed. */
static void install_lin(struct bc_tree *t, struct bc_lin *fresh)
{
	bc__lin_free(&t->lin);
	t->has_lin = false;
	t->lin_cap = t->lin_kcap = t->lin_pcap = 0;
	t->nesting = 0;
	if (t->root == BC_NONE) {
		bc__lin_free(fresh);
	} else if (t->bare) {
		t->nesting = bc__measure(t, t->root);
		for (uint32_t n = 0; n < t->npool; n++) {
			if (t->pool[n].live && t->pool[n].is_op) {
				kids_build(t, n);
			}
		}
	} else {
		t->lin = *fresh;
		t->has_lin = true;
		t->lin_cap = (uint32_t)bc__lin_room(fresh->count);
		t->lin_kcap = (uint32_t)bc__lin_room(fresh->nprims);
		t->lin_pcap = (uint32_t)bc__lin_room(fresh->nparam);
		bc__lin_fill(t, &t->lin);
		t->nesting = t->lin.nesting;
	}
	memset(fresh, 0, sizeof(*fresh));
	/* Laid out whole: no splices to follow. */
	t->dirty.structure = true;
	t->dirty.spliced = false;
	t->dirty.edits++;
}

/* ---- builder ------------------------------------------------------------ */

int bc_tree_begin(struct bc_tree *t)
{
	tree_clear(t);
	t->building = true;
	return 0;
}

/* Creates a node with id (0 = fresh) under the innermost open operator. */
static int add_node(struct bc_tree *t, uint32_t id, bool is_op,
                    struct bc_errinfo *ei, uint32_t *out)
{
	uint32_t n;
	int rc;
	if (!t->building) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "tree: bc_tree_begin() not called");
	}
	if (t->nopen == 0 && t->root != BC_NONE) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "tree: a scene has exactly one root");
	}
	if (t->nopen && bc__node_unary(&t->pool[t->open[t->nopen - 1]]) &&
	    t->pool[t->open[t->nopen - 1]].u.nchildren >= 1) {
		uint32_t u = t->open[t->nopen - 1];
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "tree: %s node %u takes exactly one "
		                      "child",
		                      bc_op_name(t->pool[u].u.op.kind),
		                      t->pool[u].id);
	}
	/* The new node would be number nopen + 1 on its path. */
	if (t->nopen + 1u > BC_TREE_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_EDEPTH,
		                      "tree: nesting deeper than %u levels",
		                      BC_TREE_MAX_DEPTH);
	}
	if (is_op && t->nopen == t->open_cap) {
		uint32_t cap = t->open_cap ? 2 * t->open_cap : 64;
		uint32_t *grown = bc_reallocarray(t->open, cap, sizeof(*grown));
		if (!grown) {
			return bc_errinfo_set(ei, BC_ENOMEM, "tree: %s",
			                      bc_strerror(BC_ENOMEM));
		}
		t->open = grown;
		t->open_cap = cap;
	}
	if (t->nnodes >= BC_TREE_MAX_NODES ||
	    (!is_op && 2u * t->nprims + 1u > BC_TREE_MAX_NODES)) {
		return bc_errinfo_set(ei, BC_ELIMIT, "tree: more than %u nodes",
		                      BC_TREE_MAX_NODES);
	}
	if (id != 0 && bc__id_find(t, id) != BC_NONE) {
		return bc_errinfo_set(ei, BC_EDUPID, "tree: duplicate id %u",
		                      id);
	}
	if ((rc = pool_reserve(t, 1)) || (rc = bc__map_reserve(&t->ids, 1))) {
		return bc_errinfo_set(ei, rc, "tree: %s", bc_strerror(rc));
	}
	n = pool_take(t);
	t->pool[n].auto_id = id == 0;
	t->pool[n].id = id ? id : fresh_id(t);
	t->pool[n].is_op = is_op;
	bc__id_put(t, t->pool[n].id, n);
	if (t->nopen) {
		link_child(t, t->open[t->nopen - 1], BC_NONE, n);
	} else {
		t->root = n;
	}
	t->nnodes++;
	*out = n;
	return 0;
}

int bc_tree_push_op(struct bc_tree *t, uint32_t id, const struct bc_op_data *op,
                    struct bc_errinfo *ei)
{
	uint32_t n;
	struct bc_op_data o = *op;
	int rc;
	if (bc_op_is_smooth(o.kind) && o.range == 0.0f) {
		o.range = bc_op_default_range(o.blend);
	}
	if (!bc_op_is_smooth(o.kind)) {
		o.blend = 0.0f;
		o.range = 0.0f;
	}
	if ((rc = bc_op_validate(&o, ei)) ||
	    (rc = add_node(t, id, true, ei, &n))) {
		return rc;
	}
	t->pool[n].u.op = o;
	t->nops++;
	t->open[t->nopen++] = n;
	return 0;
}

int bc_tree_push_unary(struct bc_tree *t, uint32_t id, const struct bc_unary *u,
                       struct bc_errinfo *ei)
{
	uint32_t n;
	int rc;
	if ((rc = bc_unary_validate(u, ei)) ||
	    (rc = add_node(t, id, true, ei, &n))) {
		return rc;
	}
	memset(&t->pool[n].u.op, 0, sizeof(t->pool[n].u.op));
	t->pool[n].u.op.kind = u->kind;
	t->pool[n].xpar = xpar_take(t);
	memcpy(xpar_at(t, t->pool[n].xpar), u->u, sizeof(u->u));
	t->nops++;
	t->nunary_nodes++;
	t->open[t->nopen++] = n;
	return 0;
}

int bc_tree_pop_op(struct bc_tree *t, struct bc_errinfo *ei)
{
	uint32_t n;
	if (!t->building || t->nopen == 0) {
		return bc_errinfo_set(ei, BC_ESTATE, "tree: no open operator");
	}
	n = t->open[t->nopen - 1];
	if (bc__node_unary(&t->pool[n])) {
		if (t->pool[n].u.nchildren != 1) {
			return bc_errinfo_set(ei, BC_EINVAL,
			                      "tree: %s node %u needs exactly "
			                      "one child",
			                      bc_op_name(t->pool[n].u.op.kind),
			                      t->pool[n].id);
		}
	} else if (t->pool[n].u.nchildren < 2) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "tree: operator %u (%s) needs two or "
		                      "more children, has %u",
		                      t->pool[n].id,
		                      bc_op_name(t->pool[n].u.op.kind),
		                      t->pool[n].u.nchildren);
	}
	t->nopen--;
	return 0;
}

int bc_tree_put_prim(struct bc_tree *t, uint32_t id,
                     const struct bc_prim_data *p, struct bc_errinfo *ei)
{
	struct bc_prim_data copy = *p;
	uint32_t n;
	int rc;
	if ((rc = bc_prim_validate(&copy, ei)) ||
	    (rc = add_node(t, id, false, ei, &n))) {
		return rc;
	}
	prim_write(t, &t->pool[n], &copy, true);
	t->nprims++;
	count_prim(t, copy.kind, copy.has_color, 1);
	return 0;
}

int bc_tree_end(struct bc_tree *t, struct bc_errinfo *ei)
{
	struct bc_lin fresh;
	int rc;
	if (!t->building) {
		return bc_errinfo_set(ei, BC_ESTATE,
		                      "tree: bc_tree_begin() not called");
	}
	if (t->nopen) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "tree: operator %u not closed",
		                      t->pool[t->open[t->nopen - 1]].id);
	}
	if (t->root == BC_NONE) {
		return bc_errinfo_set(ei, BC_EINVAL, "tree: no root node");
	}
	if ((rc = check_shape(t, ei))) {
		return rc;
	}
	if ((rc = lin_alloc(t, &fresh, t->nprims, t->nspheres, t->nops,
	                    t->nunary_nodes > 0, false))) {
		return bc_errinfo_set(ei, rc, "tree: %s", bc_strerror(rc));
	}
	t->building = false;
	install_lin(t, &fresh);
	return 0;
}

/* ---- reading ------------------------------------------------------------ */

bool bc_tree_has_auto_ids(const struct bc_tree *t)
{
	for (uint32_t n = 0; n < t->npool; n++) {
		if (t->pool[n].live && t->pool[n].auto_id) {
			return true;
		}
	}
	return false;
}

uint32_t bc_tree_node_count(const struct bc_tree *t)
{
	return t->nnodes;
}

uint32_t bc_tree_prim_count(const struct bc_tree *t)
{
	return t->nprims;
}

uint32_t bc_tree_nesting(const struct bc_tree *t)
{
	return (t->root == BC_NONE || t->building) ? 0 : t->nesting;
}

uint32_t bc_tree_root(const struct bc_tree *t)
{
	return (t->root == BC_NONE || t->building) ? 0 : t->pool[t->root].id;
}

bool bc_tree_get(const struct bc_tree *t, uint32_t id,
                 struct bc_prim_data *prim, struct bc_op_data *op)
{
	uint32_t n = bc__id_find(t, id);
	if (prim) {
		memset(prim, 0, sizeof(*prim));
	}
	if (op) {
		memset(op, 0, sizeof(*op));
	}
	if (n == BC_NONE) {
		return false;
	}
	if (t->pool[n].is_op && op) {
		*op = t->pool[n].u.op;
	} else if (!t->pool[n].is_op && prim) {
		bc__prim_read(t, &t->pool[n], prim);
	}
	return true;
}

uint32_t bc_tree_child_count(const struct bc_tree *t, uint32_t id)
{
	uint32_t n = bc__id_find(t, id);
	return n == BC_NONE ? 0 : bc__nkids(&t->pool[n]);
}

uint32_t bc_tree_child(const struct bc_tree *t, uint32_t id, uint32_t k)
{
	uint32_t n = bc__id_find(t, id), c;
	if (n == BC_NONE) {
		return 0;
	}
	c = child_at(t, n, k);
	return c == BC_NONE ? 0 : t->pool[c].id;
}

void bc_tree_counts(const struct bc_tree *t, uint32_t *colored,
                    uint64_t *floats)
{
	if (colored) {
		*colored = t->ncolored;
	}
	if (floats) {
		*floats = t->nfloats;
	}
}

uint32_t bc_tree_child_index(const struct bc_tree *t, uint32_t id)
{
	uint32_t n = bc__id_find(t, id), p, s, a, k;
	const struct bc_lin *l = &t->lin;
	const struct bc__kids *kids;
	if (n == BC_NONE || (p = t->pool[n].parent) == BC_NONE ||
	    bc__node_unary(&t->pool[p])) {
		return 0;
	}
	if ((kids = kids_of(t, p)) != NULL) {
		return kids_pos(t, kids, n);
	}
	if (!t->has_lin || t->building) {
		/* From both ends at once: the nearer one ends the walk (the
		 * last child of a wide operator costs nothing). */
		uint32_t b = n;
		for (k = 0;; k++) {
			if (t->pool[n].prev == BC_NONE) {
				return k;
			}
			if (t->pool[b].next == BC_NONE) {
				return t->pool[p].u.nchildren - 1u - k;
			}
			n = t->pool[n].prev;
			b = t->pool[b].next;
		}
	}
	/* Child i >= 1 is the right operand of the fold i levels up the
	 * operator's left spine from its first fold; child 0 the left one. */
	s = bc__slot(t, &t->pool[n]);
	if (l->node[2 * s] & BC_WORD_LEFT) {
		return 0;
	}
	a = bc_lin_parent(l, s);
	k = t->pool[p].u.nchildren;
	return k - 1u - (l->depth[a] - l->depth[bc__slot(t, &t->pool[p])]);
}

uint32_t bc_tree_parent(const struct bc_tree *t, uint32_t id)
{
	uint32_t n = bc__id_find(t, id);
	if (n == BC_NONE || t->pool[n].parent == BC_NONE) {
		return 0;
	}
	return t->pool[t->pool[n].parent].id;
}

uint32_t bc_tree_slot(const struct bc_tree *t, uint32_t id)
{
	uint32_t n = bc__id_find(t, id);
	return (n == BC_NONE || !t->has_lin) ? BC_NONE
	                                     : bc__slot(t, &t->pool[n]);
}

const struct bc_lin *bc_tree_lin(const struct bc_tree *t)
{
	return t->has_lin ? &t->lin : NULL;
}

void bc_tree_take_dirty(struct bc_tree *t, struct bc_dirty *out)
{
	*out = t->dirty;
	memset(&t->dirty, 0, sizeof(t->dirty));
}

const struct bc_dirty *bc_tree_dirty(const struct bc_tree *t)
{
	return &t->dirty;
}

/* ---- parameter edits ---------------------------------------------------- */

static uint32_t live_node(const struct bc_tree *t, uint32_t id)
{
	return t->building ? BC_NONE : bc__id_find(t, id);
}

/* live_node, with the node's slot, param and prim brought up to date. */
static uint32_t live_node_now(struct bc_tree *t, uint32_t id)
{
	uint32_t n = live_node(t, id);
	if (n != BC_NONE && t->lay) {
		bc__refresh(t, &t->pool[n]);
	}
	return n;
}

int bc_tree_set_prim(struct bc_tree *t, uint32_t id,
                     const struct bc_prim_data *p, struct bc_errinfo *ei)
{
	uint32_t n = live_node_now(t, id);
	struct bc_prim_data copy = *p;
	int rc;
	if (n == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u", id);
	}
	if (t->pool[n].is_op || t->pool[n].pkind != (uint8_t)p->kind) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is not a primitive of that "
		                      "kind: replace it instead",
		                      id);
	}
	if ((rc = bc_prim_validate(&copy, ei))) {
		return rc;
	}
	count_prim(t, copy.kind, t->pool[n].has_color, -1);
	count_prim(t, copy.kind, copy.has_color, 1);
	prim_write(t, &t->pool[n], &copy, false);
	if (!t->has_lin) {
		t->dirty.edits++;
		return 0;
	}
	bc__lin_update_prim(t, &t->pool[n]);
	bc__dirty_range(&t->dirty.param_lo, &t->dirty.param_hi, t->lay[n].param,
	                t->lay[n].param + bc_prim_record_vec4(copy.kind));
	if (bc__lin_prim_bends(t, &t->pool[n])) {
		/* The bounds of its twist and bend ancestors changed. */
		bc__dirty_range(&t->dirty.param_lo, &t->dirty.param_hi, 0,
		                t->lin.nparam);
	}
	bc__dirty_range(&t->dirty.prim_lo, &t->dirty.prim_hi, t->lay[n].prim,
	                t->lay[n].prim + 1);
	t->dirty.edits++;
	return 0;
}

int bc_tree_set_op(struct bc_tree *t, uint32_t id, const struct bc_op_data *op,
                   struct bc_errinfo *ei)
{
	uint32_t n = live_node_now(t, id);
	struct bc_op_data o = *op;
	const struct bc_lin *l = &t->lin;
	uint32_t first_slot, k_lo, k_hi;
	int rc;
	if (n == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u", id);
	}
	if (!t->pool[n].is_op) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is a primitive, not an "
		                      "operator",
		                      id);
	}
	if (bc__node_unary(&t->pool[n])) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is a %s node: set its own "
		                      "parameters",
		                      id, bc_op_name(t->pool[n].u.op.kind));
	}
	if (bc_op_is_smooth(o.kind) && o.range == 0.0f) {
		o.range = bc_op_default_range(o.blend);
	}
	if (!bc_op_is_smooth(o.kind)) {
		o.blend = 0.0f;
		o.range = 0.0f;
	}
	if ((rc = bc_op_validate(&o, ei))) {
		return rc;
	}
	if (bc__op_kills(o.kind) && (rc = bc__lin_want_kills(t))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	t->pool[n].u.op = o;
	if (!t->has_lin) {
		t->dirty.edits++;
		return 0;
	}
	bc__lin_update_op(t, &t->pool[n]);
	/* The subtree's slots are [first, top]; its primitives are those with
	 * indices from the first leaf's to the last leaf's. */
	first_slot = bc_lin_first(l, t->lay[n].slot);
	/* The leftmost slot is a leaf; a binary subtree of s slots has
	 * (s + 1) / 2 leaves, all consecutive primitives. */
	k_lo = bc_lin_leaf_prim(l, first_slot);
	k_hi = k_lo + (t->lay[n].slot - first_slot) / 2 + 1;
	bc__dirty_range(&t->dirty.slot_lo, &t->dirty.slot_hi, first_slot,
	                t->lay[n].slot + 1);
	bc__dirty_range(&t->dirty.param_lo, &t->dirty.param_hi, t->lay[n].param,
	                t->lay[n].param + BC_OP_RECORD_VEC4);
	bc__dirty_range(&t->dirty.prim_lo, &t->dirty.prim_hi, k_lo, k_hi);
	t->dirty.edits++;
	return 0;
}

int bc_tree_set_unary(struct bc_tree *t, uint32_t id, const struct bc_unary *u,
                      struct bc_errinfo *ei)
{
	uint32_t n = live_node_now(t, id);
	const struct bc_lin *l = &t->lin;
	uint32_t first_slot, k_lo, k_hi;
	int rc;
	if (n == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u", id);
	}
	if (!bc__node_unary(&t->pool[n])) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is not a unary node", id);
	}
	if ((rc = bc_unary_validate(u, ei))) {
		return rc;
	}
	t->pool[n].u.op.kind = u->kind;
	memcpy(xpar_at(t, t->pool[n].xpar), u->u, sizeof(u->u));
	if (!t->has_lin) {
		t->dirty.edits++;
		return 0;
	}
	bc__lin_update_unary(t, &t->pool[n]);
	first_slot = bc_lin_first(l, t->lay[n].slot);
	k_lo = bc_lin_leaf_prim(l, first_slot);
	k_hi = k_lo + (t->lay[n].slot - first_slot) / 2 + 1;
	/* Its record, and the bounds of every twist and bend (conservatively
	 * the whole parameter range: these trees are small). */
	bc__dirty_range(&t->dirty.param_lo, &t->dirty.param_hi, 0, l->nparam);
	bc__dirty_range(&t->dirty.prim_lo, &t->dirty.prim_hi, k_lo, k_hi);
	t->dirty.edits++;
	return 0;
}

bool bc_tree_get_unary(const struct bc_tree *t, uint32_t id,
                       struct bc_unary *out)
{
	uint32_t n = bc__id_find(t, id);
	memset(out, 0, sizeof(*out));
	if (n == BC_NONE || !bc__node_unary(&t->pool[n])) {
		return false;
	}
	out->kind = t->pool[n].u.op.kind;
	memcpy(out->u, bc__uparam(t, &t->pool[n]), sizeof(out->u));
	return true;
}

/* ---- structural edits --------------------------------------------------- */

/* Is pool node n inside the subtree rooted at pool node top? */
static bool within(const struct bc_tree *t, uint32_t n, uint32_t top)
{
	for (; n != BC_NONE; n = t->pool[n].parent) {
		if (n == top) {
			return true;
		}
	}
	return false;
}

/* Checks that every id sub chose is free in t, or (replace) belongs to the
 * subtree `allowed` that is about to go. */
static int check_ids(const struct bc_tree *t, const struct bc_tree *sub,
                     uint32_t top, uint32_t allowed, struct bc_errinfo *ei)
{
	uint32_t depth = 0;
	for (uint32_t n = top; n != BC_NONE;
	     n = preorder_next(sub, n, top, &depth)) {
		const struct bc__node *sn = &sub->pool[n];
		uint32_t m;
		if (sn->auto_id) {
			continue;
		}
		m = bc__id_find(t, sn->id);
		if (m != BC_NONE &&
		    (allowed == BC_NONE || !within(t, m, allowed))) {
			return bc_errinfo_set(ei, BC_EDUPID,
			                      "id %u is already in the scene",
			                      sn->id);
		}
	}
	return 0;
}

/* Copies one node of sub into t (room reserved, ids checked). */
static uint32_t copy_node(struct bc_tree *t, const struct bc_tree *sub,
                          const struct bc__node *sn, bool keep_ids)
{
	uint32_t m = pool_take(t);
	t->pool[m].is_op = sn->is_op;
	if (sn->is_op) {
		/* Its children are linked as they are copied. */
		t->pool[m].u.op = sn->u.op;
		t->pool[m].u.unary = sn->u.unary;
		if (sn->xpar != BC_NONE) {
			/* A unary node's parameters. */
			t->pool[m].xpar = xpar_take(t);
			memcpy(xpar_at(t, t->pool[m].xpar),
			       xpar_at(sub, sn->xpar),
			       BC__XPAR_FLOATS * sizeof(float));
		}
	} else {
		struct bc_prim_data p;
		bc__prim_read(sub, sn, &p);
		prim_write(t, &t->pool[m], &p, true);
	}
	t->pool[m].auto_id = sn->auto_id;
	t->pool[m].id = (sn->auto_id && !keep_ids) ? fresh_id(t) : sn->id;
	bc__id_put(t, t->pool[m].id, m);
	t->nnodes++;
	if (sn->is_op) {
		t->nops++;
		t->nunary_nodes += bc__node_unary(sn) ? 1u : 0u;
	} else {
		t->nprims++;
		count_prim(t, (enum bc_prim)sn->pkind, sn->has_color, 1);
	}
	return m;
}

/* Copies sub's subtree at top into t (room reserved, ids checked), walking
 * both trees in step without recursion. Returns the new pool index. */
static uint32_t copy_in(struct bc_tree *t, const struct bc_tree *sub,
                        uint32_t top, bool keep_ids)
{
	uint32_t n = top, m = copy_node(t, sub, &sub->pool[top], keep_ids);
	uint32_t root = m;
	for (;;) {
		if (sub->pool[n].is_op &&
		    sub->pool[n].u.first_child != BC_NONE) {
			uint32_t c = sub->pool[n].u.first_child;
			uint32_t cm =
			    copy_node(t, sub, &sub->pool[c], keep_ids);
			link_child(t, m, BC_NONE, cm);
			n = c;
			m = cm;
			continue;
		}
		while (n != top && sub->pool[n].next == BC_NONE) {
			n = sub->pool[n].parent;
			m = t->pool[m].parent;
		}
		if (n == top) {
			return root;
		}
		n = sub->pool[n].next;
		{
			uint32_t pm = t->pool[m].parent;
			m = copy_node(t, sub, &sub->pool[n], keep_ids);
			link_child(t, pm, BC_NONE, m);
		}
	}
}

/* Shared by insert, replace and copy: checks sub against t's limits when
 * `gone` (statistics of what leaves t) is removed and sub is placed at depth
 * `at_depth`, then reserves every resource: new layout arrays in fresh, or,
 * without fresh, room in t's to splice sub in. */
static int prepare_graft(struct bc_tree *t, const struct bc_tree *sub,
                         uint32_t at_depth, const struct subtree_stats *gone,
                         struct bc_lin *fresh, struct bc_errinfo *ei)
{
	struct subtree_stats st = {0};
	uint64_t prims, spheres, ops;
	int rc = 0;
	if (sub->building || sub->root == BC_NONE) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "the subtree to graft is empty or "
		                      "unfinished");
	}
	subtree_stats(sub, sub->root, &st);
	/* sub's root lands at depth at_depth + 1, so its deepest node at
	 * at_depth + st.depth: that is the nesting the builder counts. */
	if ((uint64_t)at_depth + st.depth > BC_TREE_MAX_DEPTH) {
		return bc_errinfo_set(ei, BC_EDEPTH,
		                      "the result would nest deeper than %u "
		                      "levels",
		                      BC_TREE_MAX_DEPTH);
	}
	prims = (uint64_t)t->nprims - gone->prims + st.prims;
	spheres = (uint64_t)t->nspheres - gone->spheres + st.spheres;
	ops = (uint64_t)t->nops - gone->ops + st.ops;
	if (2u * prims - 1u > BC_TREE_MAX_NODES) {
		return bc_errinfo_set(ei, BC_ELIMIT,
		                      "the result would exceed %u nodes",
		                      BC_TREE_MAX_NODES);
	}
	if (fresh) {
		rc = lin_alloc(
		    t, fresh, (uint32_t)prims, (uint32_t)spheres, (uint32_t)ops,
		    t->nunary_nodes + sub->nunary_nodes > 0, st.kill_ops > 0);
	} else if (!t->bare) {
		rc = bc__splice_reserve(t, (uint32_t)(2u * prims - 1u),
		                        (uint32_t)prims,
		                        t->lin.nparam + tree_recs(sub),
		                        st.spheres<st.prims, st.kill_ops> 0);
	}
	if (rc) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	if ((rc = pool_reserve(t, st.nodes)) ||
	    (rc = bc__map_reserve(&t->ids, st.nodes))) {
		if (fresh) {
			bc__lin_free(fresh);
		}
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	return 0;
}

int bc_tree_insert(struct bc_tree *t, uint32_t parent_id, uint32_t pos,
                   const struct bc_tree *sub, struct bc_errinfo *ei)
{
	uint32_t p = live_node(t, parent_id), before, m;
	struct subtree_stats none = {0};
	struct bc_lin fresh;
	bool splice = splices(t, sub), touch;
	int rc;
	if (p == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u",
		                      parent_id);
	}
	if (!t->pool[p].is_op) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is a primitive: children go "
		                      "under operators",
		                      parent_id);
	}
	if (bc__node_unary(&t->pool[p])) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "node %u is a %s node with its one "
		                      "child: replace the child instead",
		                      parent_id,
		                      bc_op_name(t->pool[p].u.op.kind));
	}
	if (pos > t->pool[p].u.nchildren) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "position %u beyond the %u children of "
		                      "node %u",
		                      pos, t->pool[p].u.nchildren, parent_id);
	}
	if (sub->building || sub->root == BC_NONE) {
		return bc_errinfo_set(ei, BC_EINVAL, "the subtree is empty");
	}
	if ((rc = check_ids(t, sub, sub->root, BC_NONE, ei))) {
		return rc;
	}
	if (!t->nameless && (rc = bc__names_reserve(&t->names, sub->names.n))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	if ((rc = prepare_graft(t, sub, depth_of(t, p), &none,
	                        splice ? NULL : &fresh, ei))) {
		return rc;
	}
	before = child_at(t, p, pos);
	m = copy_in(t, sub, sub->root, false);
	link_child(t, p, before, m);
	kids_build(t, p);
	if (splice) {
		/* The measures follow the path from m up (a graft only adds
		 * nesting and need), then the layout is spliced. */
		uint32_t nest = depth_of(t, p) + bc__measure(t, m);
		need_grow(t, m);
		if (t->pool[t->root].need > BC_EVAL_STACK) {
			rc = need_error(t, ei);
			unlink_child(t, m);
			free_subtree(t, m);
			bc__measure(t, t->root);
			return rc;
		}
		touch = splice_insert(t, m, sub->nprims, tree_recs(sub));
		if (nest > t->nesting) {
			t->nesting = nest;
		}
		splice_finish(t, touch);
		bc__names_graft(t, sub);
		return 0;
	}
	/* The evaluation stack depends on the whole tree: measured on the
	 * result, and undone (which cannot fail) when over the limit. */
	if ((rc = check_shape(t, ei))) {
		unlink_child(t, m);
		free_subtree(t, m);
		bc__measure(t, t->root);
		bc__lin_free(&fresh);
		return rc;
	}
	install_lin(t, &fresh);
	bc__names_graft(t, sub);
	return 0;
}

/* Detaches and frees pool node n's subtree; an operator left with one child
 * is replaced by that child. */
static void cut(struct bc_tree *t, uint32_t n)
{
	uint32_t p = t->pool[n].parent;
	if (p == BC_NONE) {
		free_subtree(t, n);
		t->root = BC_NONE;
		return;
	}
	unlink_child(t, n);
	free_subtree(t, n);
	if (t->pool[p].u.nchildren == 1) {
		uint32_t only = t->pool[p].u.first_child;
		uint32_t gp = t->pool[p].parent;
		uint32_t after = t->pool[p].next;
		unlink_child(t, only);
		if (gp == BC_NONE) {
			t->root = only;
		} else {
			unlink_child(t, p);
			link_child(t, gp, after, only);
		}
		bc__id_del(t, t->pool[p].id);
		t->nops--;
		t->nunary_nodes -= bc__node_unary(&t->pool[p]) ? 1u : 0u;
		t->nnodes--;
		pool_release(t, p);
	}
}

int bc_tree_remove(struct bc_tree *t, uint32_t id, struct bc_errinfo *ei)
{
	uint32_t n = live_node(t, id), p;
	struct subtree_stats st = {0};
	struct bc_lin fresh;
	uint32_t collapse;
	int rc;
	if (n == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u", id);
	}
	/* A unary node cannot lose its only child: the node goes with it
	 * (and so on up a chain of unary nodes). */
	while (t->pool[n].parent != BC_NONE &&
	       bc__node_unary(&t->pool[t->pool[n].parent])) {
		n = t->pool[n].parent;
	}
	subtree_stats(t, n, &st);
	p = t->pool[n].parent;
	collapse = (p != BC_NONE && t->pool[p].u.nchildren == 2) ? 1 : 0;
	if (p != BC_NONE && splices(t, NULL)) {
		/* Spliced out; the measures follow the path up (nesting
		 * only looked for again when the deepest path may have
		 * gone). */
		uint32_t nest = t->nesting, gp = t->pool[p].parent;
		uint32_t deepest = depth_of(t, n) - 1u + st.depth;
		bool touch = splice_remove(t, n);
		bc__names_drop_subtree(t, n);
		if (collapse) {
			bc__names_del(&t->names, t->pool[p].id);
		}
		cut(t, n);
		need_shrink(t, collapse ? gp : p);
		if ((collapse || deepest >= nest) && !reaches(t, nest)) {
			t->nesting = bc__measure(t, t->root);
		}
		splice_finish(t, touch);
		return 0;
	}
	memset(&fresh, 0, sizeof(fresh));
	if (p != BC_NONE && (rc = lin_alloc(t, &fresh, t->nprims - st.prims,
	                                    t->nspheres - st.spheres,
	                                    t->nops - st.ops - collapse,
	                                    t->nunary_nodes > 0, false))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	bc__names_drop_subtree(t, n);
	if (collapse) {
		bc__names_del(&t->names, t->pool[p].id);
	}
	cut(t, n);
	install_lin(t, &fresh);
	return 0;
}

/* bc_tree_replace's end for a spliced layout: pool node m (a copy of sub)
 * is linked where n was (whose layout blk notes; it added old_need to its
 * parent's need). The measures follow the path up, the layout is spliced,
 * n goes. On a refusal n is put back. */
static int replace_spliced(struct bc_tree *t, uint32_t n, uint32_t m,
                           const struct bc__block *blk, uint32_t old_need,
                           const struct subtree_stats *gone,
                           const struct bc_tree *sub, struct bc_errinfo *ei)
{
	uint32_t p = t->pool[m].parent, after = t->pool[m].next;
	uint32_t nest = t->nesting, pd = depth_of(t, p);
	uint32_t deepest = pd + bc__measure(t, m);
	bool touch;
	int rc;
	if (need_in_parent(t, m) >= old_need) {
		need_grow(t, m);
	} else {
		need_shrink(t, p);
	}
	if (t->pool[t->root].need > BC_EVAL_STACK) {
		rc = need_error(t, ei);
		unlink_child(t, m);
		link_child(t, p, after, n);
		free_subtree(t, m);
		remap_ids(t, n);
		bc__measure(t, t->root);
		return rc;
	}
	touch = splice_replace(t, blk, m, sub->nprims, tree_recs(sub));
	/* The replaced nodes' names go, reused ids included: the subtree's
	 * own names are the new nodes'. */
	bc__names_drop_subtree(t, n);
	free_subtree(t, n);
	if (deepest >= nest) {
		t->nesting = deepest;
	} else if (pd + gone->depth >= nest && !reaches(t, nest)) {
		t->nesting = bc__measure(t, t->root);
	}
	splice_finish(t, touch);
	bc__names_graft(t, sub);
	return 0;
}

int bc_tree_replace(struct bc_tree *t, uint32_t id, const struct bc_tree *sub,
                    struct bc_errinfo *ei)
{
	uint32_t n = live_node(t, id), p, after, m, old_need = 0;
	struct subtree_stats gone = {0};
	struct bc__block blk;
	struct bc_lin fresh;
	bool splice;
	int rc;
	if (n == BC_NONE) {
		return bc_errinfo_set(ei, BC_ENONODE, "no node with id %u", id);
	}
	if (sub->building || sub->root == BC_NONE) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "the replacement is empty");
	}
	splice = t->pool[n].parent != BC_NONE && splices(t, sub);
	if ((rc = check_ids(t, sub, sub->root, n, ei))) {
		return rc;
	}
	if (!t->nameless && (rc = bc__names_reserve(&t->names, sub->names.n))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	subtree_stats(t, n, &gone);
	p = t->pool[n].parent;
	if ((rc = prepare_graft(t, sub, p == BC_NONE ? 0 : depth_of(t, p),
	                        &gone, splice ? NULL : &fresh, ei))) {
		return rc;
	}
	if (splice) {
		splice_note(t, n, &blk);
		old_need = need_in_parent(t, n);
	}
	after = t->pool[n].next;
	if (p != BC_NONE) {
		unlink_child(t, n);
	}
	/* The old subtree stays in the pool until the result is known to be
	 * within the limits; replacement ids it shares with it are mapped to
	 * the copy, and back when the edit is undone. */
	m = copy_in(t, sub, sub->root, false);
	if (p == BC_NONE) {
		t->root = m;
	} else {
		link_child(t, p, after, m);
	}
	if (splice) {
		return replace_spliced(t, n, m, &blk, old_need, &gone, sub, ei);
	}
	if ((rc = check_shape(t, ei))) {
		if (p == BC_NONE) {
			t->root = n;
		} else {
			unlink_child(t, m);
			link_child(t, p, after, n);
		}
		free_subtree(t, m);
		remap_ids(t, n);
		bc__measure(t, t->root);
		bc__lin_free(&fresh);
		return rc;
	}
	/* The replaced nodes' names go, reused ids included: the
	 * subtree's own names are the new nodes'. */
	bc__names_drop_subtree(t, n);
	free_subtree(t, n);
	install_lin(t, &fresh);
	bc__names_graft(t, sub);
	return 0;
}

int bc_tree_relayout(struct bc_tree *t, struct bc_errinfo *ei)
{
	struct bc_lin fresh;
	int rc;
	if (t->root == BC_NONE || t->building) {
		return 0;
	}
	if ((rc = lin_alloc(t, &fresh, t->nprims, t->nspheres, t->nops,
	                    t->nunary_nodes > 0, false))) {
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	install_lin(t, &fresh);
	return 0;
}

void bc_tree_swap(struct bc_tree *a, struct bc_tree *b)
{
	struct bc_tree keep = *a;
	*a = *b;
	*b = keep;
}

int bc_tree_copy(struct bc_tree *dst, const struct bc_tree *src,
                 struct bc_errinfo *ei)
{
	struct subtree_stats none = {0};
	struct bc_lin fresh;
	int rc;
	if (dst == src) {
		return 0;
	}
	tree_clear(dst);
	if (src->root == BC_NONE) {
		return 0;
	}
	if ((rc = prepare_graft(dst, src, 0, &none, &fresh, ei))) {
		return rc;
	}
	if (!dst->nameless && (rc = bc__names_copy(&dst->names, &src->names))) {
		bc__lin_free(&fresh);
		tree_clear(dst);
		return bc_errinfo_set(ei, rc, "%s", bc_strerror(rc));
	}
	dst->root = copy_in(dst, src, src->root, true);
	/* Keep the numbering of fresh ids where src would continue it. */
	if (src->next_id > dst->next_id) {
		dst->next_id = src->next_id;
	}
	install_lin(dst, &fresh);
	return 0;
}
