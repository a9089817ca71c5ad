/*
 * Vector and quaternion helpers on plain float arrays, the layout the
 * scene, the camera and the GPU buffers already use: a vec3 is float[3], a
 * quaternion float[4] stored (x, y, z, w) with w the scalar part, rotating
 * v to q v q^-1. Header-only and static inline, so each caller gets them
 * inlined and the GLSL twins in shaders/ stay the only other copy.
 * Outputs may alias inputs unless a comment says otherwise.
 */
#ifndef BLOBCAST_VEC_H
#define BLOBCAST_VEC_H

#include <math.h>

static inline void bc_v3_set(float out[3], float x, float y, float z)
{
	out[0] = x;
	out[1] = y;
	out[2] = z;
}

static inline void bc_v3_add(const float a[3], const float b[3], float out[3])
{
	bc_v3_set(out, a[0] + b[0], a[1] + b[1], a[2] + b[2]);
}

static inline void bc_v3_sub(const float a[3], const float b[3], float out[3])
{
	bc_v3_set(out, a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

static inline void bc_v3_scale(const float a[3], float s, float out[3])
{
	bc_v3_set(out, a[0] * s, a[1] * s, a[2] * s);
}

static inline float bc_v3_dot(const float a[3], const float b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* out = a x b (right-handed). */
static inline void bc_v3_cross(const float a[3], const float b[3], float out[3])
{
	bc_v3_set(out, a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
	          a[0] * b[1] - a[1] * b[0]);
}

static inline float bc_v3_len(const float a[3])
{
	return sqrtf(bc_v3_dot(a, a));
}

/* Scales a to unit length and returns its old length; a zero (or not
 * finite) vector is left as it is, so callers test the result. */
static inline float bc_v3_normalize(float a[3])
{
	float n = bc_v3_len(a);
	if (n > 0.0f && isfinite(n)) {
		bc_v3_scale(a, 1.0f / n, a);
	}
	return n;
}

/* Divides a by its length when that is above zero: the camera's rays and
 * the light direction, whose images are compared bit for bit, were made
 * this way (a division rounds differently from bc_v3_normalize's product
 * with the reciprocal). */
static inline void bc_v3_normalize_div(float a[3])
{
	float n = bc_v3_len(a);
	if (n > 0.0f) {
		bc_v3_set(a, a[0] / n, a[1] / n, a[2] / n);
	}
}

static inline void bc_quat_identity(float q[4])
{
	q[0] = q[1] = q[2] = 0.0f;
	q[3] = 1.0f;
}

/* Rotation by angle radians about the unit axis (x, y, z). */
static inline void bc_quat_axis_angle(float q[4], float x, float y, float z,
                                      float angle)
{
	float s = sinf(0.5f * angle);
	q[0] = x * s;
	q[1] = y * s;
	q[2] = z * s;
	q[3] = cosf(0.5f * angle);
}

/* out = a * b: the rotation b, then a. */
static inline void bc_quat_mul(const float a[4], const float b[4], float out[4])
{
	float r[4];
	r[0] = a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1];
	r[1] = a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0];
	r[2] = a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3];
	r[3] = a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2];
	for (int i = 0; i < 4; i++) {
		out[i] = r[i];
	}
}

/* Scales q to unit length; a zero quaternion becomes the identity. */
static inline void bc_quat_normalize(float q[4])
{
	float n = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	if (!(n > 0.0f) || !isfinite(n)) {
		bc_quat_identity(q);
		return;
	}
	for (int i = 0; i < 4; i++) {
		q[i] /= n;
	}
}

/* out = q v q^-1 for a unit q, as v + 2w (u x v) + 2 u x (u x v) with
 * u = q.xyz. */
static inline void bc_quat_rotate(const float q[4], const float v[3],
                                  float out[3])
{
	float t[3], r[3];
	t[0] = 2.0f * (q[1] * v[2] - q[2] * v[1]);
	t[1] = 2.0f * (q[2] * v[0] - q[0] * v[2]);
	t[2] = 2.0f * (q[0] * v[1] - q[1] * v[0]);
	r[0] = v[0] + q[3] * t[0] + (q[1] * t[2] - q[2] * t[1]);
	r[1] = v[1] + q[3] * t[1] + (q[2] * t[0] - q[0] * t[2]);
	r[2] = v[2] + q[3] * t[2] + (q[0] * t[1] - q[1] * t[0]);
	bc_v3_set(out, r[0], r[1], r[2]);
}

#endif
