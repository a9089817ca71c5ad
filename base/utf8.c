/*
 * Strict UTF-8 (RFC 3629) for every string that crosses a process
 * boundary: the wire protocol's str fields and node names in scene files.
 */
#include "blobcast/bytes.h"

size_t bc_utf8_check(const uint8_t *p, size_t n)
{
	size_t i = 0;
	while (i < n) {
		uint8_t c = p[i];
		if (c >= 0x01 && c <= 0x7f) {
			i++;
			continue;
		}
		/* Lead byte: the sequence length and the range of the
		 * second byte, which is what excludes overlong forms,
		 * surrogates (U+D800..DFFF) and code points over U+10FFFF
		 * (RFC 3629, section 4). */
		size_t len;
		uint8_t lo = 0x80, hi = 0xbf;
		if (c >= 0xc2 && c <= 0xdf) {
			len = 2;
		} else if (c == 0xe0) {
			len = 3;
			lo = 0xa0;
		} else if (c == 0xed) {
			len = 3;
			hi = 0x9f;
		} else if (c >= 0xe1 && c <= 0xef) {
			len = 3;
		} else if (c == 0xf0) {
			len = 4;
			lo = 0x90;
		} else if (c >= 0xf1 && c <= 0xf3) {
			len = 4;
		} else if (c == 0xf4) {
			len = 4;
			hi = 0x8f;
		} else {
			return i; /* NUL, a stray continuation, C0, C1, F5+ */
		}
		if (n - i < len) {
			return i;
		}
		if (p[i + 1] < lo || p[i + 1] > hi) {
			return i;
		}
		for (size_t k = 2; k < len; k++) {
			if (p[i + k] < 0x80 || p[i + k] > 0xbf) {
				return i;
			}
		}
		i += len;
	}
	return n;
}

size_t bc_utf8_encode(uint32_t cp, char out[4])
{
	if (cp < 0x80u) {
		out[0] = (char)cp;
		return 1;
	}
	if (cp < 0x800u) {
		out[0] = (char)(0xc0u | (cp >> 6));
		out[1] = (char)(0x80u | (cp & 0x3fu));
		return 2;
	}
	if ((cp >= 0xd800u && cp < 0xe000u) || cp > 0x10ffffu) {
		return 0;
	}
	if (cp < 0x10000u) {
		out[0] = (char)(0xe0u | (cp >> 12));
		out[1] = (char)(0x80u | ((cp >> 6) & 0x3fu));
		out[2] = (char)(0x80u | (cp & 0x3fu));
		return 3;
	}
	out[0] = (char)(0xf0u | (cp >> 18));
	out[1] = (char)(0x80u | ((cp >> 12) & 0x3fu));
	out[2] = (char)(0x80u | ((cp >> 6) & 0x3fu));
	out[3] = (char)(0x80u | (cp & 0x3fu));
	return 4;
}
