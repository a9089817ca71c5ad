/*
 * Surface nets over a uniform grid (one vertex per cell the surface
 * crosses, one quad per grid edge whose ends differ in sign, joining the
 * four cells around that edge), visited through an octree of regions:
 *
 *  - a region keeps the primitives whose ABVs meet it (its parent's list,
 *    filtered), and is dropped when none does (the field is +inf there)
 *    or when the field at its centre, through the pruned view of its
 *    primitives, exceeds the Lipschitz bound times its half diagonal (no
 *    sign change inside);
 *  - a region of BLOCK cells a side evaluates its grid corners, one layer
 *    more on the low side, through its view, gives every cell the surface
 *    crosses a vertex (the mean of its edges' interpolated crossings,
 *    moved once along the gradient onto the surface and kept inside the
 *    cell), and emits the quads of the grid edges whose low end it owns.
 *
 * The pruned view has the sign of the full field everywhere in its region
 * (blobtree's sparse evaluation), so every block agrees on the sign at the
 * corners it shares: the quads form a closed surface. A cell's vertex is
 * made once, by whichever block first needs it (a hash from cell to
 * vertex). Corners on the box's boundary count as outside, so a solid cut
 * by the box is closed by its faces. Quads are oriented with the outward
 * side (towards positive field) counter-clockwise, and split into two
 * triangles along the diagonal whose ends are nearer.
 */
#include "blobcast/mesh.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "blobcast/alloc.h"

/* Cells a side of a leaf region: 16^3 cells, 18^3 corner samples. */
#define BLOCK 16u
#define SIDE (BLOCK + 2u)
/* The blobtree field's Lipschitz bound (docs/architecture.md: the tracers
 * step by it). */
#define LIPSCHITZ 1.45f

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

/* The corner value at global index (i, j, k), from the block's samples. */
static float cval(const struct build *b, int64_t i, int64_t j, int64_t k)
{
	int64_t x = i - b->base[0], y = j - b->base[1], z = k - b->base[2];
	return b->val[(z * SIDE + y) * SIDE + x];
}

/* The vertex of cell (i, j, k), made from the block's samples on first
 * use. */
static int cell_vertex(struct build *b, int64_t i, int64_t j, int64_t k,
                       uint32_t *id)
{
	uint64_t c =
	    (uint64_t)i +
	    (uint64_t)b->n[0] * ((uint64_t)j + (uint64_t)b->n[1] * (uint64_t)k);
	bool found;
	size_t slot;
	float v[8], acc[3] = {0, 0, 0}, p[3], g[3], f, gg;
	uint32_t cross = 0;
	uint8_t rgb[3] = {178, 178, 178};
	uint32_t prim = BC_NONE;
	int rc;
	if (2 * (b->map.n + 1) > b->map.cap && (rc = vmap_grow(&b->map))) {
		return rc;
	}
	slot = vmap_slot(&b->map, c, &found);
	if (found) {
		*id = b->map.val[slot];
		return 0;
	}
	for (int q = 0; q < 8; q++) {
		v[q] = cval(b, i + (q & 1), j + ((q >> 1) & 1), k + (q >> 2));
	}
	/* The 12 edges: corners differing in one bit. */
	for (int q = 0; q < 8; q++) {
		for (int bit = 1; bit < 8; bit <<= 1) {
			int r = q | bit;
			float t;
			if (r == q || (v[q] < 0.0f) == (v[r] < 0.0f)) {
				continue;
			}
			t = v[q] / (v[q] - v[r]);
			acc[0] +=
			    (float)(q & 1) + t * (float)((r & 1) - (q & 1));
			acc[1] += (float)((q >> 1) & 1) +
			          t * (float)(((r >> 1) & 1) - ((q >> 1) & 1));
			acc[2] +=
			    (float)(q >> 2) + t * (float)((r >> 2) - (q >> 2));
			cross++;
		}
	}
	corner_pos(b, i, j, k, p);
	for (int a = 0; a < 3; a++) {
		p[a] += b->cell * (cross ? acc[a] / (float)cross : 0.5f);
	}
	/* One step along the gradient onto the surface, kept in the cell
	 * (a cell holding a sharp edge keeps its mean point instead of
	 * being pulled onto one face far away). */
	f = eval_view(b, p);
	{
		float h = 0.25f * b->cell;
		for (int a = 0; a < 3; a++) {
			float q1[3] = {p[0], p[1], p[2]},
			      q2[3] = {p[0], p[1], p[2]};
			q1[a] += h;
			q2[a] -= h;
			g[a] =
			    (eval_view(b, q1) - eval_view(b, q2)) / (2.0f * h);
		}
	}
	gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
	if (gg > 0.25f && isfinite(f)) {
		float lo[3], q[3];
		corner_pos(b, i, j, k, lo);
		for (int a = 0; a < 3; a++) {
			q[a] = p[a] - f * g[a] / gg;
			q[a] = fminf(fmaxf(q[a], lo[a]), lo[a] + b->cell);
		}
		memcpy(p, q, sizeof(p));
	}
	b->m->evals++;
	(void)bc_view_eval_id(&b->view, b->l, p, &prim);
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
	b->map.key[slot] = c + 1;
	b->map.val[slot] = *id;
	b->map.n++;
	return 0;
}

/* A leaf region: cells [c0, c0 + BLOCK) clipped to the grid. */
static int leaf(struct build *b, const uint32_t c0[3])
{
	uint32_t c1[3];
	int rc;
	for (int a = 0; a < 3; a++) {
		c1[a] = c0[a] + BLOCK < b->n[a] ? c0[a] + BLOCK : b->n[a];
		b->base[a] = (int32_t)c0[a] - 1;
	}
	/* Corners base .. c1 (one layer below the block for the cells on its
	 * low side that its edges need). */
	for (int64_t k = b->base[2]; k <= (int64_t)c1[2]; k++) {
		for (int64_t j = b->base[1]; j <= (int64_t)c1[1]; j++) {
			for (int64_t i = b->base[0]; i <= (int64_t)c1[0]; i++) {
				float p[3], v;
				size_t at = (size_t)(((k - b->base[2]) * SIDE +
				                      (j - b->base[1])) *
				                         SIDE +
				                     (i - b->base[0]));
				bool edge = i <= 0 || j <= 0 || k <= 0 ||
				            i >= b->n[0] || j >= b->n[1] ||
				            k >= b->n[2];
				if (edge) {
					/* The box's faces close the solid. */
					b->val[at] = 1.0f;
					continue;
				}
				corner_pos(b, i, j, k, p);
				v = eval_view(b, p);
				b->val[at] = v == 0.0f ? 1e-30f : v;
			}
		}
	}
	/* Edges from corner (i, j, k) along axis a, owned by this block when
	 * the corner is one of its own (index in [c0, c1)); the four cells
	 * around it lie in the block or the layer below. */
	for (int64_t k = c0[2]; k < (int64_t)c1[2] + 1; k++) {
		for (int64_t j = c0[1]; j < (int64_t)c1[1] + 1; j++) {
			for (int64_t i = c0[0]; i < (int64_t)c1[0] + 1; i++) {
				int64_t at[3] = {i, j, k};
				bool own = true;
				for (int a = 0; a < 3; a++) {
					/* The block's last corner layer
					 * belongs to the next block, except
					 * at the grid's end. */
					own &= at[a] < (int64_t)c1[a] ||
					       c1[a] == b->n[a];
				}
				if (!own) {
					continue;
				}
				for (int a = 0; a < 3; a++) {
					int u = (a + 1) % 3, w = (a + 2) % 3;
					int64_t e[3] = {i, j, k};
					float v0, v1;
					uint32_t id[4];
					e[a]++;
					if (e[a] > (int64_t)b->n[a] ||
					    at[u] < 1 || at[w] < 1 ||
					    at[u] >= b->n[u] ||
					    at[w] >= b->n[w]) {
						continue;
					}
					v0 = cval(b, i, j, k);
					v1 = cval(b, e[0], e[1], e[2]);
					if ((v0 < 0.0f) == (v1 < 0.0f)) {
						continue;
					}
					/* Cells around the edge, counter-
					 * clockwise about +a. */
					for (int q = 0; q < 4; q++) {
						int64_t cc[3] = {i, j, k};
						cc[u] -= (q == 0 || q == 3);
						cc[w] -= (q == 0 || q == 1);
						if ((rc = cell_vertex(
						         b, cc[0], cc[1], cc[2],
						         &id[q]))) {
							return rc;
						}
					}
					if (!(v0 < 0.0f)) {
						/* Inside towards -a: flip. */
						uint32_t s = id[1];
						id[1] = id[3];
						id[3] = s;
					}
					{
						const float
						    *p0 = b->m->pos[id[0]],
						    *p1 = b->m->pos[id[1]],
						    *p2 = b->m->pos[id[2]],
						    *p3 = b->m->pos[id[3]];
						float d02 = 0, d13 = 0;
						for (int x = 0; x < 3; x++) {
							d02 += (p0[x] - p2[x]) *
							       (p0[x] - p2[x]);
							d13 += (p1[x] - p3[x]) *
							       (p1[x] - p3[x]);
						}
						if (d02 <= d13) {
							rc = push_tri(
							    b->m, id[0], id[1],
							    id[2]);
							if (!rc) {
								rc = push_tri(
								    b->m, id[0],
								    id[2],
								    id[3]);
							}
						} else {
							rc = push_tri(
							    b->m, id[0], id[1],
							    id[3]);
							if (!rc) {
								rc = push_tri(
								    b->m, id[1],
								    id[2],
								    id[3]);
							}
						}
						if (rc) {
							return rc;
						}
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
		/* One cell more below (the leaf samples that layer too) and
		 * above (a vertex's gradient samples reach past its cell). */
		lo[a] = b->org[a] + ((float)c0[a] - 1.0f) * b->cell;
		hi[a] = b->org[a] + ((float)c1[a] + 1.0f) * b->cell;
	}
}

static void progress(struct build *b, uint64_t cells)
{
	b->done_cells += cells;
	if (b->o && b->o->progress) {
		b->o->progress(b->o->ctx,
		               (double)b->done_cells / (double)b->total_cells);
	}
}

/* Region cells [c0, c1), primitives b->act[depth][0..n). */
static int region(struct build *b, const uint32_t c0[3], const uint32_t c1[3],
                  uint32_t depth, uint32_t n)
{
	float lo[3], hi[3], c[3], r = 0.0f, f;
	const uint32_t *act = b->act[depth];
	uint32_t side = 0;
	int rc;
	uint64_t cells =
	    (uint64_t)(c1[0] - c0[0]) * (c1[1] - c0[1]) * (c1[2] - c0[2]);
	if (n == 0) {
		progress(b, cells);
		return 0; /* nothing reaches here: +inf, outside */
	}
	region_box(b, c0, c1, lo, hi);
	for (int a = 0; a < 3; a++) {
		c[a] = 0.5f * (lo[a] + hi[a]);
		r += 0.25f * (hi[a] - lo[a]) * (hi[a] - lo[a]);
		side = c1[a] - c0[a] > side ? c1[a] - c0[a] : side;
	}
	r = sqrtf(r);
	if ((rc = bc_view_build(&b->view, b->l, act, n))) {
		return rc;
	}
	f = eval_view(b, c);
	if (fabsf(f) > LIPSCHITZ * b->l->lip * r * 1.001f + 1e-6f * b->cell) {
		progress(b, cells);
		return 0; /* no sign change in the region */
	}
	if (side <= BLOCK || depth + 1 >= b->levels) {
		if (side > BLOCK) {
			return BC_ELIMIT; /* levels counts every halving */
		}
		b->m->cells_visited += cells;
		rc = leaf(b, c0);
		progress(b, cells);
		return rc;
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
			for (uint32_t i = 0; i < n; i++) {
				if (bc_abv_meets_box(&b->l->abv[act[i]], clo,
				                     chi)) {
					b->act[depth + 1][m2++] = act[i];
				}
			}
			if ((rc = region(b, d0, d1, depth + 1, m2))) {
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
		rc = region(&b, zero, b.n, 0, l->nprims);
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

/* ---- writers ------------------------------------------------------------- */

enum bc_mesh_format bc_mesh_format_of(const char *path)
{
	const char *dot = path ? strrchr(path, '.') : NULL;
	if (!dot) {
		return BC_MESH_FORMAT_INVALID;
	}
	if (strcasecmp(dot, ".obj") == 0) {
		return BC_MESH_FORMAT_OBJ;
	}
	if (strcasecmp(dot, ".ply") == 0) {
		return BC_MESH_FORMAT_PLY;
	}
	if (strcasecmp(dot, ".stl") == 0) {
		return BC_MESH_FORMAT_STL;
	}
	return BC_MESH_FORMAT_INVALID;
}

static void put_f32(FILE *f, float v)
{
	uint32_t u;
	uint8_t b[4];
	memcpy(&u, &v, 4);
	for (int i = 0; i < 4; i++) {
		b[i] = (uint8_t)(u >> (8 * i));
	}
	fwrite(b, 1, 4, f);
}

static void put_u32(FILE *f, uint32_t u)
{
	uint8_t b[4];
	for (int i = 0; i < 4; i++) {
		b[i] = (uint8_t)(u >> (8 * i));
	}
	fwrite(b, 1, 4, f);
}

static void write_body(const struct bc_mesh *m, FILE *f,
                       enum bc_mesh_format fmt)
{
	switch (fmt) {
	case BC_MESH_FORMAT_OBJ:
		fprintf(f, "# blobcast mesh: %u vertices, %u triangles\n",
		        m->nverts, m->ntris);
		for (uint32_t i = 0; i < m->nverts; i++) {
			fprintf(f, "v %.9g %.9g %.9g %.4g %.4g %.4g\n",
			        (double)m->pos[i][0], (double)m->pos[i][1],
			        (double)m->pos[i][2], m->rgb[i][0] / 255.0,
			        m->rgb[i][1] / 255.0, m->rgb[i][2] / 255.0);
		}
		for (uint32_t i = 0; i < m->ntris; i++) {
			fprintf(f, "f %u %u %u\n", m->tri[i][0] + 1,
			        m->tri[i][1] + 1, m->tri[i][2] + 1);
		}
		break;
	case BC_MESH_FORMAT_PLY:
		fprintf(
		    f,
		    "ply\nformat binary_little_endian 1.0\n"
		    "comment blobcast mesh\n"
		    "element vertex %u\nproperty float x\nproperty float y\n"
		    "property float z\nproperty uchar red\n"
		    "property uchar green\nproperty uchar blue\n"
		    "element face %u\nproperty list uchar uint "
		    "vertex_indices\nend_header\n",
		    m->nverts, m->ntris);
		for (uint32_t i = 0; i < m->nverts; i++) {
			for (int a = 0; a < 3; a++) {
				put_f32(f, m->pos[i][a]);
			}
			fwrite(m->rgb[i], 1, 3, f);
		}
		for (uint32_t i = 0; i < m->ntris; i++) {
			fputc(3, f);
			for (int a = 0; a < 3; a++) {
				put_u32(f, m->tri[i][a]);
			}
		}
		break;
	default: { /* STL */
		char head[80];
		memset(head, 0, sizeof(head));
		snprintf(head, sizeof(head), "blobcast mesh");
		fwrite(head, 1, sizeof(head), f);
		put_u32(f, m->ntris);
		for (uint32_t i = 0; i < m->ntris; i++) {
			const float *a = m->pos[m->tri[i][0]],
			            *b = m->pos[m->tri[i][1]],
			            *c = m->pos[m->tri[i][2]];
			float u[3], v[3], n[3], len;
			for (int x = 0; x < 3; x++) {
				u[x] = b[x] - a[x];
				v[x] = c[x] - a[x];
			}
			n[0] = u[1] * v[2] - u[2] * v[1];
			n[1] = u[2] * v[0] - u[0] * v[2];
			n[2] = u[0] * v[1] - u[1] * v[0];
			len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
			for (int x = 0; x < 3; x++) {
				put_f32(f, len > 0.0f ? n[x] / len : 0.0f);
			}
			for (int x = 0; x < 3; x++) {
				put_f32(f, a[x]);
			}
			for (int x = 0; x < 3; x++) {
				put_f32(f, b[x]);
			}
			for (int x = 0; x < 3; x++) {
				put_f32(f, c[x]);
			}
			fputc(0, f);
			fputc(0, f);
		}
		break;
	}
	}
}

int bc_mesh_write(const struct bc_mesh *m, const char *path,
                  enum bc_mesh_format format, struct bc_errinfo *ei)
{
	size_t plen = path ? strlen(path) : 0;
	char *tmp;
	FILE *f;
	int rc = 0;
	if (format <= BC_MESH_FORMAT_INVALID ||
	    format >= BC_MESH_FORMAT_COUNT) {
		return bc_errinfo_set(ei, BC_EINVAL, "mesh: unknown format");
	}
	if (!path || !plen) {
		return bc_errinfo_set(ei, BC_EINVAL, "mesh: no file name");
	}
	tmp = bc_malloc(plen + 48);
	if (!tmp) {
		return bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	/* Beside the target, so that rename() replaces it in one step. */
	snprintf(tmp, plen + 48, "%s.tmp.%ld", path, (long)getpid());
	f = fopen(tmp, "wb");
	if (!f) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, strerror(errno));
		bc_free(tmp);
		return rc;
	}
	write_body(m, f, format);
	if (fflush(f) != 0 || ferror(f) || fsync(fileno(f)) != 0) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, strerror(errno));
	}
	if (fclose(f) != 0 && rc == 0) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, strerror(errno));
	}
	if (rc == 0 && rename(tmp, path) != 0) {
		rc =
		    bc_errinfo_set(ei, BC_EIO, "%s: %s", path, strerror(errno));
	}
	if (rc) {
		(void)remove(tmp);
	}
	bc_free(tmp);
	return rc;
}
