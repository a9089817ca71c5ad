/*
 * The AVX-512 packet kernel (packet.h): 16 rays per packet. This file
 * alone is compiled with -mavx512f (render/cpu/CMakeLists.txt) and is only
 * called when the CPU has it (packet.c checks).
 */
#include "packet.h"

#include "vec_avx512.h"

#define PK_LANES 16u
#define PK_MARCH bc__pk_march_avx512
#define PK_HITS bc__pk_hits_avx512
#define PK_SHADE bc__pk_shade_avx512

#include "packet_kernel.h"
