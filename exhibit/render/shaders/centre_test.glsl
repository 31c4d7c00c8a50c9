// A curve is hidden where its centre line is: a wide line whose centre runs just behind a
// surface's outline would otherwise show the rim beyond the outline as a sliver (the depth
// test sees nothing there). The surfaces' own window depth per pixel (the sheet buffer,
// surface.glsl GBUFFER: .y, 0 where empty), when the frame has one: u_centre_test 1 reads the
// single-sampled texture, 2 the multisampled one, 0 none. Tested at each end of a segment in
// the vertex shader (per fragment it cost a quarter of a 1080p frame with many curves).
uniform int u_centre_test;
// How far the surfaces' triangles may lie from the true surfaces (gpu.mesh_sag), scene units.
uniform float u_sag;
uniform sampler2D u_surface_depth;
uniform sampler2DMS u_surface_depth_ms;

vec4 surface_at(ivec2 p) {
    return u_centre_test == 1 ? texelFetch(u_surface_depth, p, 0) : texelFetch(u_surface_depth_ms, p, 0);
}

// The mesh's sag (u_sag) at clip position c, in pixels on screen and in window depth: the
// longest a 4D offset of that length can move the point (the clip map's Jacobian there).
vec2 sag_on_screen(vec4 c) {
    mat4 rows = transpose(u_M);
    vec3 ndc = c.xyz / c.w;
    vec4 jx = (rows[0] - ndc.x * rows[3]) / c.w;
    vec4 jy = (rows[1] - ndc.y * rows[3]) / c.w;
    vec4 jz = (rows[2] - ndc.z * rows[3]) / c.w;
    float px = 0.5 * max(length(jx) * u_viewport.x, length(jy) * u_viewport.y);
    return u_sag * vec2(px, 0.5 * length(jz));
}

// Whether a surface lies in front of the point at pixel position ``centre`` and window depth
// ``z`` (clip position ``c``): the depth planes of the pixels around it (each pixel's window
// depth and its screen gradient) carried to the point itself, so a point just outside the
// surface's last pixels is still seen behind it. A plane is the surface's own only at its
// pixel: carried d pixels, towards a fold, where the sheet turns away and is seen edge-on, it
// is off by up to what it spans over d (its slope grows without bound there). So a sheet hides
// the point only by more than its plane spans over d, half a pixel and the mesh's sag (the
// curve lies on the true surface, the triangles within the sag of it). With half a pixel and no
// sag, a curve on the outline fell in front of and behind the planes by turns: Figure 9's offset
// curve in dashes. A flat sheet has no slope and hides what is behind it by any depth.
float centre_hidden(vec2 centre, float z, vec4 c) {
    if (u_centre_test == 0) return 0.0;
    ivec2 size = u_centre_test == 1 ? textureSize(u_surface_depth, 0)
                                    : textureSize(u_surface_depth_ms);
    vec2 sag = sag_on_screen(c);
    ivec2 q = ivec2(floor(centre));
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 p = clamp(q + ivec2(dx, dy), ivec2(0), size - 1);
            vec4 g = surface_at(p);
            if (g.y <= 0.0) continue;   // empty
            vec2 d = centre - (vec2(p) + 0.5);
            float plane = g.y + dot(g.zw, d);
            vec2 reach = abs(d) + 0.5 + sag.x;
            if (z > plane + dot(reach, abs(g.zw)) + sag.y) return 1.0;
        }
    }
    return 0.0;
}
