// Capsule coverage of a screen-space segment. Pass 0 draws the opaque core and writes depth;
// pass 1 adds the antialiased rim with blending and no depth writes, so joints never leave gaps.
flat in vec4 v_ends;
flat in vec4 v_color;   // rgb, alpha
flat in float v_half_width;
uniform int u_pass;
out vec4 f_color;
#if defined CENTRE_TEST
// A curve is hidden where its centre line is: a wide line whose centre runs just behind a
// surface's outline would otherwise show the rim beyond the outline as a sliver (the depth
// test sees nothing there). The surfaces' own window depth per pixel (the sheet buffer,
// surface.glsl GBUFFER: .y, 0 where empty), when the frame has one: u_centre_test 1 reads the
// single-sampled texture, 2 the multisampled one, 0 none.
uniform int u_centre_test;
uniform sampler2D u_surface_depth;
uniform sampler2DMS u_surface_depth_ms;

vec4 surface_at(ivec2 p) {
    return u_centre_test == 1 ? texelFetch(u_surface_depth, p, 0) : texelFetch(u_surface_depth_ms, p, 0);
}

// Hidden when a surface lies in front of the centre point: the depth planes of the pixels
// around it (each pixel's window depth and its screen gradient), carried to the centre itself,
// so a centre that falls just outside the surface's last pixels is still seen behind it.
bool centre_hidden(vec2 centre) {
    if (u_centre_test == 0) return false;
    ivec2 size = u_centre_test == 1 ? textureSize(u_surface_depth, 0)
                                    : textureSize(u_surface_depth_ms);
    ivec2 c = ivec2(floor(centre));
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 p = clamp(c + ivec2(dx, dy), ivec2(0), size - 1);
            vec4 g = surface_at(p);
            if (g.y <= 0.0) continue;   // empty
            // The plane carried to the centre, less half the depth it spans over a pixel: within
            // a pixel of a fold, seen edge-on, the front and back sheets are that close.
            float z = g.y + dot(g.zw, centre - (vec2(p) + 0.5));
            float slack = 0.5 * (abs(g.z) + abs(g.w));
            // gl_FragCoord.z is the line's depth at this point of its centre (constant across).
            if (gl_FragCoord.z > z + slack) return true;
        }
    }
    return false;
}
#endif

void main() {
    vec2 p = gl_FragCoord.xy;
    vec2 a = v_ends.xy, b = v_ends.zw;
    vec2 ab = b - a;
    float h = clamp(dot(p - a, ab) / max(dot(ab, ab), 1e-8), 0.0, 1.0);
    float dist = length(p - a - h * ab);
    float coverage = clamp(v_half_width + 0.5 - dist, 0.0, 1.0);
#if defined CENTRE_TEST
    if (centre_hidden(a + h * ab)) discard;
#endif
    if (u_pass == 0) {
        if (coverage < 0.5) discard;
        f_color = vec4(v_color.rgb, v_color.a);
    } else {
        if (coverage <= 0.0) discard;
        f_color = vec4(v_color.rgb, v_color.a * coverage);
    }
}
