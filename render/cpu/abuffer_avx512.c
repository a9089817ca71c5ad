/*
 * The A-buffer's AVX-512 kernels (abuffer.h): 16 rays, a quarter tile, per
 * vector. This file alone is compiled with -mavx512f -mavx2
 * -ffp-contract=off (render/cpu/CMakeLists.txt) and is only called when
 * the CPU has AVX-512F (abuffer.c checks).
 */
#include "abuffer.h"

#include "vec_avx512.h"

#define AB_LANES 16u
#define AB_DIRS bc__ab_dirs_avx512
#define AB_SPHERE bc__ab_sphere_avx512

#include "abuffer_kernel.h"
