/*
 * The A-buffer's AVX2 kernels (abuffer.h): 8 rays per vector. This file
 * alone is compiled with -mavx2 -ffp-contract=off
 * (render/cpu/CMakeLists.txt) and is only called when the CPU has AVX2
 * (abuffer.c checks).
 */
#include "abuffer.h"

#include "vec_avx2.h"

#define AB_LANES 8u
#define AB_DIRS bc__ab_dirs_avx2
#define AB_SPHERE bc__ab_sphere_avx2

#include "abuffer_kernel.h"
