// A vertical gradient behind everything (a full-screen triangle, no vertex buffer), at the far
// plane: drawn with the depth test always passing and depth writes on, it also clears depth.
#if defined VERTEX_SHADER
#include "fullscreen.glsl"
out float v_y;
void main() {
    vec2 p = fullscreen_corner();
    v_y = p.y * 0.5 + 0.5;
    gl_Position = vec4(p, 1.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
uniform vec3 u_top;
uniform vec3 u_bottom;
in float v_y;
out vec4 f_color;
void main() { f_color = vec4(mix(u_bottom, u_top, clamp(v_y, 0.0, 1.0)), 1.0); }
#endif
