/*
 * The AVX2 packet kernel (packet.h): 8 rays per packet. This file alone is
 * compiled with -mavx2 -mfma (render/cpu/CMakeLists.txt) and is only
 * called when the CPU has both (packet.c checks).
 */
#include "packet.h"

#include "vec_avx2.h"

#define PK_LANES 8u
#define PK_MARCH bc__pk_march_avx2
#define PK_HITS bc__pk_hits_avx2
#define PK_SHADE bc__pk_shade_avx2

#include "packet_kernel.h"
