// blobcast-view: every draw is 2-D, in window pixels with the origin at the
// top left (as mouse positions and the server's pixel rows count), turned
// into clip space here. Written for both GLSL 1.10 (GL 2.1) and GLSL ES
// 1.00 (GLES 2): no #version line, whose absence means exactly those.
attribute vec2 a_pos;
attribute vec2 a_uv;
uniform vec2 u_size;
varying vec2 v_uv;

void main()
{
	v_uv = a_uv;
	gl_Position = vec4(a_pos.x / u_size.x * 2.0 - 1.0,
			   1.0 - a_pos.y / u_size.y * 2.0, 0.0, 1.0);
}
