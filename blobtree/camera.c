/*
 * Cameras: the scene's camera and the pixel rays derived from it. Pixel
 * (i, j), j counted from the top row, looks through the pixel centre; the
 * vertical field of view is fov_y_deg; directions are unit length so that
 * ray parameters are world distances.
 */
#include "blobcast/blobtree.h"

#include <math.h>

#include "blobcast/vec.h"

void bc_camera_default(struct bc_camera *cam)
{
	*cam = (struct bc_camera){
	    .eye = {0.0f, 0.0f, 6.0f},
	    .target = {0.0f, 0.0f, 0.0f},
	    .up = {0.0f, 1.0f, 0.0f},
	    .fov_y_deg = 45.0f,
	};
}

int bc_camera_validate(const struct bc_camera *cam, struct bc_errinfo *ei)
{
	float fwd[3], side[3];
	for (int i = 0; i < 3; i++) {
		if (!isfinite(cam->eye[i]) || !isfinite(cam->target[i]) ||
		    !isfinite(cam->up[i])) {
			return bc_errinfo_set(ei, BC_ENONFINITE,
			                      "camera: coordinates must be "
			                      "finite");
		}
		if (fabsf(cam->eye[i]) > BC_PARAM_MAX_ABS ||
		    fabsf(cam->target[i]) > BC_PARAM_MAX_ABS) {
			return bc_errinfo_set(ei, BC_ERANGE,
			                      "camera: coordinates beyond %g",
			                      (double)BC_PARAM_MAX_ABS);
		}
	}
	if (!(cam->fov_y_deg > 0.0f && cam->fov_y_deg < 180.0f)) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "camera: fov_y_deg %g outside (0, 180)",
		                      (double)cam->fov_y_deg);
	}
	bc_v3_sub(cam->target, cam->eye, fwd);
	if (!(bc_v3_len(fwd) > 1e-6f)) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "camera: eye and target coincide");
	}
	bc_v3_normalize_div(fwd);
	bc_v3_cross(fwd, cam->up, side);
	if (!(bc_v3_len(side) > 1e-6f * (bc_v3_len(cam->up) + 1e-30f)) ||
	    !(bc_v3_len(cam->up) > 0.0f)) {
		return bc_errinfo_set(ei, BC_ERANGE,
		                      "camera: up is zero or parallel to the "
		                      "view direction");
	}
	return 0;
}

void bc_view_rays_init(struct bc_view_rays *vr, const struct bc_camera *cam,
                       uint32_t width, uint32_t height)
{
	const float pi = 3.14159265358979f;
	vr->eye[0] = cam->eye[0];
	vr->eye[1] = cam->eye[1];
	vr->eye[2] = cam->eye[2];
	bc_v3_sub(cam->target, cam->eye, vr->forward);
	bc_v3_normalize_div(vr->forward);
	bc_v3_cross(vr->forward, cam->up, vr->right);
	bc_v3_normalize_div(vr->right);
	bc_v3_cross(vr->right, vr->forward, vr->up);
	vr->tan_half_y = tanf(cam->fov_y_deg * pi / 360.0f);
	vr->width = width ? width : 1;
	vr->height = height ? height : 1;
	vr->aspect = (float)vr->width / (float)vr->height;
	vr->x0 = 0;
	vr->y0 = 0;
}

void bc_view_rays_init_window(struct bc_view_rays *vr,
                              const struct bc_camera *cam, uint32_t width,
                              uint32_t height, uint32_t x0, uint32_t y0)
{
	bc_view_rays_init(vr, cam, width, height);
	vr->x0 = x0;
	vr->y0 = y0;
}

void bc_view_rays_dir(const struct bc_view_rays *vr, float x, float y,
                      float dir[3])
{
	float sx = (2.0f * (x + (float)vr->x0) / (float)vr->width - 1.0f) *
	           vr->tan_half_y * vr->aspect;
	float sy = (1.0f - 2.0f * (y + (float)vr->y0) / (float)vr->height) *
	           vr->tan_half_y;
	for (int i = 0; i < 3; i++) {
		dir[i] = vr->forward[i] + sx * vr->right[i] + sy * vr->up[i];
	}
	bc_v3_normalize_div(dir);
}
