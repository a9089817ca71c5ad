/*
 * One rule set for numbers typed by people (command lines, the viewer's
 * options, the daemon's flags), so every program accepts and refuses the
 * same spellings and words its errors alike:
 *
 * - decimal only, no leading or trailing space, the whole string consumed;
 * - unsigned values take no sign (not even '+'): "-1" is a syntax error,
 *   not a huge number;
 * - floats are finite (no "nan", "inf", no hex floats);
 * - a size is "WxH" and a vector "x,y,z", each part under the rules above.
 *
 * Each function returns 0, BC_EINVAL when the text is not a number of that
 * kind, or BC_ERANGE when it is one but outside [lo, hi]. The out-values
 * are written only on success.
 */
#ifndef BLOBCAST_NUM_H
#define BLOBCAST_NUM_H

#include <stdint.h>

int bc_num_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out);
int bc_num_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out);
int bc_num_f32(const char *s, float lo, float hi, float *out);
int bc_num_f64(const char *s, double lo, double hi, double *out);
/* "WxH", each part a u32 in [lo, hi]. */
int bc_num_size(const char *s, uint32_t lo, uint32_t hi, uint32_t *w,
                uint32_t *h);
/* "x,y,z", each part a finite float (no range). */
int bc_num_vec3(const char *s, float out[3]);
/* n (1..BC_NUM_MAX_FLOATS) comma-separated finite floats, as for vec3. */
#define BC_NUM_MAX_FLOATS 16
int bc_num_f32s(const char *s, float *out, int n);

/* qsort's comparison for uint32_t, ascending. */
int bc_cmp_u32(const void *a, const void *b);

#endif
