// Screen-space thick lines: core-profile GL has no wide lines, so every segment is a quad
// expanded in pixels around its clipped end points; the fragment shader cuts a capsule out of it.

uniform float u_line_bias;  // NDC depth pulled towards the viewer, so curves on a surface win

// Plane distances of a point for the line clipper: sensor hyperplane, front plane, eye's near
// and far planes. A segment is cut where one becomes negative (Liang-Barsky), exactly as the
// GPU clips triangles, so no segment is ever drawn through infinity.
vec4 line_distances(vec4 p, vec4 c) {
    // The sensor plane is cut a hair in front of H = 0: points there project to infinity.
    return vec4(sensor_plane(p) - 1e-5, front_plane(p), c.z + c.w, c.w - c.z);
}

bool clip_segment(inout vec4 c0, inout vec4 c1, vec4 d0, vec4 d1) {
    float t0 = 0.0, t1 = 1.0;
    for (int i = 0; i < 4; ++i) {
        float a = d0[i], b = d1[i];
        if (a < 0.0 && b < 0.0) return false;
        if (a < 0.0) t0 = max(t0, a / (a - b));
        else if (b < 0.0) t1 = min(t1, a / (a - b));
    }
    if (t0 > t1) return false;
    vec4 e0 = mix(c0, c1, t0);
    vec4 e1 = mix(c0, c1, t1);
    c0 = e0;
    c1 = e1;
    return true;
}

vec2 clip_to_pixels(vec4 c) { return (c.xy / c.w * 0.5 + 0.5) * u_viewport; }

// Corner k (0..3, triangle-strip order) of the quad around segment c0-c1 of half width hw px.
// ends receives the two end points in pixels for the fragment shader's capsule test.
vec4 line_corner(vec4 c0, vec4 c1, float hw, int k, out vec4 ends) {
    vec2 a0 = clip_to_pixels(c0);
    vec2 a1 = clip_to_pixels(c1);
    ends = vec4(a0, a1);
    vec2 d = a1 - a0;
    float len = length(d);
    vec2 dir = len > 1e-4 ? d / len : vec2(1.0, 0.0);
    vec2 nrm = vec2(-dir.y, dir.x);
    float ext = hw + 1.0;  // one more pixel for the antialiased rim
    bool far_end = k >= 2;
    float side = (k & 1) == 1 ? 1.0 : -1.0;
    vec4 c = far_end ? c1 : c0;
    vec2 px = (far_end ? a1 + dir * ext : a0 - dir * ext) + nrm * side * ext;
    vec2 ndc = px / u_viewport * 2.0 - 1.0;
    // The corner's depth is the line's own, carried on past the end by the cap: NDC depth is
    // affine in screen space along a line and is interpolated so, hence exact everywhere on
    // the quad. (The end's depth at the capped corner stretched it: two curves along one line,
    // cut into different segments, then crossed each other in depth at every joint.)
    float z0 = c0.z / c0.w, z1 = c1.z / c1.w;
    float t = len > 1e-4 ? (far_end ? 1.0 + ext / len : -ext / len) : (far_end ? 1.0 : 0.0);
    return vec4(ndc * c.w, (mix(z0, z1, t) - u_line_bias) * c.w, c.w);
}
