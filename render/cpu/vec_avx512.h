/*
 * The AVX-512 vector operations the CPU kernels are written in (16 floats
 * a vector): packet_avx512.c (the tracer) and abuffer_avx512.c (the A-buffer)
 * include this, each compiled with its own flags (render/cpu/
 * CMakeLists.txt); vfma exists only where the compiler may use FMA.
 */
#ifndef BLOBCAST_RENDER_CPU_VEC_AVX512_H
#define BLOBCAST_RENDER_CPU_VEC_AVX512_H

#include <immintrin.h>
#include <stdint.h>

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
/* Rounded down to an integer (floorf). */
static inline vf vfloor(vf a)
{
	return _mm512_roundscale_ps(a,
	                            _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
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
#if defined(__FMA__) || defined(__AVX512F__)
static inline vf vfma(vf a, vf b, vf c)
{
	return _mm512_fmadd_ps(a, b, c);
}
#endif
/* As AVX2's minps: a < b ? a : b, as bc__minf. */
static inline vf vmin(vf a, vf b)
{
	return _mm512_min_ps(a, b);
}
static inline vf vmax(vf a, vf b)
{
	return _mm512_max_ps(a, b);
}
static inline vf vsqrt(vf a)
{
	return _mm512_sqrt_ps(a);
}
static inline vf vabs(vf a)
{
	return _mm512_abs_ps(a);
}
static inline vf vneg(vf a)
{
	/* A sign flip, as AVX2's (AVX-512F has no float xor). */
	return _mm512_castsi512_ps(_mm512_xor_si512(
	    _mm512_castps_si512(a), _mm512_set1_epi32(INT32_MIN)));
}
static inline vm vlt(vf a, vf b)
{
	return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ);
}
static inline vm vle(vf a, vf b)
{
	return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ);
}
static inline vm vgt(vf a, vf b)
{
	return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ);
}
static inline vm mand(vm a, vm b)
{
	return (vm)(a & b);
}
static inline vf vsel(vm m, vf a, vf b)
{
	return _mm512_mask_blend_ps(m, b, a);
}
static inline vm vge(vf a, vf b)
{
	return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ);
}
static inline vm mnot(vm a)
{
	return (vm)~a;
}
static inline vm mfrombits(uint32_t bits)
{
	return (vm)bits;
}
static inline uint32_t mtobits(vm m)
{
	return (uint32_t)m;
}
static inline vf vbits(uint32_t u)
{
	return _mm512_castsi512_ps(_mm512_set1_epi32((int)u));
}

#endif
