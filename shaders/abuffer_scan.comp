#version 430 core
// A-buffer pass, prefix sum: gives every tile the offset of its sorted list
// (the exclusive sum of the fragment counts before it) and records the
// longest list. One workgroup: each invocation sums a contiguous run of
// tiles, the run totals are scanned in shared memory, then each invocation
// writes its run's offsets.
#include "common.glsl"

#define SCAN_THREADS 256u

layout(local_size_x = 256) in;

shared uint s_sum[SCAN_THREADS];
shared uint s_max[SCAN_THREADS];

void main()
{
	uint lid = gl_LocalInvocationIndex;
	uint n = u_size.z * u_size.w;
	uint per = (n + SCAN_THREADS - 1u) / SCAN_THREADS;
	uint b = min(lid * per, n), e = min(b + per, n);
	uint sum = 0u, most = 0u;
	for (uint i = b; i < e; i++) {
		uint c = b_tile[i].y;
		sum += c;
		most = max(most, c);
	}
	s_sum[lid] = sum;
	s_max[lid] = most;
	barrier();
	// Inclusive Hillis-Steele scan of the run totals.
	for (uint o = 1u; o < SCAN_THREADS; o <<= 1u) {
		uint v = lid >= o ? s_sum[lid - o] : 0u;
		barrier();
		s_sum[lid] += v;
		barrier();
	}
	uint run = s_sum[lid] - sum;
	for (uint i = b; i < e; i++) {
		b_tile[i].z = run;
		run += b_tile[i].y;
	}
	for (uint o = SCAN_THREADS / 2u; o > 0u; o >>= 1u) {
		if (lid < o) {
			s_max[lid] = max(s_max[lid], s_max[lid + o]);
		}
		barrier();
	}
	if (lid == 0u) {
		b_stat[BC_STAT_MAX_OVERLAP] = s_max[0];
	}
}
