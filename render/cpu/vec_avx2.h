/*
 * The AVX2 vector operations the CPU kernels are written in (8 floats
 * a vector): packet_avx2.c (the tracer) and abuffer_avx2.c (the A-buffer)
 * include this, each compiled with its own flags (render/cpu/
 * CMakeLists.txt); vfma exists only where the compiler may use FMA.
 */
#ifndef BLOBCAST_RENDER_CPU_VEC_AVX2_H
#define BLOBCAST_RENDER_CPU_VEC_AVX2_H

#include <immintrin.h>
#include <stdint.h>

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
/* Rounded down to an integer (floorf). */
static inline vf vfloor(vf a)
{
	return _mm256_floor_ps(a);
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
#if defined(__FMA__) || defined(__AVX512F__)
static inline vf vfma(vf a, vf b, vf c)
{
	return _mm256_fmadd_ps(a, b, c);
}
#endif
/* minps returns its second operand unless the first is smaller: a < b ?
 * a : b, as bc__minf. */
static inline vf vmin(vf a, vf b)
{
	return _mm256_min_ps(a, b);
}
static inline vf vmax(vf a, vf b)
{
	return _mm256_max_ps(a, b);
}
static inline vf vsqrt(vf a)
{
	return _mm256_sqrt_ps(a);
}
static inline vf vabs(vf a)
{
	return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a);
}
static inline vf vneg(vf a)
{
	return _mm256_xor_ps(_mm256_set1_ps(-0.0f), a);
}
static inline vm vlt(vf a, vf b)
{
	return _mm256_cmp_ps(a, b, _CMP_LT_OQ);
}
static inline vm vle(vf a, vf b)
{
	return _mm256_cmp_ps(a, b, _CMP_LE_OQ);
}
static inline vm vgt(vf a, vf b)
{
	return _mm256_cmp_ps(a, b, _CMP_GT_OQ);
}
static inline vm mand(vm a, vm b)
{
	return _mm256_and_ps(a, b);
}
static inline vf vsel(vm m, vf a, vf b)
{
	return _mm256_blendv_ps(b, a, m);
}
static inline vm vge(vf a, vf b)
{
	return _mm256_cmp_ps(a, b, _CMP_GE_OQ);
}
static inline vm mnot(vm a)
{
	return _mm256_xor_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
}
static inline vm mfrombits(uint32_t bits)
{
	__m256i sel = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
	__m256i b = _mm256_and_si256(_mm256_set1_epi32((int)bits), sel);
	return _mm256_castsi256_ps(_mm256_cmpeq_epi32(b, sel));
}
static inline uint32_t mtobits(vm m)
{
	return (uint32_t)_mm256_movemask_ps(m);
}
static inline vf vbits(uint32_t u)
{
	return _mm256_castsi256_ps(_mm256_set1_epi32((int)u));
}

#endif
