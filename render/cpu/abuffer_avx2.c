/*
 * The A-buffer's AVX2 kernels (abuffer.h): 8 rays per vector. This file
 * alone is compiled with -mavx2 -ffp-contract=off
 * (render/cpu/CMakeLists.txt) and is only called when the CPU has AVX2
 * (abuffer.c checks).
 */
#include "abuffer.h"

#include <immintrin.h>

#define AB_LANES 8u
#define AB_DIRS bc__ab_dirs_avx2
#define AB_SPHERE bc__ab_sphere_avx2

typedef __m256 vf;
typedef __m256 vm;

static inline vf vset1(float a)
{
	return _mm256_set1_ps(a);
}
static inline vf vload(const float *p)
{
	return _mm256_load_ps(p);
}
static inline void vstore(float *p, vf a)
{
	_mm256_store_ps(p, a);
}
static inline vf vadd(vf a, vf b)
{
	return _mm256_add_ps(a, b);
}
static inline vf vsub(vf a, vf b)
{
	return _mm256_sub_ps(a, b);
}
static inline vf vmul(vf a, vf b)
{
	return _mm256_mul_ps(a, b);
}
static inline vf vdiv(vf a, vf b)
{
	return _mm256_div_ps(a, b);
}
static inline vf vsqrt(vf a)
{
	return _mm256_sqrt_ps(a);
}
static inline vf vabs(vf a)
{
	return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a);
}
/* minps and maxps return their second operand unless the first is
 * smaller (larger). */
static inline vf vmin(vf a, vf b)
{
	return _mm256_min_ps(a, b);
}
static inline vf vmax(vf a, vf b)
{
	return _mm256_max_ps(a, b);
}
static inline vm vgt(vf a, vf b)
{
	return _mm256_cmp_ps(a, b, _CMP_GT_OQ);
}
static inline vm vge(vf a, vf b)
{
	return _mm256_cmp_ps(a, b, _CMP_GE_OQ);
}
static inline vm mand(vm a, vm b)
{
	return _mm256_and_ps(a, b);
}
static inline vm mfrombits(uint32_t bits)
{
	__m256i sel = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
	__m256i b = _mm256_and_si256(_mm256_set1_epi32((int)bits), sel);
	return _mm256_castsi256_ps(_mm256_cmpeq_epi32(b, sel));
}
static inline vf vsel(vm m, vf a, vf b)
{
	return _mm256_blendv_ps(b, a, m);
}

#include "abuffer_kernel.h"
