// blobcast-view: the frame texture (u_textured = 1) or a flat colour for
// the overlay's text, panels and outlines (u_textured = 0). Frames are
// opaque: their alpha is ignored. GLSL ES needs a default float precision;
// desktop GLSL 1.10 has no precision qualifiers, hence the #ifdef.
#ifdef GL_ES
precision mediump float;
#endif
uniform sampler2D u_tex;
uniform vec4 u_color;
uniform float u_textured;
varying vec2 v_uv;

void main()
{
	vec4 t = vec4(texture2D(u_tex, v_uv).rgb, 1.0);
	gl_FragColor = mix(u_color, t, u_textured);
}
