#version 430 core
// A-buffer pass, sorting: one workgroup per tile of the region (every tile,
// or those the region lists) moves the tile's linked list into its
// contiguous range of the sorted buffer, ordered by entry depth, ties by
// primitive index (as the CPU renderer orders them, so both walk the same
// depth ranges). A primitive has at most one fragment per tile, so the
// order is total: the list's order does not depend on the order the
// rasterizer's atomics linked it in. Lists of up to BC_SORT_SHARED fragments are
// bitonic-sorted in shared memory by the whole workgroup; longer ones are
// heap-sorted in place by one invocation, which is slow but needs no memory
// beyond the list itself.
#include "common.glsl"

layout(local_size_x = 64) in;

shared uvec4 s_e[BC_SORT_SHARED];

// Does fragment a come before b?
bool before(uvec4 a, uvec4 b)
{
	float ta = uintBitsToFloat(a.x), tb = uintBitsToFloat(b.x);
	return ta < tb || (ta == tb && a.z < b.z);
}

void heap_sift(uint base, uint root, uint n)
{
	for (;;) {
		uint child = 2u * root + 1u;
		if (child >= n) {
			return;
		}
		if (child + 1u < n &&
		    before(b_frag[base + child], b_frag[base + child + 1u])) {
			child++;
		}
		if (!before(b_frag[base + root], b_frag[base + child])) {
			return;
		}
		uvec4 t = b_frag[base + root];
		b_frag[base + root] = b_frag[base + child];
		b_frag[base + child] = t;
		root = child;
	}
}

void main()
{
	uint lid = gl_LocalInvocationIndex;
	uint tile = bc_region_tile(gl_WorkGroupID);
	if (tile == BC_NONE) {
		return;
	}
	uvec4 tl = b_tile[tile];
	uint n = tl.y, off = tl.z;
	if (n == 0u) {
		return;
	}
	if (n > BC_SORT_SHARED) {
		if (lid != 0u) {
			return;
		}
		uint i = tl.x;
		for (uint j = 0u; j < n; j++) {
			uvec4 l = b_link[i];
			b_frag[off + j] = uvec4(l.x, l.y, l.z, 0u);
			i = l.w;
		}
		for (uint r = n / 2u; r-- > 0u;) {
			heap_sift(off, r, n);
		}
		for (uint m = n - 1u; m > 0u; m--) {
			uvec4 t = b_frag[off];
			b_frag[off] = b_frag[off + m];
			b_frag[off + m] = t;
			heap_sift(off, 0u, m);
		}
		return;
	}
	// Padding sorts last: +inf entry, largest index.
	uint size = 1u;
	while (size < n) {
		size <<= 1u;
	}
	for (uint j = lid; j < size; j += 64u) {
		s_e[j] = uvec4(0x7f800000u, 0u, BC_NONE, 0u);
	}
	barrier();
	if (lid == 0u) {
		uint i = tl.x;
		for (uint j = 0u; j < n; j++) {
			uvec4 l = b_link[i];
			s_e[j] = uvec4(l.x, l.y, l.z, 0u);
			i = l.w;
		}
	}
	barrier();
	for (uint k = 2u; k <= size; k <<= 1u) {
		for (uint j = k >> 1u; j > 0u; j >>= 1u) {
			for (uint i = lid; i < size; i += 64u) {
				uint p = i ^ j;
				if (p > i) {
					uvec4 a = s_e[i], b = s_e[p];
					bool up = (i & k) == 0u;
					if (up ? before(b, a) : before(a, b)) {
						s_e[i] = b;
						s_e[p] = a;
					}
				}
			}
			barrier();
		}
	}
	for (uint j = lid; j < n; j += 64u) {
		b_frag[off + j] = s_e[j];
	}
}
