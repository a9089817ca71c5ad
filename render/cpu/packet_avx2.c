/*
 * The AVX2 packet kernel (packet.h): 8 rays per packet. This file alone is
 * compiled with -mavx2 -mfma (render/cpu/CMakeLists.txt) and is only
 * called when the CPU has both (packet.c checks).
 */
#include "packet.h"

#include <immintrin.h>

#define PK_LANES 8u
#define PK_MARCH bc__pk_march_avx2
#define PK_EVAL_ID bc__pk_eval_id_avx2

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
static inline vf vfma(vf a, vf b, vf c)
{
	return _mm256_fmadd_ps(a, b, c);
}
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

#include "packet_kernel.h"
