#version 430 core
// A-buffer pass, vertex stage: one point per primitive, drawn without vertex
// buffers; the geometry stage reads the primitive's ABV itself.
#include "common.glsl"

flat out uint v_prim;

void main()
{
	v_prim = uint(gl_VertexID);
	gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
