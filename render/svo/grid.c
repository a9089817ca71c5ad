/*
 * A uniform grid of pruned variants, the setting of the thesis's §6.1
 * (Table 6.1): the tree's box is cut into n^3 equal voxels, each pruned from
 * the full variant, and points are evaluated with their voxel's variant. It
 * measures pruning cost per voxel and evaluation speedup without any
 * hierarchy; the octree (octree.c) is what the renderer uses.
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/clock.h"

struct voxel {
	uint32_t off, npairs, nterms;
	uint8_t state;
	float value;
};

struct bc_svo_grid {
	const struct bc_svo_rpn *rpn;
	uint32_t n;
	float lo[3], step[3];
	struct voxel *vox;
	struct bc__svo_pool pool;
	uint32_t *full;
};

int bc_svo_grid_build(struct bc_svo_grid **out, const struct bc_svo_rpn *rpn,
                      enum bc_range_arith arith, uint32_t n, double *prune_ms)
{
	struct bc_svo_grid *gr;
	struct bc_svo_ranger *g = NULL;
	uint32_t *mask = NULL;
	double ms = 0.0;
	int rc;
	*out = NULL;
	*prune_ms = 0.0;
	if (n == 0 || n > BC_SVO_MAX_GRID) {
		return BC_ERANGE;
	}
	if (!rpn || rpn->n == 0) {
		return BC_EINVAL;
	}
	gr = bc_calloc(1, sizeof(*gr));
	if (!gr) {
		return BC_ENOMEM;
	}
	gr->rpn = rpn;
	gr->n = n;
	for (int i = 0; i < 3; i++) {
		float ext = rpn->hi[i] - rpn->lo[i];
		gr->lo[i] = rpn->lo[i];
		gr->step[i] = ext > 0.0f ? ext / (float)n : 1.0f;
	}
	gr->vox = bc_calloc((size_t)n * n * n, sizeof(*gr->vox));
	gr->full = bc_calloc(rpn->nwords, sizeof(*gr->full));
	mask = bc_calloc(rpn->nwords, sizeof(*mask));
	if (!gr->vox || !gr->full || !mask) {
		rc = BC_ENOMEM;
		goto cleanup;
	}
	if ((rc = bc_svo_ranger_create(&g, rpn, arith))) {
		goto cleanup;
	}
	bc_svo_mask_fill(rpn, gr->full);
	for (uint32_t k = 0; k < n; k++) {
		for (uint32_t j = 0; j < n; j++) {
			for (uint32_t i = 0; i < n; i++) {
				struct voxel *v =
				    &gr->vox[((size_t)k * n + j) * n + i];
				struct bc_svo_region rg;
				struct bc_svo_prune_result res;
				uint32_t ijk[3] = {i, j, k};
				double t0;
				memset(&rg, 0, sizeof(rg));
				for (int a = 0; a < 3; a++) {
					rg.lo[a] = gr->lo[a] +
					           (float)ijk[a] * gr->step[a];
					rg.hi[a] =
					    gr->lo[a] +
					    (float)(ijk[a] + 1) * gr->step[a];
				}
				t0 = bc_clock_ms();
				rc = bc_svo_prune(g, gr->full, mask, &rg, 0.0f,
				                  &res);
				ms += bc_clock_ms() - t0;
				if (rc) {
					goto cleanup;
				}
				v->state = (uint8_t)res.state;
				v->nterms = res.nterms;
				if (res.state == BC_SVO_STATE_ACTIVE) {
					rc = bc__svo_pool_put(
					    &gr->pool, mask, rpn->nwords,
					    &v->off, &v->npairs);
					if (rc) {
						goto cleanup;
					}
				} else {
					v->value = bc__svo_state_value(
					    res.state, res.root);
				}
			}
		}
	}
	*prune_ms = ms;
	rc = 0;
cleanup:
	bc_svo_ranger_destroy(g);
	bc_free(mask);
	if (rc) {
		bc_svo_grid_destroy(gr);
		return rc;
	}
	*out = gr;
	return 0;
}

void bc_svo_grid_destroy(struct bc_svo_grid *gr)
{
	if (!gr) {
		return;
	}
	bc_free(gr->vox);
	bc__svo_pool_finish(&gr->pool);
	bc_free(gr->full);
	bc_free(gr);
}

float bc_svo_grid_eval(const struct bc_svo_grid *gr, const float p[3])
{
	uint32_t c[3];
	const struct voxel *v;
	struct bc_svo_cmask m;
	for (int a = 0; a < 3; a++) {
		float u = (p[a] - gr->lo[a]) / gr->step[a];
		if (!(u >= 0.0f && u <= (float)gr->n)) {
			return bc_svo_rpn_eval(gr->rpn, gr->full, p);
		}
		c[a] = u >= (float)gr->n ? gr->n - 1u : (uint32_t)u;
		/* The division may round p into a neighbour: the voxel must be
		 * the one whose bounds, computed as the build did, hold p. */
		if (c[a] > 0 && p[a] < gr->lo[a] + (float)c[a] * gr->step[a]) {
			c[a]--;
		} else if (c[a] + 1u < gr->n &&
		           p[a] >
		               gr->lo[a] + (float)(c[a] + 1u) * gr->step[a]) {
			c[a]++;
		}
	}
	v = &gr->vox[((size_t)c[2] * gr->n + c[1]) * gr->n + c[0]];
	if (v->state != BC_SVO_STATE_ACTIVE) {
		return v->value;
	}
	m.pairs = gr->pool.v + 2u * (size_t)v->off;
	m.nwords = v->npairs;
	return bc_svo_cmask_eval(gr->rpn, m, p);
}

void bc_svo_grid_stats(const struct bc_svo_grid *gr, double *avg_terms,
                       uint32_t *max_terms, uint64_t *bytes)
{
	size_t nv = (size_t)gr->n * gr->n * gr->n;
	double sum = 0.0;
	uint32_t most = 0;
	for (size_t i = 0; i < nv; i++) {
		sum += gr->vox[i].nterms;
		most = gr->vox[i].nterms > most ? gr->vox[i].nterms : most;
	}
	*avg_terms = nv ? sum / (double)nv : 0.0;
	*max_terms = most;
	*bytes = nv * sizeof(struct voxel) + gr->pool.n * sizeof(uint32_t);
}
