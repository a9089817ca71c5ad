/*
 * The viewer's geometry: its own camera, moved by the mouse and sent to the
 * server as CAMERA, and the projections the highlight and the drag need.
 * Every basis comes from bc_view_rays_init(), the function the renderers
 * use, so that a point this file projects to pixel (x, y) is the point the
 * server draws there and a PICK at (x, y) names.
 */
#include <math.h>
#include <string.h>

#include "blobcast/proto_limits.h"
#include "blobcast/vec.h"
#include "viewer.h"

/* Rotates v about the unit axis k by angle a (Rodrigues' formula). */
static void rotate3(const float v[3], const float k[3], float a, float out[3])
{
	float c = cosf(a), s = sinf(a), kv[3], d = bc_v3_dot(k, v);
	bc_v3_cross(k, v, kv);
	for (int i = 0; i < 3; i++) {
		out[i] = v[i] * c + kv[i] * s + k[i] * d * (1.0f - c);
	}
}

void bc_viewer_orbit(struct bc_camera *cam, float dx, float dy)
{
	float off[3], up[3], right[3], turned[3], n;
	bc_v3_sub(cam->eye, cam->target, off);
	memcpy(up, cam->up, sizeof(up));
	if ((n = bc_v3_len(up)) <= 0.0f) {
		return;
	}
	for (int i = 0; i < 3; i++) {
		up[i] /= n;
	}
	rotate3(off, up, -dx * BC_VIEWER_ORBIT_PER_PX, off);
	bc_v3_cross(off, up, right);
	if ((n = bc_v3_len(right)) > 0.0f) {
		for (int i = 0; i < 3; i++) {
			right[i] /= n;
		}
		rotate3(off, right, dy * BC_VIEWER_ORBIT_PER_PX, turned);
		/* Past the pole the view would flip (and at it the server
		 * refuses the camera): keep the last good elevation. */
		if (fabsf(bc_v3_dot(turned, up)) <
		    BC_VIEWER_ORBIT_MAX_COS * bc_v3_len(turned)) {
			memcpy(off, turned, sizeof(off));
		}
	}
	for (int i = 0; i < 3; i++) {
		cam->eye[i] = cam->target[i] + off[i];
	}
}

float bc_viewer_pixel_size(const struct bc_camera *cam, float z,
                           uint32_t height)
{
	struct bc_view_rays vr;
	bc_view_rays_init(&vr, cam, 1, height);
	return 2.0f * z * vr.tan_half_y / (float)vr.height;
}

void bc_viewer_pan(struct bc_camera *cam, float dx, float dy, uint32_t height)
{
	struct bc_view_rays vr;
	float off[3], s;
	bc_view_rays_init(&vr, cam, 1, height);
	bc_v3_sub(cam->target, cam->eye, off);
	s = bc_viewer_pixel_size(cam, bc_v3_len(off), height);
	/* The scene follows the mouse: dragging right moves the camera
	 * left. */
	for (int i = 0; i < 3; i++) {
		float m = -dx * s * vr.right[i] + dy * s * vr.up[i];
		cam->eye[i] += m;
		cam->target[i] += m;
	}
}

void bc_viewer_zoom(struct bc_camera *cam, float steps)
{
	float off[3], d, nd;
	bc_v3_sub(cam->eye, cam->target, off);
	if ((d = bc_v3_len(off)) <= 0.0f) {
		return;
	}
	nd = d * expf(steps * 0.1f);
	nd = fminf(fmaxf(nd, BC_VIEWER_ZOOM_MIN), BC_VIEWER_ZOOM_MAX);
	for (int i = 0; i < 3; i++) {
		cam->eye[i] = cam->target[i] + off[i] * (nd / d);
	}
}

void bc_viewer_cam_clamp(struct bc_camera *cam)
{
	const float m = BC_PROTO_MAX_ABS;
	for (int i = 0; i < 3; i++) {
		cam->eye[i] = fminf(fmaxf(cam->eye[i], -m), m);
		cam->target[i] = fminf(fmaxf(cam->target[i], -m), m);
	}
}

bool bc_viewer_project(const struct bc_camera *cam, uint32_t width,
                       uint32_t height, const float p[3], float out[3])
{
	struct bc_view_rays vr;
	float d[3], z, x, y;
	bc_view_rays_init(&vr, cam, width, height);
	bc_v3_sub(p, vr.eye, d);
	z = bc_v3_dot(d, vr.forward);
	if (!(z > 1e-6f)) {
		return false;
	}
	/* The inverse of bc_view_rays_dir(): normalized screen coordinates
	 * in [-1, 1], then pixels. */
	x = bc_v3_dot(d, vr.right) / (z * vr.tan_half_y * vr.aspect);
	y = bc_v3_dot(d, vr.up) / (z * vr.tan_half_y);
	out[0] = (x + 1.0f) * 0.5f * (float)vr.width;
	out[1] = (1.0f - y) * 0.5f * (float)vr.height;
	out[2] = z;
	return true;
}

void bc_viewer_move_in_plane(const struct bc_camera *cam, uint32_t height,
                             const float origin[3], float z, float dx, float dy,
                             float out[3])
{
	struct bc_view_rays vr;
	float s = bc_viewer_pixel_size(cam, z, height);
	bc_view_rays_init(&vr, cam, 1, height);
	for (int i = 0; i < 3; i++) {
		out[i] = origin[i] + dx * s * vr.right[i] - dy * s * vr.up[i];
	}
}

bool bc_viewer_node_box(const struct bc_tree *t, uint32_t id, float lo[3],
                        float hi[3])
{
	return t && bc_tree_node_box(t, id, lo, hi) == 0;
}

void bc_viewer_frame_box(struct bc_camera *cam, const float lo[3],
                         const float hi[3], float aspect)
{
	float dir[3], c[3], d[3], r, n, half_y, half_x, half, dist;
	bc_v3_sub(cam->eye, cam->target, dir);
	if (!((n = bc_v3_len(dir)) > 0.0f) || !isfinite(n)) {
		return;
	}
	for (int i = 0; i < 3; i++) {
		c[i] = 0.5f * (lo[i] + hi[i]);
		d[i] = hi[i] - lo[i];
		dir[i] /= n;
	}
	/* The sphere around the box fits whatever the view direction. */
	r = 0.5f * bc_v3_len(d);
	if (!isfinite(r) || !(aspect > 0.0f)) {
		return;
	}
	r = fmaxf(r, BC_VIEWER_ZOOM_MIN);
	half_y = 0.5f * cam->fov_y_deg * 3.14159265f / 180.0f;
	half_x = atanf(tanf(half_y) * aspect);
	half = fminf(half_y, half_x);
	dist = r / sinf(half) * BC_VIEWER_FIT_MARGIN;
	dist = fminf(fmaxf(dist, BC_VIEWER_ZOOM_MIN), BC_VIEWER_ZOOM_MAX);
	for (int i = 0; i < 3; i++) {
		cam->target[i] = c[i];
		cam->eye[i] = c[i] + dir[i] * dist;
	}
	bc_viewer_cam_clamp(cam);
}

const uint8_t bc_viewer_box_edges[12][2] = {
    {0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
    {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7},
};

void bc_viewer_box_corners(const struct bc_prim_data *p, float corners[8][3])
{
	struct bc_abv b;
	float center[3] = {0.0f, 0.0f, 0.0f}, axis[3][3] = {{0.0f}},
	      half[3] = {0.0f, 0.0f, 0.0f};
	bc_prim_bound(p, &b);
	switch (b.shape) {
	case BC_ABV_BOX:
		memcpy(center, b.center, sizeof(center));
		memcpy(axis, b.axis, sizeof(axis));
		memcpy(half, b.half, sizeof(half));
		break;
	case BC_ABV_CAPSULE:
		/* The local box around the segment and its radius. */
		for (int i = 0; i < 3; i++) {
			float lo = fminf(b.center[i], b.end[i]) - b.radius;
			float hi = fmaxf(b.center[i], b.end[i]) + b.radius;
			center[i] = 0.5f * (lo + hi);
			half[i] = 0.5f * (hi - lo);
			axis[i][i] = 1.0f;
		}
		break;
	case BC_ABV_SPHERE:
	default:
		memcpy(center, b.center, sizeof(center));
		for (int i = 0; i < 3; i++) {
			half[i] = b.radius;
			axis[i][i] = 1.0f;
		}
		break;
	}
	for (int k = 0; k < 8; k++) {
		float local[3];
		for (int i = 0; i < 3; i++) {
			local[i] = center[i];
		}
		for (int a = 0; a < 3; a++) {
			float s = ((k >> a) & 1) ? half[a] : -half[a];
			for (int i = 0; i < 3; i++) {
				local[i] += s * axis[a][i];
			}
		}
		bc_quat_rotate(p->rotate, local, corners[k]);
		for (int i = 0; i < 3; i++) {
			corners[k][i] += p->translate[i];
		}
	}
}

int bc_viewer_size_param(enum bc_prim kind)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	if (!info) {
		return -1;
	}
	for (int k = 0; k < (int)info->nparams; k++) {
		if (info->params[k].flags & BC_PARAM_POSITIVE) {
			return k;
		}
	}
	for (int k = 0; k < (int)info->nparams; k++) {
		if (info->params[k].flags & BC_PARAM_NONNEG) {
			return k;
		}
	}
	return -1;
}
