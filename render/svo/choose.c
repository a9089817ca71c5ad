/*
 * Choosing the pruning arithmetic per scene (docs/svo.md, "IA against
 * RevAA"). A scene of sharp operators over primitives whose RevAA range is
 * their interval extension's prunes the same in both: IA, without a trial.
 * Otherwise a short trial prunes the top levels of the octree with each
 * arithmetic and counts cells and terms per level; the rule compares the
 * terms IA and RevAA keep at the trial's last level, which is what every
 * deeper level evaluates, weighted by what one term costs in each.
 */
#include "svo_impl.h"

#include <math.h>
#include <string.h>

#include "blobcast/alloc.h"

void bc__svo_root_box(const struct bc_svo_rpn *rpn, float band, float lo[3],
                      float hi[3])
{
	/* A cube about the tree's box, grown so the band around the surface
	 * fits and by a little more so surface points on the box are inside.
	 * A cube, not the box: cells of a thin scene's box would be slivers,
	 * every one of them touching the surface. */
	float half = 0.0f;
	for (int i = 0; i < 3; i++) {
		half = fmaxf(half, 0.5f * (rpn->hi[i] - rpn->lo[i]));
	}
	half += band + 1.0e-3f * fmaxf(rpn->size, 1.0e-6f);
	for (int i = 0; i < 3; i++) {
		float c = 0.5f * (rpn->lo[i] + rpn->hi[i]);
		lo[i] = c - half;
		hi[i] = c + half;
	}
}

struct trial {
	struct bc_svo_ranger *g;
	uint32_t *masks; /* one variant per level */
	uint32_t nwords, levels;
	float band;
	struct bc_svo_trial *out;
};

static int visit(struct trial *t, uint32_t level, const uint32_t *mask,
                 uint32_t nin, const float lo[3], const float hi[3])
{
	struct bc_svo_region rg;
	struct bc_svo_prune_result res;
	struct bc_svo_trial_level *lv = &t->out->level[level];
	uint32_t *m = t->masks + (size_t)level * t->nwords;
	int rc;
	memset(&rg, 0, sizeof(rg));
	memcpy(rg.lo, lo, sizeof(rg.lo));
	memcpy(rg.hi, hi, sizeof(rg.hi));
	if ((rc = bc_svo_prune(t->g, mask, m, &rg, t->band, &res))) {
		return rc;
	}
	lv->cells++;
	lv->terms_in += nin;
	lv->terms_out += res.nterms;
	if (res.state != BC_SVO_STATE_ACTIVE) {
		lv->decided++;
		return 0;
	}
	if (level + 1 >= t->levels) {
		return 0;
	}
	for (uint32_t c = 0; c < 8; c++) {
		float clo[3], chi[3];
		for (int i = 0; i < 3; i++) {
			float mid = 0.5f * (lo[i] + hi[i]);
			bool upper = (c >> i) & 1u;
			clo[i] = upper ? mid : lo[i];
			chi[i] = upper ? hi[i] : mid;
		}
		if ((rc = visit(t, level + 1, m, res.nterms, clo, chi))) {
			return rc;
		}
	}
	return 0;
}

int bc_svo_trial_run(const struct bc_svo_rpn *rpn, enum bc_range_arith arith,
                     float band, uint32_t levels, struct bc_svo_trial *out)
{
	struct trial t = {.nwords = rpn->nwords, .band = band, .out = out};
	uint32_t *full;
	float lo[3], hi[3];
	int rc;
	memset(out, 0, sizeof(*out));
	if (levels == 0 || levels > BC_SVO_TRIAL_MAX_LEVELS ||
	    !(band >= 0.0f)) {
		return BC_EINVAL;
	}
	out->levels = levels;
	t.levels = levels;
	if ((rc = bc_svo_ranger_create(&t.g, rpn, arith))) {
		return rc;
	}
	out->arith = bc_svo_ranger_arith(t.g);
	t.masks =
	    bc_calloc((size_t)(levels + 1u) * rpn->nwords, sizeof(*t.masks));
	if (!t.masks) {
		bc_svo_ranger_destroy(t.g);
		return BC_ENOMEM;
	}
	full = t.masks + (size_t)levels * rpn->nwords;
	bc_svo_mask_fill(rpn, full);
	bc__svo_root_box(rpn, band, lo, hi);
	rc = visit(&t, 0, full, bc_svo_mask_count(full, rpn->nwords), lo, hi);
	bc_free(t.masks);
	bc_svo_ranger_destroy(t.g);
	return rc;
}

enum bc_range_arith bc_svo_arith_choose(const struct bc_svo_trial *ia,
                                        const struct bc_svo_trial *rev)
{
	uint32_t last = ia->levels - 1u;
	uint64_t kia, krev;
	if (ia->levels == 0 || rev->levels != ia->levels) {
		return BC_RANGE_IA;
	}
	kia = ia->level[last].terms_out;
	krev = rev->level[last].terms_out;
	/* RevAA pays for itself only where IA keeps BC_SVO_REVAA_COST times
	 * the terms RevAA keeps (ties go to IA, the cheaper). */
	return (double)kia > BC_SVO_REVAA_COST * (double)krev ? BC_RANGE_REVAA
	                                                      : BC_RANGE_IA;
}

bool bc_svo_arith_may_differ(const struct bc_svo_rpn *rpn)
{
	for (uint32_t i = 0; i < rpn->n; i++) {
		const struct bc_svo_term *t = &rpn->terms[i];
		if (t->type == BC_SVO_TERM_OP &&
		    bc_op_is_smooth((enum bc_op)t->kind)) {
			return true;
		}
		if (t->type == BC_SVO_TERM_PRIM &&
		    t->kind == BC_PRIM_ELLIPSOID) {
			return true;
		}
	}
	return false;
}

int bc_svo_arith_default(const struct bc_svo_rpn *rpn, float band,
                         enum bc_range_arith *out)
{
	struct bc_svo_trial ia, rev;
	int rc;
	*out = BC_RANGE_IA;
	if (!bc_svo_arith_may_differ(rpn)) {
		return 0;
	}
	if ((rc = bc_svo_trial_run(rpn, BC_RANGE_IA, band, BC_SVO_TRIAL_LEVELS,
	                           &ia)) ||
	    (rc = bc_svo_trial_run(rpn, BC_RANGE_REVAA, band,
	                           BC_SVO_TRIAL_LEVELS, &rev))) {
		return rc;
	}
	*out = bc_svo_arith_choose(&ia, &rev);
	return 0;
}
