/*
 * Private state of struct bc_tree, shared by tree.c (model, ids, builder,
 * edits) and linearize.c (the post-order layout, ROIs, ABVs).
 */
#ifndef BLOBCAST_BLOBTREE_TREE_IMPL_H
#define BLOBCAST_BLOBTREE_TREE_IMPL_H

#include "blobcast/blobtree.h"

/* A primitive's data as a pool node keeps it: 28 bytes, where struct
 * bc_prim_data takes 80 (eight parameters, of which a sphere uses one,
 * and a rotation, which most primitives of a big scene leave alone). The
 * first parameter float, translation and colour are here; a kind of two
 * or more parameters (a box's three half extents,
 * bc_scene_prim_nfloats) or a primitive with a rotation other than the
 * identity keeps the other parameters and the rotation in a chunk of the
 * tree's xpar store (struct bc_tree, BC__XPAR_FLOATS), taken when the
 * node needs it and given back when the node goes; the store keeps room
 * for a chunk for every pool node, so that an edit that rotates a sphere
 * cannot fail for memory. Kind and colour flag are in the node's
 * header. Read and written whole through bc__prim_read and prim_write
 * (tree.c). A unary node keeps its parameters in a chunk too. */
struct bc__prim_room {
	float p0;
	float translate[3];
	float color[3];
};
/* A chunk: a primitive's parameters past the first, then its rotation;
 * or a unary node's parameters. */
#define BC__XPAR_PARAMS (BC_PRIM_MAX_PARAMS - 1)
#define BC__XPAR_FLOATS (BC__XPAR_PARAMS + 4)
_Static_assert(BC_UNARY_MAX_PARAMS <= BC__XPAR_FLOATS,
               "a unary node's parameters fit a chunk");

/* One node of the editable n-ary model, in a pool addressed by index: 52
 * bytes (a million-sphere model, bare, about 56 bytes a primitive). An
 * operator's children (first, last, count) share the room of a
 * primitive's data, which has none: they are read on operators only, and
 * where a node may be either (a public call's id) through bc__nkids,
 * which gives a primitive none. */
struct bc__node {
	uint32_t id;
	uint32_t parent;     /* pool index, BC_NONE for the root or detached */
	uint32_t next, prev; /* siblings: pool indices, BC_NONE at the ends */
	bool is_op : 1;
	bool live : 1;
	bool auto_id : 1;   /* id was assigned, not chosen by the scene */
	bool has_color : 1; /* a primitive's: its colour is its own */
	/* Position index of a bare tree's wide operators (struct
	 * bc__kids): BC__KIDS_OP on an operator that has one, BC__KIDS_AT
	 * on a child that is one of its anchors. */
	uint8_t kids;
	uint8_t pkind; /* a primitive's enum bc_prim */
	/* Evaluation stack entries of its subtree, BC__NEED_MAX for that
	 * many or more (bc__need): far past BC_EVAL_STACK, which no tree
	 * may pass. */
	uint8_t need;
	/* Its chunk of the xpar store (struct bc__prim_room), BC_NONE. */
	uint32_t xpar;
	/* A primitive's data, or an operator's (a unary node, u.op.kind
	 * says it is one, keeps its parameters in its chunk) and its
	 * children (pool indices, BC_NONE when it has none). */
	union {
		struct bc__prim_room prim;
		struct {
			struct bc_op_data op;
			uint32_t unary; /* unary index (set by linearization) */
			uint32_t first_child, last_child;
			uint32_t nchildren;
		};
	} u;
};
_Static_assert(BC_PRIM_COUNT <= 256, "a primitive's kind is one byte");
/* Two of these a primitive in the daemon (the session's tree and the
 * render copy): docs/benchmarks.md, "A pool node in 84 bytes", "A
 * rotation in the chunk" and "An operator's children in a primitive's
 * room". */
_Static_assert(sizeof(struct bc__node) <= 52, "a pool node grew");

#define BC__NEED_MAX 255u
_Static_assert(BC_EVAL_STACK < BC__NEED_MAX,
               "a node's need saturates past the stack a tree may need");
/* A need as a node keeps it: v, or BC__NEED_MAX for v and more (the
 * same verdict against BC_EVAL_STACK). */
static inline uint8_t bc__need(uint32_t v)
{
	return (uint8_t)(v < BC__NEED_MAX ? v : BC__NEED_MAX);
}

/* Node n's number of children: none for a primitive, whose data has the
 * room of an operator's count. */
static inline uint32_t bc__nkids(const struct bc__node *n)
{
	return n->is_op ? n->u.nchildren : 0u;
}

/* Pool node n's primitive data, whole (n must be a primitive). */
void bc__prim_read(const struct bc_tree *t, const struct bc__node *n,
                   struct bc_prim_data *out);
/* Unary node n's parameters (BC_UNARY_MAX_PARAMS floats, its chunk). */
const float *bc__uparam(const struct bc_tree *t, const struct bc__node *n);

/* Where a node of a laid-out tree is in its layout (struct bc_tree's lay,
 * beside the pool, index for index): set by linearization. A bare tree
 * keeps none (12 bytes a node). */
struct bc__lay {
	uint32_t slot;  /* the node's top slot */
	uint32_t param; /* parameter record, vec4 units */
	/* Primitive index (primitives only), and the low byte of the count
	 * of splices slot, param and prim have followed (bc__lay_epoch):
	 * a node lags fewer splices than the shift log holds. Written
	 * through bc__lay_prim and bc__lay_mark. */
	uint32_t prim : 24;
	uint32_t epoch : 8;
};
_Static_assert(BC_TREE_MAX_NODES < (1u << 24),
               "a primitive index fits a layout place's 24 bits");

#define BC__KIDS_OP 1u
#define BC__KIDS_AT 2u

static inline bool bc__node_unary(const struct bc__node *n)
{
	return n->is_op && bc_op_is_unary(n->u.op.kind);
}

/* Open-addressing map from id (never 0) to pool index. */
struct bc__idmap {
	uint32_t *keys; /* 0 = empty */
	uint32_t *vals;
	uint32_t cap; /* power of two */
	uint32_t count;
};

/* ids map (tree.c): find gives BC_NONE for an unknown id; put needs room
 * made by reserve (load <= 1/2); del shifts back, leaving no tombstone. */
uint32_t bc__map_find(const struct bc__idmap *m, uint32_t id);
void bc__map_put_nogrow(struct bc__idmap *m, uint32_t id, uint32_t val);
int bc__map_reserve(struct bc__idmap *m, uint32_t more);
/* Room for nodes more nodes in the pool and the id map, backed by memory
 * now (bc_populate): for a builder that knows its node count. */
int bc__tree_reserve(struct bc_tree *t, uint32_t nodes);
void bc__map_del(struct bc__idmap *m, uint32_t id);

/* Node names (names.c): kept apart from the nodes, which every primitive
 * pays for, in a dense array indexed through an id map; most scenes name a
 * few nodes or none. */
struct bc__name {
	uint32_t id;
	uint8_t len;
	char text[BC_TREE_NAME_MAX + 1]; /* NUL-terminated */
};
struct bc__names {
	struct bc__idmap at; /* id -> index in v */
	struct bc__name *v;
	uint32_t n, cap;
};

/* One splice of the layout (splice.c): in each index space -- slots,
 * records (vec4), primitives -- del entries at `at` went and ins new ones
 * came. */
struct bc__span {
	uint32_t at, del, ins;
};
struct bc__shift {
	struct bc__span s, p, k;
};
/* A bare tree has no layout to find child k of a wide operator in, and
 * walking the child list to it took about 5 ms at the 350 000th child:
 * an operator of BC__KIDS_MIN children or more keeps every BC__KIDS_STEP-th
 * child (its anchors, at[i] at position i * BC__KIDS_STEP), which
 * link_child and unlink_child keep current (a pass over the anchors, not
 * the children). Child k is then at most BC__KIDS_STEP steps from an
 * anchor, and a child's position as far from the anchor before it. */
#define BC__KIDS_MIN 2048u
#define BC__KIDS_STEP 256u
struct bc__kids {
	uint32_t op; /* pool index of the operator */
	uint32_t n, cap;
	uint32_t *at;
};

/* Splices a node's slot, param and prim may lag behind (the log below, a
 * ring): a splice then renumbers no node of the model. Each splice brings
 * a share of the pool up to date (BC__SWEEP of it, splice.c), so that no
 * node lags more than about 2 * BC__SWEEP splices, well within the ring.
 * A full pass once per ring's worth of splices cost one edit in 32 some
 * 40 ms at 700 000 nodes; the share costs each about 1 ms. */
#define BC__SHIFTS 128u
#define BC__SWEEP 32u

struct bc_tree {
	struct bc__node *pool;
	/* Layout places of the pool's nodes, cap of them; NULL in a bare
	 * tree. */
	struct bc__lay *lay;
	uint32_t npool, cap;
	uint32_t free_head; /* chain of dead pool entries through .next */
	/* Parameters past the first and rotations of the primitives that
	 * need them, and unary nodes' parameters (struct bc__prim_room):
	 * chunks of BC__XPAR_FLOATS floats, nxpar of them in use or on the
	 * free chain (through a chunk's first word, from xpar_free), room for
	 * xpar_cap, which pool_reserve keeps at least the pool's (each node
	 * takes one at most); pages of that room nobody writes are not
	 * resident, so a scene of unrotated spheres costs none. */
	float *xpar;
	uint32_t nxpar, xpar_cap, xpar_free;
	struct bc__idmap ids;
	uint32_t root; /* pool index, BC_NONE when empty */
	uint32_t nnodes, nprims, nops;
	/* Unary and domain nodes among the nops: a layout of a tree without
	 * any keeps no per-slot arrays for them (struct bc_lin's wrap). */
	uint32_t nunary_nodes;
	/* Primitives with a colour, and their shape floats in all
	 * (bc_tree_counts). */
	uint32_t ncolored;
	uint64_t nfloats;
	/* Spheres among the nprims: their records are shorter
	 * (bc_prim_record_vec4). */
	uint32_t nspheres;
	uint32_t next_id;

	/* Builder state: the open operators, innermost last (grown on the heap:
	 * depth costs no C stack). */
	uint32_t *open;
	uint32_t nopen, open_cap;
	bool building;

	/* The model's nesting (bc_tree_nesting), kept by every edit whether
	 * or not the tree is laid out. */
	uint32_t nesting;
	/* A bare tree (bc_tree_set_layout) keeps the model alone: has_lin
	 * stays false, and structural edits measure the model (need,
	 * nesting) without splicing or rebuilding any layout. */
	bool bare;
	/* bc_tree_set_names(t, false): names are checked, not kept. */
	bool nameless;
	/* The position indices of a bare tree's wide operators. */
	struct bc__kids *kids;
	uint32_t nkids, kids_cap;
	struct bc_lin lin;
	bool has_lin;
	/* Room of lin's arrays: slots, primitives, records (vec4). */
	uint32_t lin_cap, lin_kcap, lin_pcap;
	/* Splice e is shift[e % BC__SHIFTS]; a node whose epoch is e still
	 * has to follow splices e .. epoch - 1 (unsigned: epoch may wrap,
	 * and 2^32 is a multiple of the ring). sweep: the next pool entry
	 * a splice brings up to date. */
	uint32_t epoch, sweep;
	struct bc__shift shift[BC__SHIFTS];
	struct bc_dirty dirty;

	struct bc__names names;
};

/* A node's id to its pool index. A node whose id is its pool index + 1
 * -- every node of a scene built or loaded in order with ids counted from
 * 1, the usual case, and nodes added after it with fresh ids -- is found
 * at that index and takes no entry in the id map; the map holds the
 * others, and is asked first, so that a replacement's node sharing the id
 * of one still in place wins (free_subtree, remap_ids). A million-node
 * scene kept a 16 MiB map per tree before. */
static inline uint32_t bc__id_find(const struct bc_tree *t, uint32_t id)
{
	uint32_t n = bc__map_find(&t->ids, id);
	if (n == BC_NONE && id != 0 && id - 1u < t->npool &&
	    t->pool[id - 1u].live && t->pool[id - 1u].id == id) {
		n = id - 1u;
	}
	return n;
}
/* Maps id to node n (room reserved with bc__map_reserve). */
static inline void bc__id_put(struct bc_tree *t, uint32_t id, uint32_t n)
{
	if (id - 1u != n || bc__map_find(&t->ids, id) != BC_NONE) {
		bc__map_put_nogrow(&t->ids, id, n);
	}
}
/* Unmaps id (a node found in place needs nothing). */
static inline void bc__id_del(struct bc_tree *t, uint32_t id)
{
	bc__map_del(&t->ids, id);
}

/* Where index v of one space points after a splice; an index into the
 * entries that went lands on `at` (for first[]: the next subtree moves
 * there). */
static inline uint32_t bc__span_map(const struct bc__span *sp, uint32_t v)
{
	if (v < sp->at) {
		return v;
	}
	if (v < sp->at + sp->del) {
		return sp->at;
	}
	return v - sp->del + sp->ins;
}

/* Vec4s of the records of prims primitives of which spheres are spheres
 * (bc_prim_record_vec4). */
static inline uint64_t bc__prim_recs(uint64_t prims, uint64_t spheres)
{
	return BC_PRIM_RECORD_VEC4 * prims -
	       (BC_PRIM_RECORD_VEC4 - BC_SPHERE_RECORD_VEC4) * spheres;
}

/* Entries a layout built whole allocates for n: room for the splices of
 * the first structural edits (splice.c), so that the first one after a
 * load does not grow every array at once. */
static inline size_t bc__lin_room(size_t n)
{
	return n ? n + n / 32u + 64u : 0u;
}

/* Widens the dirty range [*lo, *hi) to hold [a, b). */
static inline void bc__dirty_range(uint32_t *lo, uint32_t *hi, uint32_t a,
                                   uint32_t b)
{
	if (*lo == *hi) {
		*lo = a;
		*hi = b;
		return;
	}
	if (a < *lo) {
		*lo = a;
	}
	if (b > *hi) {
		*hi = b;
	}
}

/* Index v of space i (0 slots, 1 records, 2 primitives), stored as of
 * splice `epoch`, as of now. */
static inline uint32_t bc__follow(const struct bc_tree *t, uint32_t v,
                                  uint32_t epoch, int i)
{
	for (uint32_t e = epoch; e != t->epoch; e++) {
		const struct bc__shift *sh = &t->shift[e % BC__SHIFTS];
		v = bc__span_map(i == 0 ? &sh->s : i == 1 ? &sh->p : &sh->k, v);
	}
	return v;
}

/* The layout place of pool node n (of a tree that is not bare), as
 * stored: read it through bc__slot and the like, or after bc__refresh. */
static inline struct bc__lay *bc__lay(const struct bc_tree *t,
                                      const struct bc__node *n)
{
	return &t->lay[n - t->pool];
}

/* The splice a layout place has followed up to (its epoch byte: it lags
 * fewer than BC__SHIFTS <= 256 splices), and the marks that it follows
 * every splice so far and that its primitive index is k. */
_Static_assert(BC__SHIFTS <= 256u, "a place's epoch byte tells its lag");
static inline uint32_t bc__lay_epoch(const struct bc_tree *t,
                                     const struct bc__lay *y)
{
	return t->epoch - ((t->epoch - (uint32_t)y->epoch) & 0xffu);
}
static inline void bc__lay_mark(const struct bc_tree *t, struct bc__lay *y)
{
	y->epoch = t->epoch & 0xffu;
}
static inline void bc__lay_prim(struct bc__lay *y, uint32_t k)
{
	y->prim = k & 0xffffffu;
}

/* Node n's slot, record and primitive index as of now. */
static inline uint32_t bc__slot(const struct bc_tree *t,
                                const struct bc__node *n)
{
	const struct bc__lay *y = bc__lay(t, n);
	return bc__follow(t, y->slot, bc__lay_epoch(t, y), 0);
}
static inline uint32_t bc__param(const struct bc_tree *t,
                                 const struct bc__node *n)
{
	const struct bc__lay *y = bc__lay(t, n);
	return bc__follow(t, y->param, bc__lay_epoch(t, y), 1);
}
static inline uint32_t bc__prim(const struct bc_tree *t,
                                const struct bc__node *n)
{
	const struct bc__lay *y = bc__lay(t, n);
	return bc__follow(t, y->prim, bc__lay_epoch(t, y), 2);
}
/* Brings node n's slot, param and prim up to date, and returns them
 * (which may then be read and written directly). */
static inline struct bc__lay *bc__refresh(struct bc_tree *t,
                                          const struct bc__node *n)
{
	struct bc__lay *y = bc__lay(t, n);
	uint32_t slot = bc__slot(t, n), param = bc__param(t, n);
	bc__lay_prim(y, bc__prim(t, n));
	y->slot = slot;
	y->param = param;
	bc__lay_mark(t, y);
	return y;
}

/* names.c */

void bc__names_free(struct bc__names *nm);
/* Room for `more` names. Returns 0 or BC_ENOMEM. */
int bc__names_reserve(struct bc__names *nm, uint32_t more);
void bc__names_del(struct bc__names *nm, uint32_t id);
/* Drops the names of every node of the subtree at pool node top. */
void bc__names_drop_subtree(struct bc_tree *t, uint32_t top);
/* Gives t the names of sub's nodes whose ids sub chose (a graft keeps
 * those ids), room reserved with bc__names_reserve(sub's count). */
void bc__names_graft(struct bc_tree *t, const struct bc_tree *sub);
/* dst's names become a copy of src's. Returns 0 or BC_ENOMEM. */
int bc__names_copy(struct bc__names *dst, const struct bc__names *src);
/* Checks a name (1..BC_TREE_NAME_MAX bytes of strict UTF-8 without NUL). */
int bc__name_check(const char *name, size_t len, struct bc_errinfo *ei);

/* tree.c */

/* Measures the subtree at pool node top without recursion: returns its
 * nesting (nodes on its longest path, top counting 1) and sets each node's
 * need (evaluation stack entries of the left-folded post-order). */
uint32_t bc__measure(struct bc_tree *t, uint32_t top);

/* linearize.c */

/* Allocates the arrays of l for nprims primitives (nspheres of them
 * spheres: their records are shorter, and spheres alone keep sphere ABVs
 * alone, struct bc_lin's sabv) and nops operators
 * (binary and unary: room for each to be either); the per-slot arrays of
 * unary and domain nodes (wrap, wrap_top, dom, ucount) only when unary
 * (the tree may have such a node), else they stay NULL; kill counts only
 * when kills (the tree may have an intersection or a difference), r- only
 * when kills or unary (without both, every r- is 0).
 * Returns 0 or BC_ENOMEM (l is then zeroed). */
int bc__lin_alloc(struct bc_lin *l, uint32_t nprims, uint32_t nspheres,
                  uint32_t nops, bool unary, bool kills);
/* Whether operator kind op kills an operand (intersection, difference):
 * a layout with one keeps kill counts (struct bc_lin's kills). */
static inline bool bc__op_kills(enum bc_op op)
{
	return bc_op_class(op) != BC_OPCLASS_UNION;
}
/* Stores primitive k's world ABV (l's abv or, for spheres alone, sabv). */
void bc__lin_set_abv(struct bc_lin *l, uint32_t k, const struct bc_abv *a);
void bc__lin_free(struct bc_lin *l);
/* Fills l (allocated for t's counts) from t's model; cannot fail. */
void bc__lin_fill(struct bc_tree *t, struct bc_lin *l);
/* Where the next emitted slot, primitive, record and unary node go. */
struct bc__fill {
	struct bc_lin *l;
	uint32_t slot, prim, param, unary;
};
/* Emits the subtree at pool node top in post-order from fs on: slots,
 * node words (but top's ancestor), records, colours, and each node's
 * slot, param, prim and unary. */
void bc__lin_emit(struct bc_tree *t, struct bc__fill *fs, uint32_t top);
/* Writes slot o as a fold of operator p (its record at param) over slots
 * left and right. */
void bc__lin_fold(struct bc_lin *l, const struct bc__node *p, uint32_t param,
                  uint32_t left, uint32_t right, uint32_t o);
void bc__lin_set_parent(struct bc_lin *l, uint32_t child, uint32_t parent,
                        bool left);
/* Slot s's ROI, kill and value counts, depth, fast and jump pointers from
 * its parent's (which must be final). */
void bc__lin_link(struct bc_lin *l, uint32_t s);
/* The two halves of bc__lin_link: ROI, kill and value counts and domain
 * node; depth, fast and jump pointers. */
void bc__lin_propagate(struct bc_lin *l, uint32_t s);
void bc__lin_pointers(struct bc_lin *l, uint32_t s);
/* bc__lin_pointers of slots top down to lo (top's parent final). */
void bc__lin_pointers_down(struct bc_lin *l, uint32_t lo, uint32_t top);
/* Places primitive k's ABV (its slot's ROI known) and grows l's box. */
void bc__lin_place_abv(struct bc_tree *t, struct bc_lin *l, uint32_t k,
                       const struct bc_prim_data *p);
void bc__lin_update_size(struct bc_lin *l);

/* splice.c: structural edits of a layout without unary nodes, in place
 * (the file's comment). */

/* Room in t->lin's arrays for count slots, nprims primitives and nparam
 * records; others: primitives other than spheres come (a layout of
 * spheres alone keeps whole ABVs from then on); kills: an intersection or
 * a difference comes (a layout without kill counts gets them, all 0 so
 * far). Returns 0 or BC_ENOMEM (the arrays as they were, some maybe
 * larger). */
int bc__splice_reserve(struct bc_tree *t, uint32_t count, uint32_t nprims,
                       uint32_t nparam, bool others, bool kills);
/* Gives t->lin kill counts and r- (struct bc_lin's kills, roi_lo), all 0
 * (a layout without them, about to take an intersection or a
 * difference). Returns 0 or BC_ENOMEM. */
int bc__lin_want_kills(struct bc_tree *t);
/* Pool node m, with px primitives, records of rx vec4 in all and no unary
 * node, was just linked under a binary operator: splices it into t->lin
 * (room reserved). Returns whether the box must be measured again. */
bool bc__splice_insert(struct bc_tree *t, uint32_t m, uint32_t px, uint32_t rx);
/* Pool node c (not the root) is about to be cut: splices it, and its
 * parent when that is left with one child, out of t->lin. Returns whether
 * the box must be measured again. */
bool bc__splice_remove(struct bc_tree *t, uint32_t c);
/* Where a subtree's layout lies: its slots [first, top] (top's node word
 * word), records [param, pend), primitives [k, k + nprims), and whether
 * one of their ABVs touches the box. */
struct bc__block {
	uint32_t first, top, word, param, pend, k, nprims;
	bool touch;
};
/* Notes where pool node c's subtree lies. */
void bc__splice_note(struct bc_tree *t, uint32_t c, struct bc__block *b);
/* Pool node m (px primitives, records of rx vec4, no unary node) took the
 * place of the subtree noted in b: splices it in there (room reserved).
 * Returns whether the box must be measured again. */
bool bc__splice_replace(struct bc_tree *t, const struct bc__block *b,
                        uint32_t m, uint32_t px, uint32_t rx);
/* After any of these, the model final: the box (measured again when touch), the
 * stack (the root's need), the dirty state. */
void bc__splice_finish(struct bc_tree *t, bool touch);
/* Rewrites primitive n's parameter record, colour and ABV in t->lin. */
void bc__lin_update_prim(struct bc_tree *t, const struct bc__node *n);
/* Rewrites operator n's node words and record, then the ROIs, kill counts
 * and ABVs of its subtree. */
void bc__lin_update_op(struct bc_tree *t, const struct bc__node *n);
/* Rewrites unary node n's record, then the ROIs and ABVs of its subtree and
 * the domain nodes' Lipschitz bounds. */
void bc__lin_update_unary(struct bc_tree *t, const struct bc__node *n);
/* Is primitive n under a twist or bend (whose bounds its ABV feeds)? */
bool bc__lin_prim_bends(const struct bc_tree *t, const struct bc__node *n);
/* Transforms a local bounding shape by p's rigid transform and offsets it. */
void bc__abv_place(const struct bc_prim_data *p, float offset,
                   struct bc_abv *abv);
/* The rules the layout and bc_tree_node_box share (paper eq. 13-16 and
 * docs/scene-format.md): the ROI [lo, hi] of an operand of operator op
 * (smooth range ro, 0 for a sharp one; left: the first operand) from the
 * operator's; the ROI a unary node of kind (record rec) gives its child
 * from its own; a unary node's record from its model node. */
void bc__roi_operand(enum bc_op op, float ro, bool left, float *lo, float *hi);
void bc__roi_unary(enum bc_op kind, const float *rec, float *lo, float *hi);
void bc__unary_record(float *rec, const struct bc_tree *t,
                      const struct bc__node *n);
/* Maps a bounding shape from a domain node's child frame to its input
 * frame (kind, record rec): a shape holding every point whose mapped
 * point lies in the given one. Returns the radius about the axis for
 * twist and bend, 0 otherwise (linearize.c says how). */
float bc__abv_preimage(enum bc_op kind, const float *rec, struct bc_abv *abv);

#endif
