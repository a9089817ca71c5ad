/*
 * The A-buffer's AVX-512 kernels (abuffer.h): 16 rays, a quarter tile, per
 * vector. This file alone is compiled with -mavx512f -mavx2
 * -ffp-contract=off (render/cpu/CMakeLists.txt) and is only called when
 * the CPU has AVX-512F (abuffer.c checks).
 */
#include "abuffer.h"

#include <immintrin.h>

#define AB_LANES 16u
#define AB_DIRS bc__ab_dirs_avx512
#define AB_SPHERE bc__ab_sphere_avx512

typedef __m512 vf;
typedef __mmask16 vm;

static inline vf vset1(float a)
{
	return _mm512_set1_ps(a);
}
static inline vf vload(const float *p)
{
	return _mm512_load_ps(p);
}
static inline void vstore(float *p, vf a)
{
	_mm512_store_ps(p, a);
}
static inline vf vadd(vf a, vf b)
{
	return _mm512_add_ps(a, b);
}
static inline vf vsub(vf a, vf b)
{
	return _mm512_sub_ps(a, b);
}
static inline vf vmul(vf a, vf b)
{
	return _mm512_mul_ps(a, b);
}
static inline vf vdiv(vf a, vf b)
{
	return _mm512_div_ps(a, b);
}
static inline vf vsqrt(vf a)
{
	return _mm512_sqrt_ps(a);
}
static inline vf vabs(vf a)
{
	return _mm512_abs_ps(a);
}
/* vminps and vmaxps return their second operand unless the first is
 * smaller (larger). */
static inline vf vmin(vf a, vf b)
{
	return _mm512_min_ps(a, b);
}
static inline vf vmax(vf a, vf b)
{
	return _mm512_max_ps(a, b);
}
static inline vm vgt(vf a, vf b)
{
	return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ);
}
static inline vm vge(vf a, vf b)
{
	return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ);
}
static inline vm mand(vm a, vm b)
{
	return (vm)(a & b);
}
static inline vm mfrombits(uint32_t bits)
{
	return (vm)bits;
}
static inline vf vsel(vm m, vf a, vf b)
{
	return _mm512_mask_blend_ps(m, b, a);
}

#include "abuffer_kernel.h"
