/*
 * Collapsing the short edges of a closed 2-manifold mesh without changing
 * its topology (blobcast/mesh.h, docs/mesh.md). Marching tetrahedra put
 * several vertices close together wherever the surface passes near a grid
 * corner; merging them removes slivers and about half the triangles.
 *
 * An edge (u, v) shared by triangles (u, v, a) and (v, u, b) collapses
 * into u (u keeps its place, v goes) only when
 *  - the link condition holds: the vertices adjacent to both u and v are
 *    exactly a and b (otherwise the collapse would pinch the surface);
 *  - a and b have more than three neighbours (else they would be left
 *    with two, and a tetrahedron would fold flat);
 *  - no triangle that v keeps turns over or becomes (near) flat when v is
 *    moved to u: its normal keeps a positive dot product with its old one
 *    and its area stays above a floor.
 * Under the link condition an edge collapse keeps a closed 2-manifold a
 * closed 2-manifold of the same topology (Dey, Edelsbrunner et al.,
 * "Topology preserving edge contraction", 1999); the orientation of the
 * triangles that remain is untouched. Positions are never moved, so the
 * vertices stay distinct points on the grid edges they were made on.
 *
 * Each pass sorts the candidate edges by length and collapses greedily,
 * freezing the neighbourhood of every collapse for the rest of the pass
 * so that the incidence lists built at its start stay true where they are
 * read; then the arrays are compacted.
 */
#include "mesh_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"

#define DEAD UINT32_MAX

struct cand {
	float len2;
	uint32_t u, v;
};

static int cmp_cand(const void *a, const void *b)
{
	float x = ((const struct cand *)a)->len2,
	      y = ((const struct cand *)b)->len2;
	return (x > y) - (x < y);
}

struct pass {
	struct bc_mesh *m;
	uint32_t *off, *inc;    /* vertex -> incident triangles (CSR) */
	uint32_t *stamp, clock; /* neighbour marks */
	uint8_t *frozen;
	double min_area2; /* floor of |cross|^2 of a kept triangle */
};

/* Whether v's triangles other than those holding u stay well shaped with
 * v moved to u's place. */
static bool moves_ok(const struct pass *p, uint32_t u, uint32_t v)
{
	const struct bc_mesh *m = p->m;
	for (uint32_t k = p->off[v]; k < p->off[v + 1]; k++) {
		const uint32_t *t = m->tri[p->inc[k]];
		const float *q[3];
		double n0[3], n1[3];
		if (t[0] == u || t[1] == u || t[2] == u) {
			continue;
		}
		for (int c = 0; c < 3; c++) {
			q[c] = m->pos[t[c]];
		}
		bc_mesh_cross3(q[0], q[1], q[2], n0);
		for (int c = 0; c < 3; c++) {
			q[c] = m->pos[t[c] == v ? u : t[c]];
		}
		bc_mesh_cross3(q[0], q[1], q[2], n1);
		double d = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
		/* Turned by less than 45 degrees. */
		if (d <= 0.0 ||
		    2.0 * d * d <=
		        (n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]) *
		            (n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]) ||
		    n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2] <=
		        p->min_area2) {
			return false;
		}
	}
	return true;
}

/* Collapses (u, v) into u when the conditions above hold. */
static bool try_collapse(struct pass *p, uint32_t u, uint32_t v)
{
	struct bc_mesh *m = p->m;
	uint32_t shared[2], opp[2], ns = 0, common = 0;
	if (p->frozen[u] || p->frozen[v]) {
		return false;
	}
	/* The two triangles on the edge, and their third vertices. */
	for (uint32_t k = p->off[u]; k < p->off[u + 1]; k++) {
		const uint32_t *t = m->tri[p->inc[k]];
		if (t[0] == v || t[1] == v || t[2] == v) {
			if (ns == 2) {
				return false; /* not a manifold edge */
			}
			shared[ns] = p->inc[k];
			opp[ns++] = t[0] != u && t[0] != v   ? t[0]
			            : t[1] != u && t[1] != v ? t[1]
			                                     : t[2];
		}
	}
	/* The opposite vertices lose a triangle: their lists must be
	 * current (not frozen) to count what they keep. */
	if (ns != 2 || opp[0] == opp[1] || p->frozen[opp[0]] ||
	    p->frozen[opp[1]] || p->off[opp[0] + 1] - p->off[opp[0]] <= 3 ||
	    p->off[opp[1] + 1] - p->off[opp[1]] <= 3) {
		return false;
	}
	/* Link condition: the common neighbours are the two opposites. */
	p->clock++;
	for (uint32_t k = p->off[u]; k < p->off[u + 1]; k++) {
		for (int c = 0; c < 3; c++) {
			p->stamp[m->tri[p->inc[k]][c]] = p->clock;
		}
	}
	for (uint32_t k = p->off[v]; k < p->off[v + 1]; k++) {
		for (int c = 0; c < 3; c++) {
			uint32_t w = m->tri[p->inc[k]][c];
			if (w != u && w != v && p->stamp[w] == p->clock) {
				p->stamp[w] = p->clock - 1; /* count once */
				common++;
				if (w != opp[0] && w != opp[1]) {
					return false;
				}
			}
		}
	}
	if (common != 2 || !moves_ok(p, u, v)) {
		return false;
	}
	/* Apply: the two triangles go, v's others take u, the neighbourhood
	 * freezes for the rest of the pass. */
	for (int s = 0; s < 2; s++) {
		m->tri[shared[s]][0] = DEAD;
	}
	for (uint32_t k = p->off[v]; k < p->off[v + 1]; k++) {
		uint32_t *t = m->tri[p->inc[k]];
		if (t[0] == DEAD) {
			continue;
		}
		for (int c = 0; c < 3; c++) {
			p->frozen[t[c]] = 1;
			t[c] = t[c] == v ? u : t[c];
		}
	}
	for (uint32_t k = p->off[u]; k < p->off[u + 1]; k++) {
		const uint32_t *t = m->tri[p->inc[k]];
		for (int c = 0; c < 3 && t[0] != DEAD; c++) {
			p->frozen[t[c]] = 1;
		}
	}
	p->frozen[u] = p->frozen[v] = 1;
	return true;
}

/* Drops dead triangles and the vertices no triangle uses. */
static void compact(struct bc_mesh *m, uint32_t *map)
{
	uint32_t nt = 0, nv = 0;
	for (uint32_t i = 0; i < m->nverts; i++) {
		map[i] = DEAD;
	}
	for (uint32_t i = 0; i < m->ntris; i++) {
		if (m->tri[i][0] != DEAD) {
			memcpy(m->tri[nt], m->tri[i], sizeof(m->tri[0]));
			for (int c = 0; c < 3; c++) {
				map[m->tri[nt][c]] = 0;
			}
			nt++;
		}
	}
	for (uint32_t i = 0; i < m->nverts; i++) {
		if (map[i] != DEAD) {
			map[i] = nv;
			memmove(m->pos[nv], m->pos[i], sizeof(m->pos[0]));
			memmove(m->rgb[nv], m->rgb[i], sizeof(m->rgb[0]));
			nv++;
		}
	}
	for (uint32_t i = 0; i < nt; i++) {
		for (int c = 0; c < 3; c++) {
			m->tri[i][c] = map[m->tri[i][c]];
		}
	}
	m->ntris = nt;
	m->nverts = nv;
}

int bc_mesh_collapse_short(struct bc_mesh *m, float max_len, int passes,
                           bool (*progress)(void *ctx, double done), void *ctx)
{
	struct pass p = {.m = m};
	struct cand *cand = NULL;
	uint32_t *map = NULL;
	int rc = 0;
	if (m->ntris == 0) {
		return 0;
	}
	p.min_area2 = (double)max_len * max_len * 1e-4;
	p.min_area2 *= p.min_area2;
	p.off = bc_malloc(((size_t)m->nverts + 1) * sizeof(*p.off));
	p.inc = bc_malloc((size_t)m->ntris * 3 * sizeof(*p.inc));
	p.stamp = bc_calloc(m->nverts, sizeof(*p.stamp));
	p.frozen = bc_malloc(m->nverts);
	map = bc_malloc((size_t)m->nverts * sizeof(*map));
	if (!p.off || !p.inc || !p.stamp || !p.frozen || !map) {
		rc = BC_ENOMEM;
		passes = 0;
	}
	for (int pass = 0; pass < passes; pass++) {
		uint32_t nc = 0, done = 0;
		memset(p.off, 0, ((size_t)m->nverts + 1) * sizeof(*p.off));
		memset(p.frozen, 0, m->nverts);
		for (uint32_t i = 0; i < m->ntris; i++) {
			for (int c = 0; c < 3; c++) {
				p.off[m->tri[i][c] + 1]++;
			}
		}
		for (uint32_t i = 0; i < m->nverts; i++) {
			p.off[i + 1] += p.off[i];
		}
		for (uint32_t i = 0; i < m->ntris; i++) {
			for (int c = 0; c < 3; c++) {
				p.inc[p.off[m->tri[i][c]]++] = i;
			}
		}
		for (uint32_t i = m->nverts; i > 0; i--) {
			p.off[i] = p.off[i - 1];
		}
		p.off[0] = 0;
		/* Each edge once: from the triangle where it runs low to high
		 * index (its other triangle runs it the other way). The first
		 * round counts, the second fills. */
		for (int fill = 0; fill < 2; fill++) {
			if (fill) {
				bc_free(cand);
				cand = bc_malloc((size_t)(nc ? nc : 1) *
				                 sizeof(*cand));
				if (!cand) {
					rc = BC_ENOMEM;
					break;
				}
				nc = 0;
			}
			for (uint32_t i = 0; i < m->ntris; i++) {
				for (int c = 0; c < 3; c++) {
					uint32_t a = m->tri[i][c],
					         b = m->tri[i][(c + 1) % 3];
					float d2 = 0.0f;
					for (int x = 0; x < 3; x++) {
						float d =
						    m->pos[a][x] - m->pos[b][x];
						d2 += d * d;
					}
					if (a < b && d2 < max_len * max_len) {
						if (fill) {
							cand[nc] =
							    (struct cand){d2, a,
							                  b};
						}
						nc++;
					}
				}
			}
		}
		if (rc) {
			break;
		}
		qsort(cand, nc, sizeof(*cand), cmp_cand);
		for (uint32_t i = 0; i < nc; i++) {
			done += try_collapse(&p, cand[i].u, cand[i].v) ||
			        try_collapse(&p, cand[i].v, cand[i].u);
		}
		compact(m, map);
		if (progress && progress(ctx, (double)(pass + 1) / passes)) {
			rc = BC_ECLOSED;
			break;
		}
		if (done * 100u < nc || done == 0) {
			break;
		}
	}
	bc_free(p.off);
	bc_free(p.inc);
	bc_free(p.stamp);
	bc_free(p.frozen);
	bc_free(cand);
	bc_free(map);
	return rc;
}
