// A curve is hidden where its centre line is: a wide line whose centre runs just behind a
// surface's outline would otherwise show the rim beyond the outline as a sliver (the depth
// test sees nothing there). The surfaces' own window depth per pixel (the sheet buffer,
// surface.glsl GBUFFER: .y, 0 where empty), when the frame has one: u_centre_test 1 reads the
// single-sampled texture, 2 the multisampled one, 0 none. Tested at each end of a segment in
// the vertex shader (per fragment it cost a quarter of a 1080p frame with many curves).
uniform int u_centre_test;
uniform sampler2D u_surface_depth;
uniform sampler2DMS u_surface_depth_ms;

vec4 surface_at(ivec2 p) {
    return u_centre_test == 1 ? texelFetch(u_surface_depth, p, 0) : texelFetch(u_surface_depth_ms, p, 0);
}

// Whether a surface lies in front of the point at pixel position ``centre`` and window depth
// ``z``: the depth planes of the pixels around it (each pixel's window depth and its screen
// gradient) carried to the point itself, so a point just outside the surface's last pixels is
// still seen behind it; less half the depth a plane spans over a pixel, since within a pixel of
// a fold, seen edge-on, the front and back sheets are that close.
float centre_hidden(vec2 centre, float z) {
    if (u_centre_test == 0) return 0.0;
    ivec2 size = u_centre_test == 1 ? textureSize(u_surface_depth, 0)
                                    : textureSize(u_surface_depth_ms);
    ivec2 c = ivec2(floor(centre));
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 p = clamp(c + ivec2(dx, dy), ivec2(0), size - 1);
            vec4 g = surface_at(p);
            if (g.y <= 0.0) continue;   // empty
            float plane = g.y + dot(g.zw, centre - (vec2(p) + 0.5));
            if (z > plane + 0.5 * (abs(g.z) + abs(g.w))) return 1.0;
        }
    }
    return 0.0;
}
