// HUD lines and discs (the 4D axes gizmo), given in pixels (GL window coordinates, y up).
// DIAMOND: each instance is a filled diamond (a square on its corner) at in_a, in_width from
// tip to tip: the first-contact marker's shape, told from a Lemma 2 disc by its corners.
uniform vec2 u_viewport;

#if defined VERTEX_SHADER
in vec2 in_a;
in vec2 in_b;
in vec4 in_color;
in float in_width;
flat out vec4 v_ends;
flat out vec4 v_color;
flat out float v_half_width;

void main() {
    v_half_width = 0.5 * in_width;
    v_color = in_color;
    v_ends = vec4(in_a, in_b);
    vec2 d = in_b - in_a;
    float len = length(d);
    vec2 dir = len > 1e-4 ? d / len : vec2(1.0, 0.0);
    vec2 nrm = vec2(-dir.y, dir.x);
    float ext = v_half_width + 1.0;
    int k = gl_VertexID;
    vec2 px = (k >= 2 ? in_b + dir * ext : in_a - dir * ext) + nrm * ((k & 1) == 1 ? ext : -ext);
    gl_Position = vec4(px / u_viewport * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
#if defined DIAMOND
flat in vec4 v_ends;
flat in vec4 v_color;
flat in float v_half_width;
uniform int u_pass;
out vec4 f_color;

void main() {
    vec2 d = abs(gl_FragCoord.xy - v_ends.xy);
    // the distance to the nearest edge, |x| + |y| = half width, along its normal
    float dist = (d.x + d.y - v_half_width) * 0.70710678;
    float coverage = clamp(0.5 - dist, 0.0, 1.0);
    if (coverage <= 0.0) discard;
    f_color = vec4(v_color.rgb, v_color.a * (u_pass == 0 ? 1.0 : coverage));
}
#else
#include "line_fragment.glsl"
#endif
#endif
