/*
 * Marching tetrahedra over a uniform grid, visited through an octree of
 * regions:
 *
 *  - a region keeps the primitives whose ABVs meet it (its parent's list,
 *    filtered), and is dropped when none does (the field is +inf there)
 *    or when the field at its centre, through the pruned view of its
 *    primitives, exceeds the Lipschitz bound times its half diagonal (no
 *    sign change inside);
 *  - a region of BLOCK cells a side evaluates its grid corners through its
 *    view and splits every cell whose corners differ in sign into the six
 *    tetrahedra of the Kuhn (Freudenthal) triangulation, which tile space
 *    with the same edges and faces seen from every cell; each tetrahedron
 *    whose corners differ in sign gets the zero set of the linear
 *    interpolation of its corner values, one triangle or a quad of two.
 *
 * The mesh's vertices lie on the tetrahedra's edges (a hash from grid
 * edge to vertex, so each is made once), strictly inside them. A segment
 * of the surface on a tetrahedron face is shared by exactly the two
 * tetrahedra on either side of that face, and a quad's diagonal by its two
 * triangles: every edge of the mesh is used by exactly two triangles, in
 * opposite directions. The pruned view has the sign of the full field
 * everywhere in its region (blobtree's sparse evaluation), so the blocks
 * agree on the sign of every corner they share. Corners on the box's
 * boundary count as outside, so a solid cut by the box is closed along
 * its faces; a zero value counts as outside. docs/mesh.md has the
 * argument in full.
 */
#include "blobcast/mesh.h"
#include "mesh_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"

/* Cells a side of a leaf region: 16^3 cells, 17^3 corner samples. */
#define BLOCK 16u
#define SIDE (BLOCK + 1u)
/* The blobtree field's Lipschitz bound (docs/architecture.md: the tracers
 * step by it). */
#define LIPSCHITZ 1.45f
/* Edges shorter than this many cells are collapsed (mesh_collapse.c), in
 * at most this many passes (a pass leaves the neighbours of each collapse
 * for the next; eight about halve the triangle count). */
#define COLLAPSE 0.5f
#define PASSES 8

/* ---- cell -> vertex hash ------------------------------------------------- */

struct vmap {
	uint64_t *key; /* cell index + 1, 0 empty */
	uint32_t *val;
	size_t cap, n;
};

static uint64_t hash64(uint64_t x)
{
	x ^= x >> 33;
	x *= 0xff51afd7ed558ccdull;
	x ^= x >> 33;
	x *= 0xc4ceb9fe1a85ec53ull;
	return x ^ (x >> 33);
}

static int vmap_grow(struct vmap *m)
{
	size_t cap = m->cap ? 2 * m->cap : 4096;
	uint64_t *k = bc_calloc(cap, sizeof(*k));
	uint32_t *v = bc_calloc(cap, sizeof(*v));
	if (!k || !v) {
		bc_free(k);
		bc_free(v);
		return BC_ENOMEM;
	}
	for (size_t i = 0; i < m->cap; i++) {
		if (m->key[i]) {
			size_t j = hash64(m->key[i]) & (cap - 1);
			while (k[j]) {
				j = (j + 1) & (cap - 1);
			}
			k[j] = m->key[i];
			v[j] = m->val[i];
		}
	}
	bc_free(m->key);
	bc_free(m->val);
	m->key = k;
	m->val = v;
	m->cap = cap;
	return 0;
}

/* The slot of cell c: its value when *found, else where to put it. */
static size_t vmap_slot(const struct vmap *m, uint64_t c, bool *found)
{
	uint64_t key = c + 1;
	size_t j = hash64(key) & (m->cap - 1);
	while (m->key[j] && m->key[j] != key) {
		j = (j + 1) & (m->cap - 1);
	}
	*found = m->key[j] == key;
	return j;
}

/* ---- the build ----------------------------------------------------------- */

struct build {
	struct bc_mesh *m;
	const struct bc_lin *l;
	float org[3], cell;
	uint32_t n[3]; /* cells per axis */
	struct vmap map;
	struct bc_view view;
	uint32_t **act; /* active primitive lists, one per octree level */
	float val[SIDE * SIDE * SIDE];
	int32_t base[3]; /* corner index of val[0] */
	uint64_t done_cells, total_cells;
	double share; /* of the progress, the grid's (the rest: collapses) */
	const struct bc_mesh_opts *o;
	uint32_t levels; /* entries of act */
};

static void corner_pos(const struct build *b, int64_t i, int64_t j, int64_t k,
                       float p[3])
{
	p[0] = b->org[0] + (float)i * b->cell;
	p[1] = b->org[1] + (float)j * b->cell;
	p[2] = b->org[2] + (float)k * b->cell;
}

static float eval_view(struct build *b, const float p[3])
{
	b->m->evals++;
	return bc_view_eval(&b->view, b->l, p);
}

static int push_vertex(struct bc_mesh *m, const float p[3],
                       const uint8_t rgb[3], uint32_t *id)
{
	if (m->nverts == m->cap_verts) {
		uint32_t cap = m->cap_verts ? 2 * m->cap_verts : 4096;
		float(*np)[3];
		uint8_t(*nc)[3];
		if (cap < m->cap_verts) {
			return BC_ENOMEM;
		}
		np = bc_realloc(m->pos, (size_t)cap * sizeof(*np));
		if (!np) {
			return BC_ENOMEM;
		}
		m->pos = np;
		nc = bc_realloc(m->rgb, (size_t)cap * sizeof(*nc));
		if (!nc) {
			return BC_ENOMEM;
		}
		m->rgb = nc;
		m->cap_verts = cap;
	}
	memcpy(m->pos[m->nverts], p, sizeof(m->pos[0]));
	memcpy(m->rgb[m->nverts], rgb, sizeof(m->rgb[0]));
	*id = m->nverts++;
	return 0;
}

static int push_tri(struct bc_mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
	if (m->ntris == m->cap_tris) {
		uint32_t cap = m->cap_tris ? 2 * m->cap_tris : 8192;
		uint32_t(*nt)[3];
		if (cap < m->cap_tris) {
			return BC_ENOMEM;
		}
		nt = bc_realloc(m->tri, (size_t)cap * sizeof(*nt));
		if (!nt) {
			return BC_ENOMEM;
		}
		m->tri = nt;
		m->cap_tris = cap;
	}
	m->tri[m->ntris][0] = a;
	m->tri[m->ntris][1] = b;
	m->tri[m->ntris][2] = c;
	m->ntris++;
	return 0;
}

/* Whether grid corner c lies on the box's boundary, where the field counts
 * as outside so that a solid the box cuts is closed. */
static bool on_boundary(const struct build *b, const int64_t c[3])
{
	for (int a = 0; a < 3; a++) {
		if (c[a] <= 0 || c[a] >= (int64_t)b->n[a]) {
			return true;
		}
	}
	return false;
}

/* The corner value at global index (i, j, k), from the block's samples. */
static float cval(const struct build *b, const int64_t c[3])
{
	int64_t x = c[0] - b->base[0], y = c[1] - b->base[1],
	        z = c[2] - b->base[2];
	return b->val[(z * SIDE + y) * SIDE + x];
}

/* Where on an edge a vertex may sit, as a fraction of the edge: never at
 * its ends, so that the vertices of distinct edges are distinct points and
 * no triangle is degenerate (docs/mesh.md). */
#define T_MIN (1.0 / 64.0)

static double clamp_t(double t)
{
	/* NaN (an infinite or undefined field) lands on T_MIN. */
	return t > T_MIN ? (t < 1.0 - T_MIN ? t : 1.0 - T_MIN) : T_MIN;
}

/* The vertex on the grid edge from corner c along dir (bit a: +1 along
 * axis a), whose ends differ in sign; made from the block's samples on
 * first use. It starts where the linear interpolation of the ends' values
 * is zero and takes one false-position step with the field's value there
 * (the sample that also gives its colour), staying strictly inside the
 * edge. */
static int edge_vertex(struct build *b, const int64_t c[3], int dir,
                       uint32_t *id)
{
	uint64_t key =
	    ((uint64_t)c[0] +
	     (uint64_t)(b->n[0] + 1) *
	         ((uint64_t)c[1] + (uint64_t)(b->n[1] + 1) * (uint64_t)c[2])) *
	        8u +
	    (uint64_t)dir;
	int64_t e[3];
	bool found;
	size_t slot;
	double v0, v1, f, t;
	float p[3];
	uint8_t rgb[3] = {178, 178, 178};
	uint32_t prim = BC_NONE;
	bool cap;
	int rc;
	if (2 * (b->map.n + 1) > b->map.cap && (rc = vmap_grow(&b->map))) {
		return rc;
	}
	slot = vmap_slot(&b->map, key, &found);
	if (found) {
		*id = b->map.val[slot];
		return 0;
	}
	for (int a = 0; a < 3; a++) {
		e[a] = c[a] + ((dir >> a) & 1);
	}
	v0 = cval(b, c);
	v1 = cval(b, e);
	/* An edge from the box's boundary (outside by fiat) into the solid:
	 * the cap closing a cut solid, half a cell inside the box. */
	cap = on_boundary(b, c) || on_boundary(b, e);
	t = cap ? 0.5 : clamp_t(v0 / (v0 - v1));
	for (int a = 0; a < 3; a++) {
		p[a] = (float)((double)b->org[a] +
		               ((double)c[a] + t * (double)(e[a] - c[a])) *
		                   (double)b->cell);
	}
	b->m->evals++;
	f = bc_view_eval_id(&b->view, b->l, p, &prim);
	if (!cap && isfinite(f) && f != 0.0) {
		/* The zero lies between p and the end of the other sign. */
		double tf = (f < 0.0) == (v0 < 0.0)
		                ? t + (1.0 - t) * f / (f - v1)
		                : t * v0 / (v0 - f);
		t = clamp_t(tf);
		for (int a = 0; a < 3; a++) {
			p[a] =
			    (float)((double)b->org[a] +
			            ((double)c[a] + t * (double)(e[a] - c[a])) *
			                (double)b->cell);
		}
	}
	if (prim != BC_NONE && prim < b->l->nprims) {
		for (int a = 0; a < 3; a++) {
			float cc = b->l->color[prim][a];
			rgb[a] = (uint8_t)lrintf(255.0f *
			                         fminf(fmaxf(cc, 0.0f), 1.0f));
		}
	}
	if ((rc = push_vertex(b->m, p, rgb, id))) {
		return rc;
	}
	b->map.key[slot] = key + 1;
	b->map.val[slot] = *id;
	b->map.n++;
	return 0;
}

/* The vertex on the edge between corners q[u] and q[w] of a Kuhn
 * tetrahedron: one is the other plus a vector of zeros and ones. */
static int tet_vertex(struct build *b, const int64_t q[4][3], int u, int w,
                      uint32_t *id)
{
	int dir = 0;
	if (q[w][0] + q[w][1] + q[w][2] < q[u][0] + q[u][1] + q[u][2]) {
		int s = u;
		u = w;
		w = s;
	}
	for (int a = 0; a < 3; a++) {
		dir |= (int)(q[w][a] - q[u][a]) << a;
	}
	return edge_vertex(b, q[u], dir, id);
}

static double dist2(const float *p, const float *q)
{
	double d = 0.0;
	for (int a = 0; a < 3; a++) {
		d += ((double)p[a] - q[a]) * ((double)p[a] - q[a]);
	}
	return d;
}

/* Orders of the corners (even permutations of 0..3, so the orientation is
 * kept) that put the negative corner first (one negative), the positive
 * corner first (one positive), or the two negative corners first (two). */
static const uint8_t lone_first[4][4] = {
    {0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
static const uint8_t pair_first[4][4][4] = {
    [0][1] = {0, 1, 2, 3}, [0][2] = {0, 2, 3, 1}, [0][3] = {0, 3, 1, 2},
    [1][2] = {1, 2, 0, 3}, [1][3] = {1, 3, 2, 0}, [2][3] = {2, 3, 0, 1}};

/* The surface in one tetrahedron q[0..4), positively oriented
 * (det(q1 - q0, q2 - q0, q3 - q0) > 0): the zero set of the linear
 * interpolation of its corners' signs, one triangle or one quad (two
 * triangles), counter-clockwise seen from the positive side. */
static int tet(struct build *b, const int64_t q[4][3])
{
	int neg = 0, count = 0, rc;
	uint32_t id[4];
	for (int v = 0; v < 4; v++) {
		if (cval(b, q[v]) < 0.0f) {
			neg |= 1 << v;
			count++;
		}
	}
	if (count == 0 || count == 4) {
		return 0;
	}
	if (count != 2) {
		/* One corner apart: the triangle on its three edges faces away
		 * from it when it is the negative one. */
		int lone = 0;
		const uint8_t *o;
		while (((neg >> lone) & 1) != (count == 1)) {
			lone++;
		}
		o = lone_first[lone];
		for (int k = 1; k < 4; k++) {
			if ((rc = tet_vertex(b, q, o[0], o[k], &id[k - 1]))) {
				return rc;
			}
		}
		return count == 1 ? push_tri(b->m, id[0], id[1], id[2])
		                  : push_tri(b->m, id[0], id[2], id[1]);
	}
	{
		/* Negatives a, b, positives c, d: the quad on edges ac, ad, bd,
		 * bc, split along its shorter diagonal. */
		int lo = 0, hi;
		const uint8_t *o;
		while (!((neg >> lo) & 1)) {
			lo++;
		}
		hi = lo + 1;
		while (!((neg >> hi) & 1)) {
			hi++;
		}
		o = pair_first[lo][hi];
		if ((rc = tet_vertex(b, q, o[0], o[2], &id[0])) ||
		    (rc = tet_vertex(b, q, o[0], o[3], &id[1])) ||
		    (rc = tet_vertex(b, q, o[1], o[3], &id[2])) ||
		    (rc = tet_vertex(b, q, o[1], o[2], &id[3]))) {
			return rc;
		}
		if (dist2(b->m->pos[id[0]], b->m->pos[id[2]]) <=
		    dist2(b->m->pos[id[1]], b->m->pos[id[3]])) {
			if ((rc = push_tri(b->m, id[0], id[1], id[2]))) {
				return rc;
			}
			return push_tri(b->m, id[0], id[2], id[3]);
		}
		if ((rc = push_tri(b->m, id[0], id[1], id[3]))) {
			return rc;
		}
		return push_tri(b->m, id[1], id[2], id[3]);
	}
}

/* The six Kuhn tetrahedra of a cell: corner 0 to the opposite corner
 * along the axes in the order of a permutation; odd permutations have
 * their middle corners swapped to keep the orientation positive. */
static const uint8_t kuhn[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                   {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};

/* A leaf region: cells [c0, c0 + BLOCK) clipped to the grid; inside: known
 * to lie inside the solid (only its corners on the box's boundary are
 * outside). */
static int leaf(struct build *b, const uint32_t c0[3], bool inside)
{
	uint32_t c1[3];
	int rc;
	for (int a = 0; a < 3; a++) {
		c1[a] = c0[a] + BLOCK < b->n[a] ? c0[a] + BLOCK : b->n[a];
		b->base[a] = (int32_t)c0[a];
	}
	/* Corners c0 .. c1: those of the block's cells. */
	for (int64_t k = c0[2]; k <= (int64_t)c1[2]; k++) {
		for (int64_t j = c0[1]; j <= (int64_t)c1[1]; j++) {
			for (int64_t i = c0[0]; i <= (int64_t)c1[0]; i++) {
				int64_t g[3] = {i, j, k};
				float p[3], v;
				size_t at = (size_t)(((k - b->base[2]) * SIDE +
				                      (j - b->base[1])) *
				                         SIDE +
				                     (i - b->base[0]));
				if (on_boundary(b, g)) {
					/* The box's faces close the solid. */
					b->val[at] = 1.0f;
					continue;
				}
				if (inside) {
					b->val[at] = -1.0f;
					continue;
				}
				corner_pos(b, i, j, k, p);
				v = eval_view(b, p);
				/* Zero counts as outside; NaN too (v < 0
				 * is false). */
				b->val[at] = v == 0.0f ? 1e-30f : v;
			}
		}
	}
	for (int64_t k = c0[2]; k < (int64_t)c1[2]; k++) {
		for (int64_t j = c0[1]; j < (int64_t)c1[1]; j++) {
			for (int64_t i = c0[0]; i < (int64_t)c1[0]; i++) {
				bool any_neg = false, any_pos = false;
				for (int v = 0; v < 8; v++) {
					int64_t c[3] = {i + (v & 1),
					                j + ((v >> 1) & 1),
					                k + (v >> 2)};
					bool n = cval(b, c) < 0.0f;
					any_neg |= n;
					any_pos |= !n;
				}
				if (!any_neg || !any_pos) {
					continue;
				}
				for (int s = 0; s < 6; s++) {
					int64_t q[4][3];
					q[0][0] = i;
					q[0][1] = j;
					q[0][2] = k;
					memcpy(q[1], q[0], sizeof(q[0]));
					q[1][kuhn[s][0]]++;
					memcpy(q[2], q[1], sizeof(q[0]));
					q[2][kuhn[s][1]]++;
					memcpy(q[3], q[2], sizeof(q[0]));
					q[3][kuhn[s][2]]++;
					if (s >= 3) {
						int64_t t[3];
						memcpy(t, q[1], sizeof(t));
						memcpy(q[1], q[2], sizeof(t));
						memcpy(q[2], t, sizeof(t));
					}
					if ((rc = tet(b, q))) {
						return rc;
					}
				}
			}
		}
	}
	return 0;
}

static void region_box(const struct build *b, const uint32_t c0[3],
                       const uint32_t c1[3], float lo[3], float hi[3])
{
	for (int a = 0; a < 3; a++) {
		/* Every sample of a leaf (its corners, its edges' points)
		 * lies in the closed box of its cells. */
		lo[a] = b->org[a] + (float)c0[a] * b->cell;
		hi[a] = b->org[a] + (float)c1[a] * b->cell;
	}
}

/* Whether the caller asks the build to stop (opts->stop). */
static bool stop_asked(const struct build *b)
{
	return b->o && b->o->stop && b->o->stop(b->o->ctx);
}

/* Counts cells done: BC_ECLOSED when the caller asks the build to stop. */
static int progress(struct build *b, uint64_t cells)
{
	b->done_cells += cells;
	if (b->o && b->o->progress) {
		b->o->progress(b->o->ctx, b->share * (double)b->done_cells /
		                              (double)b->total_cells);
	}
	return stop_asked(b) ? BC_ECLOSED : 0;
}

/* Whether region cells [c0, c1) reach the box's boundary. */
static bool touches_boundary(const struct build *b, const uint32_t c0[3],
                             const uint32_t c1[3])
{
	for (int a = 0; a < 3; a++) {
		if (c0[a] == 0 || c1[a] == b->n[a]) {
			return true;
		}
	}
	return false;
}

static bool collapse_progress(void *ctx, double done)
{
	struct build *b = ctx;
	if (b->o && b->o->progress) {
		b->o->progress(b->o->ctx, b->share + (1.0 - b->share) * done);
	}
	return stop_asked(b);
}

/* Region cells [c0, c1), primitives b->act[depth][0..n). inside: an
 * ancestor found the field negative all over it and built b->view; only
 * the cap along the box's faces is left to make. */
static int region(struct build *b, const uint32_t c0[3], const uint32_t c1[3],
                  uint32_t depth, uint32_t n, bool inside)
{
	float lo[3], hi[3], c[3], r = 0.0f, f;
	const uint32_t *act = b->act[depth];
	uint32_t side = 0;
	int rc;
	uint64_t cells =
	    (uint64_t)(c1[0] - c0[0]) * (c1[1] - c0[1]) * (c1[2] - c0[2]);
	if (inside && !touches_boundary(b, c0, c1)) {
		return progress(b, cells); /* inside, away from the faces */
	}
	if (n == 0 && !inside) {
		return progress(b, cells); /* nothing reaches: outside */
	}
	region_box(b, c0, c1, lo, hi);
	for (int a = 0; a < 3; a++) {
		c[a] = 0.5f * (lo[a] + hi[a]);
		r += 0.25f * (hi[a] - lo[a]) * (hi[a] - lo[a]);
		side = c1[a] - c0[a] > side ? c1[a] - c0[a] : side;
	}
	r = sqrtf(r);
	if (!inside) {
		if ((rc = bc_view_build(&b->view, b->l, act, n))) {
			return rc;
		}
		f = eval_view(b, c);
		if (fabsf(f) >
		    LIPSCHITZ * b->l->lip * r * 1.001f + 1e-6f * b->cell) {
			/* No sign change in the region. Outside, or inside
			 * away from the box's faces: nothing to make. Inside
			 * against them: the cap, from the known sign (this
			 * view gives the colours). */
			if (!(f < 0.0f) || !touches_boundary(b, c0, c1)) {
				return progress(b, cells);
			}
			inside = true;
		}
	}
	if (side <= BLOCK || depth + 1 >= b->levels) {
		if (side > BLOCK) {
			return BC_ELIMIT; /* levels counts every halving */
		}
		b->m->cells_visited += cells;
		if ((rc = leaf(b, c0, inside))) {
			return rc;
		}
		return progress(b, cells);
	}
	/* Eight children, halving the longest sides (multiples of BLOCK). */
	{
		uint32_t mid[3];
		for (int a = 0; a < 3; a++) {
			uint32_t len = c1[a] - c0[a];
			uint32_t half = (len / 2 + BLOCK - 1) / BLOCK * BLOCK;
			mid[a] =
			    len > BLOCK && half < len ? c0[a] + half : c1[a];
		}
		for (int q = 0; q < 8; q++) {
			uint32_t d0[3], d1[3], m2 = 0;
			float clo[3], chi[3];
			bool empty = false;
			for (int a = 0; a < 3; a++) {
				bool up = (q >> a) & 1;
				d0[a] = up ? mid[a] : c0[a];
				d1[a] = up ? c1[a] : mid[a];
				empty |= d0[a] >= d1[a];
			}
			if (empty) {
				continue;
			}
			region_box(b, d0, d1, clo, chi);
			for (uint32_t i = 0; i < n && !inside; i++) {
				struct bc_abv abv = bc_lin_abv(b->l, act[i]);
				if (bc_abv_meets_box(&abv, clo, chi)) {
					b->act[depth + 1][m2++] = act[i];
				}
			}
			if ((rc = region(b, d0, d1, depth + 1, m2, inside))) {
				return rc;
			}
		}
	}
	return 0;
}

int bc_mesh_build(struct bc_mesh *m, const struct bc_tree *t,
                  const struct bc_mesh_opts *opts, struct bc_errinfo *ei)
{
	struct build b;
	const struct bc_lin *l = t ? bc_tree_lin(t) : NULL;
	uint32_t res = opts && opts->resolution ? opts->resolution
	                                        : BC_MESH_DEFAULT_RESOLUTION;
	float lo[3], hi[3], longest = 0.0f;
	uint32_t levels = 1, zero[3] = {0, 0, 0};
	bool given = false;
	int rc = 0;
	memset(m, 0, sizeof(*m));
	memset(&b, 0, sizeof(b));
	if (!l || l->nprims == 0) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "mesh: the scene is empty");
	}
	if (res > BC_MESH_MAX_RESOLUTION || res < 2) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "mesh: resolution %u is outside [2, %u]",
		                      res, BC_MESH_MAX_RESOLUTION);
	}
	for (int a = 0; a < 3 && opts; a++) {
		given |= opts->lo[a] != 0.0f || opts->hi[a] != 0.0f;
	}
	if (!given && res < BC_MESH_MIN_SCENE_RESOLUTION) {
		/* The longest side is res - 4 cells of scene and two of
		 * margin at each end: under 5 there is no scene left. */
		return bc_errinfo_set(
		    ei, BC_ERANGE,
		    "mesh: resolution %u leaves no cell for the "
		    "scene inside the box's two-cell margins: "
		    "give %u or more, or a box of its own",
		    res, BC_MESH_MIN_SCENE_RESOLUTION);
	}
	for (int a = 0; a < 3; a++) {
		lo[a] = given ? opts->lo[a] : l->lo[a];
		hi[a] = given ? opts->hi[a] : l->hi[a];
		if (!(hi[a] > lo[a]) || !isfinite(lo[a]) || !isfinite(hi[a])) {
			return bc_errinfo_set(
			    ei, BC_EINVAL,
			    "mesh: the box has no volume along "
			    "axis %d",
			    a);
		}
		longest = fmaxf(longest, hi[a] - lo[a]);
	}
	b.cell = longest / (float)(given ? res : res - 4u);
	for (int a = 0; a < 3; a++) {
		if (!given) {
			/* Two cells of margin: the surface stays off the
			 * box's faces. */
			lo[a] -= 2.0f * b.cell;
			hi[a] += 2.0f * b.cell;
		}
		b.org[a] = lo[a];
		b.n[a] = (uint32_t)ceilf((hi[a] - lo[a]) / b.cell - 1e-4f);
		b.n[a] = b.n[a] < 2 ? 2 : b.n[a];
	}
	b.m = m;
	b.l = l;
	/* The collapses take about as long as the grid, on foams. */
	b.share = opts && opts->raw ? 1.0 : 0.6;
	b.o = opts;
	m->cell = b.cell;
	b.total_cells = (uint64_t)b.n[0] * b.n[1] * b.n[2];
	for (uint32_t s = BLOCK; s < res + 8u * BLOCK; s *= 2) {
		levels++;
	}
	b.levels = levels + 1;
	bc_view_init(&b.view);
	b.act = bc_calloc(levels + 1, sizeof(*b.act));
	rc = b.act ? 0 : BC_ENOMEM;
	for (uint32_t d = 0; rc == 0 && d <= levels; d++) {
		b.act[d] = bc_malloc((size_t)l->nprims * sizeof(uint32_t));
		rc = b.act[d] ? 0 : BC_ENOMEM;
	}
	if (rc == 0) {
		for (uint32_t k = 0; k < l->nprims; k++) {
			b.act[0][k] = k;
		}
		rc = region(&b, zero, b.n, 0, l->nprims, false);
	}
	if (rc == 0 && !(opts && opts->raw)) {
		rc = bc_mesh_collapse_short(m, COLLAPSE * b.cell, PASSES,
		                            collapse_progress, &b);
	}
	if (rc) {
		bc_errinfo_set(ei, rc, "mesh: %s", bc_strerror(rc));
		bc_mesh_finish(m);
	}
	for (uint32_t d = 0; b.act && d <= levels; d++) {
		bc_free(b.act[d]);
	}
	bc_free(b.act);
	bc_free(b.map.key);
	bc_free(b.map.val);
	bc_view_finish(&b.view);
	return rc;
}

void bc_mesh_finish(struct bc_mesh *m)
{
	if (!m) {
		return;
	}
	bc_free(m->pos);
	bc_free(m->rgb);
	bc_free(m->tri);
	memset(m, 0, sizeof(*m));
}
