// Capsule coverage of a screen-space segment. Pass 0 draws the opaque core and writes depth;
// pass 1 adds the antialiased rim with blending and no depth writes, so joints never leave gaps.
flat in vec4 v_ends;
flat in vec4 v_color;   // rgb, alpha
flat in float v_half_width;
uniform int u_pass;
out vec4 f_color;
#if defined CENTRE_TEST
in float v_hidden;   // 1 where the centre line is behind a surface (centre_test.glsl)
#endif

void main() {
    vec2 p = gl_FragCoord.xy;
    vec2 a = v_ends.xy, b = v_ends.zw;
    vec2 ab = b - a;
    float h = clamp(dot(p - a, ab) / max(dot(ab, ab), 1e-8), 0.0, 1.0);
    float dist = length(p - a - h * ab);
    float coverage = clamp(v_half_width + 0.5 - dist, 0.0, 1.0);
#if defined CENTRE_TEST
    if (v_hidden > 0.5) discard;
#endif
    if (u_pass == 0) {
        if (coverage < 0.5) discard;
        f_color = vec4(v_color.rgb, v_color.a);
    } else {
        if (coverage <= 0.0) discard;
        f_color = vec4(v_color.rgb, v_color.a * coverage);
    }
}
