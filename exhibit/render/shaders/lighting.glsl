// Two-sided Blinn-Phong in eye coordinates (x right, y up, z towards the viewer): the normal is
// flipped towards the eye, because a projected 4D surface has no consistent outside.
uniform vec3 u_lights[2];     // towards the key and fill lights (unit; zero = off)
uniform vec3 u_color;
uniform vec2 u_w_range;       // view w mapped to the ends of the depth ramp (DEPTH_COLOUR)

vec3 depth_ramp(float w) {
    float t = clamp((w - u_w_range.x) / max(u_w_range.y - u_w_range.x, 1e-6), 0.0, 1.0);
    // far (negative w, away from the sensor) blue -> white -> near (towards the sensor) orange
    vec3 far = vec3(0.18, 0.36, 0.95), mid = vec3(0.92, 0.92, 0.88), near = vec3(0.98, 0.45, 0.12);
    return t < 0.5 ? mix(far, mid, t * 2.0) : mix(mid, near, t * 2.0 - 1.0);
}

vec3 shade(vec3 normal, vec3 to_eye, float view_w) {
    vec3 V = normalize(to_eye);
    float len = length(normal);
    vec3 N = len > 1e-12 ? normal / len : V;   // Lemma 2 points: the projected normal vanishes
    if (dot(N, V) < 0.0) N = -N;
#if defined DEPTH_COLOUR
    vec3 base = depth_ramp(view_w);
#else
    vec3 base = u_color;
#endif
    vec3 L0 = u_lights[0], L1 = u_lights[1];
    float diffuse = max(dot(N, L0), 0.0) + 0.45 * max(dot(N, L1), 0.0);
    float h0 = max(dot(N, normalize(L0 + V)), 0.0), h1 = max(dot(N, normalize(L1 + V)), 0.0);
    h0 *= h0; h0 *= h0; h0 *= h0; h0 *= h0; h0 *= h0;   // ^32 by squaring: no exp/log
    h1 *= h1; h1 *= h1; h1 *= h1; h1 *= h1; h1 *= h1;
    float grazing = 1.0 - max(dot(N, V), 0.0);
    float rim = 1.0 - 0.35 * grazing * grazing * grazing;  // darken grazing views
    return (base * (0.22 + 0.78 * diffuse) + 0.28 * (h0 + 0.45 * h1)) * rim;
}
