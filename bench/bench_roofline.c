/*
 * Roofline of the tiled tracer's vector path on this core: how far the
 * packet kernel and the frames it draws are from the machine's peak.
 *
 * Three rates, one thread each, by process CPU time:
 *
 *  - peak: fused multiply-adds of the widest vectors the tracer uses
 *    (AVX-512, else AVX2) in 12 independent chains, which keeps both FMA
 *    pipes of current cores busy: the most floating-point operations a
 *    second a core gives the kernel (an FMA counts 2);
 *  - kernel: the packet kernel (render/cpu/packet.h's march function,
 *    evaluating only) on whole packets, every lane live, over views of the
 *    primitives whose bounds hold a point of the scene (a sample of the
 *    views a frame builds per tile and depth range), so the interpreter,
 *    its broadcasts, its divisions and square roots are all in; its
 *    operations are counted per view instruction from the kernel's source
 *    (the table below), a square root or a division as one;
 *  - frame: warm 512 x 512 frames of the scene through the renderer
 *    (vector path), field evaluations (bc_render_stats) per second.
 *
 * kernel / peak is the kernel's fraction of peak; frame / kernel, in field
 * evaluations, what the rest of a frame (the per-lane state machine,
 * shading, lists, lanes idle at the ends of a tile's rays) leaves of the
 * kernel's rate.
 *
 * Usage: bench_roofline [--reps R]   (R timed repetitions, the best kept)
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/render.h"

#include "../render/cpu/packet.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define ROOF_X86 1
#endif

static double cpu_ms(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* ---- Peak --------------------------------------------------------------- */

#define CHAINS 12

#if defined(ROOF_X86)
__attribute__((target("avx512f,fma"))) static float fma512(uint64_t n)
{
	__m512 acc[CHAINS], m = _mm512_set1_ps(0.999f),
	                    a = _mm512_set1_ps(0.001f);
	float out[16], sum = 0.0f;
	for (int c = 0; c < CHAINS; c++) {
		acc[c] = _mm512_set1_ps((float)c);
	}
	for (uint64_t i = 0; i < n; i++) {
		for (int c = 0; c < CHAINS; c++) {
			acc[c] = _mm512_fmadd_ps(acc[c], m, a);
		}
	}
	for (int c = 1; c < CHAINS; c++) {
		acc[0] = _mm512_add_ps(acc[0], acc[c]);
	}
	_mm512_storeu_ps(out, acc[0]);
	for (int i = 0; i < 16; i++) {
		sum += out[i];
	}
	return sum;
}

__attribute__((target("avx2,fma"))) static float fma256(uint64_t n)
{
	__m256 acc[CHAINS], m = _mm256_set1_ps(0.999f),
	                    a = _mm256_set1_ps(0.001f);
	float out[8], sum = 0.0f;
	for (int c = 0; c < CHAINS; c++) {
		acc[c] = _mm256_set1_ps((float)c);
	}
	for (uint64_t i = 0; i < n; i++) {
		for (int c = 0; c < CHAINS; c++) {
			acc[c] = _mm256_fmadd_ps(acc[c], m, a);
		}
	}
	for (int c = 1; c < CHAINS; c++) {
		acc[0] = _mm256_add_ps(acc[0], acc[c]);
	}
	_mm256_storeu_ps(out, acc[0]);
	for (int i = 0; i < 8; i++) {
		sum += out[i];
	}
	return sum;
}
#endif

/* GFLOP/s of the FMA loop at `lanes` floats a vector (0 when this build
 * has no such loop), the best of reps. */
static double peak_gflops(uint32_t lanes, int reps)
{
	double best = 0.0;
#if defined(ROOF_X86)
	const uint64_t n = 50u * 1000u * 1000u;
	for (int r = 0; r < reps; r++) {
		double t0 = cpu_ms(), ms;
		volatile float sink = lanes == 16 ? fma512(n) : fma256(n);
		(void)sink;
		ms = cpu_ms() - t0;
		if (ms > 0.0) {
			double g = (double)n * CHAINS * lanes * 2.0 / ms * 1e-6;
			best = g > best ? g : best;
		}
	}
#else
	(void)lanes;
	(void)reps;
#endif
	return best;
}

/* ---- The kernel --------------------------------------------------------- */

/* Floating-point operations of one lane for a view instruction, counted
 * from render/cpu/packet_kernel.h (an FMA 2; add, sub, mul, div, sqrt 1;
 * min, max, abs, compares and selects 0). Every primitive first maps the
 * point by its affine record: 9 FMAs, 18. 0: no vector form (the scalar
 * field lane by lane; the scenes below have none). */
static double prim_flops(uint32_t kind)
{
	switch (kind) {
	case BC_PRIM_SPHERE: /* |p| - r: 2 FMA, mul, sqrt, sub */
		return 18 + 7;
	case BC_PRIM_BOX: /* 3 sub, |max(q,0)| (6), add, sub */
		return 18 + 11;
	case BC_PRIM_CAPSULE: /* 3 sub, dot (5), mul, 3 mul, 3 sub, len, sub */
		return 18 + 22;
	case BC_PRIM_CYLINDER: /* len2 (4), sub, sub, extrude: len2, add */
		return 18 + 11;
	case BC_PRIM_TORUS: /* len2, sub, len2, sub */
		return 18 + 10;
	case BC_PRIM_LINK: /* sub, len2, sub, len2, sub */
		return 18 + 11;
	default:
		return 0;
	}
}

static double op_flops(uint32_t kind)
{
	switch (kind) {
	case BC_OP_SMOOTH_UNION:
	case BC_OP_SMOOTH_INTERSECTION:
	case BC_OP_SMOOTH_DIFFERENCE:
		/* blend by the constant beta (sub, mul, sub; 3 mul), G (1),
		 * transition (mul, sub, mul), blend by b (sub, div, sub, mul,
		 * 3 mul), the result (1) */
		return 6 + 1 + 3 + 7 + 1;
	default: /* min or max */
		return 0;
	}
}

static double view_flops(const struct bc_view *v)
{
	double f = 0.0;
	for (uint32_t i = 0; i < v->n; i++) {
		const struct bc_view_instr *in = &v->instr[i];
		if (in->leaf == 1) {
			f += prim_flops(in->kind);
		} else if (in->leaf == 0) {
			f += op_flops(in->kind);
		}
	}
	return f;
}

static float frand(uint64_t *s)
{
	*s = *s * 6364136223846793005ull + 1442695040888963407ull;
	return (float)(*s >> 40) / (float)(1u << 24);
}

struct kernel_rate {
	double mevals; /* lane evaluations per second, millions */
	double gflops;
	double instr;    /* view instructions per evaluation, mean */
	bool has_scalar; /* a view held a kind without a vector form */
};

/* The kernel over views of the primitives whose world AABBs hold a point
 * near a random primitive, each view evaluated `rounds` times at packets
 * of points jittered about that point. */
static struct kernel_rate kernel_rate(const struct bc_lin *l, int reps)
{
	struct bc__pk_kernel k = bc__pk_kernel_for(BC_SIMD_AUTO);
	struct kernel_rate best = {0};
	const uint32_t nviews = 200, rounds = 400;
	uint32_t *act = bc_calloc(l->nprims, sizeof(*act));
	float(*lo)[3] = bc_calloc(l->nprims, sizeof(*lo));
	float(*hi)[3] = bc_calloc(l->nprims, sizeof(*hi));
	struct bc_view view;
	if (!k.march || !act || !lo || !hi) {
		bc_free(act);
		bc_free(lo);
		bc_free(hi);
		return best;
	}
	for (uint32_t i = 0; i < l->nprims; i++) {
		struct bc_abv a = bc_lin_abv(l, i);
		bc_abv_aabb(&a, lo[i], hi[i]);
	}
	bc_view_init(&view);
	for (int r = 0; r < reps; r++) {
		uint64_t state = 7;
		double ms = 0.0, evals = 0.0, flops = 0.0, instr = 0.0;
		struct kernel_rate now = {0};
		for (uint32_t v = 0; v < nviews; v++) {
			uint32_t k0 = (uint32_t)(frand(&state) *
			                         (float)l->nprims) %
			              l->nprims,
			         n = 0;
			float c[3], half[3];
			struct bc__pk_lanes ln;
			const struct bc__pk_steps st = {1e-3f, 1e-4f, 1e-4f};
			double t0, f;
			for (int a = 0; a < 3; a++) {
				half[a] = 0.5f * (hi[k0][a] - lo[k0][a]);
				c[a] =
				    lo[k0][a] + half[a] * 2.0f * frand(&state);
			}
			for (uint32_t i = 0; i < l->nprims; i++) {
				if (c[0] >= lo[i][0] && c[0] <= hi[i][0] &&
				    c[1] >= lo[i][1] && c[1] <= hi[i][1] &&
				    c[2] >= lo[i][2] && c[2] <= hi[i][2]) {
					act[n++] = i;
				}
			}
			if (n == 0 || bc_view_build(&view, l, act, n) != 0 ||
			    view.empty) {
				continue;
			}
			memset(&ln, 0, sizeof(ln));
			for (uint32_t i = 0; i < k.lanes; i++) {
				ln.ox[i] =
				    c[0] + 0.1f * half[0] * frand(&state);
				ln.oy[i] =
				    c[1] + 0.1f * half[1] * frand(&state);
				ln.oz[i] =
				    c[2] + 0.1f * half[2] * frand(&state);
				ln.dx[i] = 1e-3f * frand(&state);
				ln.dy[i] = 1e-3f * frand(&state);
				ln.dz[i] = 1.0f;
				ln.t[i] = 0.0f;
			}
			f = view_flops(&view);
			for (uint32_t i = 0; i < view.n; i++) {
				if (view.instr[i].leaf == 1 &&
				    prim_flops(view.instr[i].kind) == 0) {
					now.has_scalar = true;
				}
			}
			t0 = cpu_ms();
			for (uint32_t j = 0; j < rounds; j++) {
				/* No lane of a kind that steps. */
				struct bc__pk_kinds none = {{0}, 0, 0};
				ln.t[j % k.lanes] = 1e-6f * (float)j;
				(void)k.march(&view, l, &ln,
				              k.lanes >= 32
				                  ? UINT32_MAX
				                  : (1u << k.lanes) - 1u,
				              &none, &st);
			}
			ms += cpu_ms() - t0;
			evals += (double)rounds * k.lanes;
			flops += (double)rounds * k.lanes * f;
			instr += (double)rounds * k.lanes * view.n;
		}
		if (ms > 0.0) {
			now.mevals = evals / ms * 1e-3;
			now.gflops = flops / ms * 1e-6;
			now.instr = instr / evals;
			if (now.mevals > best.mevals) {
				best = now;
			}
		}
	}
	bc_view_finish(&view);
	bc_free(act);
	bc_free(lo);
	bc_free(hi);
	return best;
}

/* ---- Frames ------------------------------------------------------------- */

/* Field evaluations per second (millions) of warm frames, the best of
 * reps, one thread, vector path. */
static double frame_rate(struct bc_tree *t, const struct bc_camera *cam,
                         int reps)
{
	struct bc_render_opts o = {.threads = 1, .simd = BC_SIMD_AUTO};
	struct bc_renderer *r = NULL;
	struct bc_errinfo ei = {0};
	struct bc_frame f = {0};
	double best = 0.0;
	if (bc_renderer_create(&r, BC_BACKEND_TILED, &o, &ei) ||
	    bc_renderer_sync(r, t, NULL, &ei) || bc_frame_init(&f, 512, 512) ||
	    bc_renderer_render(r, cam, &f, NULL, &ei)) {
		fprintf(stderr, "bench_roofline: %s\n", ei.msg);
		bc_renderer_destroy(r);
		bc_frame_finish(&f);
		return 0.0;
	}
	for (int i = 0; i < reps; i++) {
		struct bc_render_stats st = {0};
		double t0 = cpu_ms(), ms;
		if (bc_renderer_render(r, cam, &f, &st, &ei)) {
			break;
		}
		ms = cpu_ms() - t0;
		if (ms > 0.0 && (double)st.field_evals / ms * 1e-3 > best) {
			best = (double)st.field_evals / ms * 1e-3;
		}
	}
	bc_renderer_destroy(r);
	bc_frame_finish(&f);
	return best;
}

int main(int argc, char **argv)
{
	static const struct {
		const char *label, *gen;
		struct bc_gen_opts opts;
	} scenes[] = {
	    {"fig18 smooth spheres 256",
	     "fig18",
	     {.count = 256,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH}},
	    {"fig18 smooth spheres 4096",
	     "fig18",
	     {.count = 4096,
	      .kind = BC_GEN_KIND_SPHERES,
	      .blend = BC_GEN_BLEND_SMOOTH}},
	    {"fig18 sharp boxes 1024",
	     "fig18",
	     {.count = 1024,
	      .kind = BC_GEN_KIND_BOXES,
	      .blend = BC_GEN_BLEND_SHARP}},
	    {"gears 24 teeth", "gears", {.teeth = 24}},
	    {"fig16 L3 smooth",
	     "fig16",
	     {.level = 3, .blend = BC_GEN_BLEND_SMOOTH}},
	};
	struct bc__pk_kernel k = bc__pk_kernel_for(BC_SIMD_AUTO);
	uint32_t nreps = 5;
	int reps;
	double peak;
	const struct bc_opt opts_table[] = {
	    {.name = "reps",
	     .kind = BC_OPT_U32,
	     .dst = &nreps,
	     .lo = 1,
	     .hi = 1000,
	     .arg = "R",
	     .help = "timed repetitions of each rate, the best kept (default "
	             "{default})"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args args = {.prog = "bench_roofline",
	                       .usage = "bench_roofline [options]",
	                       .opts = opts_table};
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (args.npos) {
		return bc_args_error(&args, "unexpected argument '%s'",
		                     args.pos[0]);
	}
	reps = (int)nreps;
	if (!k.march) {
		printf("no packet kernel on this CPU (the scalar path): "
		       "nothing to measure\n");
		return 0;
	}
	peak = peak_gflops(k.lanes, reps);
	printf("one thread, process CPU time; kernel %u lanes\n", k.lanes);
	printf("peak: %u-lane FMA in %d chains: %.1f GFLOP/s\n\n", k.lanes,
	       CHAINS, peak);
	printf("%-26s | %6s %8s %8s %7s | %8s %7s\n", "scene", "instr",
	       "kern Mev", "GFLOP/s", "of peak", "frame Mev", "of kern");
	for (size_t s = 0; s < sizeof(scenes) / sizeof(scenes[0]); s++) {
		struct bc_tree *t = bc_tree_create();
		struct bc_camera cam;
		struct bc_errinfo ei = {0};
		struct kernel_rate kr;
		double fr;
		if (!t ||
		    bc_gen(scenes[s].gen, &scenes[s].opts, t, &cam, &ei)) {
			fprintf(stderr, "bench_roofline: %s: %s\n",
			        scenes[s].label, t ? ei.msg : "out of memory");
			return 1;
		}
		kr = kernel_rate(bc_tree_lin(t), reps);
		fr = frame_rate(t, &cam, reps);
		printf("%-26s | %6.1f %8.1f %8.1f %6.1f%% | %8.1f %6.1f%%%s\n",
		       scenes[s].label, kr.instr, kr.mevals, kr.gflops,
		       peak > 0.0 ? 100.0 * kr.gflops / peak : 0.0, fr,
		       kr.mevals > 0.0 ? 100.0 * fr / kr.mevals : 0.0,
		       kr.has_scalar ? " (scalar kinds: flops undercounted)"
		                     : "");
		bc_tree_destroy(t);
	}
	return 0;
}
