// The benchmark's CPU baseline: numpy computed clip positions, clip distances and the projected
// normals; this shader only passes them on and lights them like the real pipeline.
#if defined VERTEX_SHADER
in vec4 in_clip;
in vec2 in_clip_distance;
in vec3 in_normal;
in vec3 in_to_eye;
out vec3 v_normal;
out vec3 v_to_eye;
void main() {
    v_normal = in_normal;
    v_to_eye = in_to_eye;
    gl_Position = in_clip;
    gl_ClipDistance[0] = in_clip_distance.x;
    gl_ClipDistance[1] = in_clip_distance.y;
}
#endif
#if defined FRAGMENT_SHADER
#include "lighting.glsl"
in vec3 v_normal;
in vec3 v_to_eye;
out vec4 f_color;
void main() { f_color = vec4(shade(v_normal, v_to_eye, 0.0), 1.0); }
#endif
