/*
 * The number rules of blobcast/num.h. Decimal digits are checked by hand
 * before strtoull/strtod run, because those accept leading space, signs on
 * unsigned values, hex and "nan", none of which a person typing an option
 * means.
 */
#include "blobcast/num.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/error.h"

static bool is_digit(char c)
{
	return c >= '0' && c <= '9';
}

int bc_num_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
	uint64_t v = 0;
	if (!s || !*s) {
		return BC_EINVAL;
	}
	for (const char *p = s; *p; p++) {
		if (!is_digit(*p)) {
			return BC_EINVAL;
		}
	}
	for (const char *p = s; *p; p++) {
		unsigned d = (unsigned)(*p - '0');
		if (v > (UINT64_MAX - d) / 10u) {
			return BC_ERANGE;
		}
		v = v * 10u + d;
	}
	if (v < lo || v > hi) {
		return BC_ERANGE;
	}
	*out = v;
	return 0;
}

int bc_num_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
	uint64_t v;
	int rc = bc_num_u64(s, lo, hi, &v);
	if (rc == 0) {
		*out = (uint32_t)v;
	}
	return rc;
}

/* [+-]digits[.digits][(e|E)[+-]digits], with at least one mantissa digit:
 * the decimal subset of strtod's syntax. */
static bool is_decimal(const char *s)
{
	bool digits = false;
	if (*s == '+' || *s == '-') {
		s++;
	}
	while (is_digit(*s)) {
		s++;
		digits = true;
	}
	if (*s == '.') {
		s++;
		while (is_digit(*s)) {
			s++;
			digits = true;
		}
	}
	if (!digits) {
		return false;
	}
	if (*s == 'e' || *s == 'E') {
		s++;
		if (*s == '+' || *s == '-') {
			s++;
		}
		if (!is_digit(*s)) {
			return false;
		}
		while (is_digit(*s)) {
			s++;
		}
	}
	return *s == '\0';
}

int bc_num_f64(const char *s, double lo, double hi, double *out)
{
	char *end;
	double v;
	if (!s || !is_decimal(s)) {
		return BC_EINVAL;
	}
	errno = 0;
	v = strtod(s, &end);
	/* ERANGE on underflow gives a denormal or zero: keep it. */
	if (*end != '\0' || !isfinite(v)) {
		return BC_ERANGE;
	}
	if (!(v >= lo && v <= hi)) {
		return BC_ERANGE;
	}
	*out = v;
	return 0;
}

int bc_num_f32(const char *s, float lo, float hi, float *out)
{
	double v;
	int rc = bc_num_f64(s, (double)lo, (double)hi, &v);
	if (rc) {
		return rc;
	}
	if (!isfinite((float)v)) {
		return BC_ERANGE;
	}
	*out = (float)v;
	return 0;
}

/* Copies the n bytes at s into buf (of size cap) as a string; false when
 * they do not fit. */
static bool copy_part(char *buf, size_t cap, const char *s, size_t n)
{
	if (n >= cap) {
		return false;
	}
	memcpy(buf, s, n);
	buf[n] = '\0';
	return true;
}

int bc_num_size(const char *s, uint32_t lo, uint32_t hi, uint32_t *w,
                uint32_t *h)
{
	char part[32];
	const char *x;
	uint32_t a, b;
	int rc;
	if (!s || !(x = strchr(s, 'x')) ||
	    !copy_part(part, sizeof(part), s, (size_t)(x - s))) {
		return BC_EINVAL;
	}
	/* Syntax of both parts first, so "0xfoo" is EINVAL, not ERANGE. */
	if (bc_num_u64(part, 0, UINT64_MAX, &(uint64_t){0}) == BC_EINVAL ||
	    bc_num_u64(x + 1, 0, UINT64_MAX, &(uint64_t){0}) == BC_EINVAL) {
		return BC_EINVAL;
	}
	if ((rc = bc_num_u32(part, lo, hi, &a)) ||
	    (rc = bc_num_u32(x + 1, lo, hi, &b))) {
		return rc;
	}
	*w = a;
	*h = b;
	return 0;
}

int bc_num_f32s(const char *s, float *out, int n)
{
	char part[64];
	float v[BC_NUM_MAX_FLOATS];
	if (!s || n < 1 || n > BC_NUM_MAX_FLOATS) {
		return BC_EINVAL;
	}
	for (int i = 0; i < n; i++) {
		const char *comma = i < n - 1 ? strchr(s, ',') : s + strlen(s);
		int rc;
		if (!comma ||
		    !copy_part(part, sizeof(part), s, (size_t)(comma - s))) {
			return BC_EINVAL;
		}
		if ((rc = bc_num_f32(part, -INFINITY, INFINITY, &v[i]))) {
			return rc;
		}
		s = comma + 1;
	}
	memcpy(out, v, (size_t)n * sizeof(v[0]));
	return 0;
}

int bc_num_vec3(const char *s, float out[3])
{
	return bc_num_f32s(s, out, 3);
}

int bc_cmp_u32(const void *a, const void *b)
{
	uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
	return (x > y) - (x < y);
}
