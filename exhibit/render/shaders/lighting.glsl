// Two-sided Blinn-Phong in eye coordinates (x right, y up, z towards the viewer): the normal is
// flipped towards the eye, because a projected 4D surface has no consistent outside.
uniform vec3 u_lights[4];
uniform int u_light_count;
uniform vec3 u_color;
uniform int u_depth_colour;   // 1: colour by 4D depth (view w) instead of the material
uniform vec2 u_w_range;       // view w mapped to the ends of the depth ramp

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
    vec3 base = u_depth_colour == 1 ? depth_ramp(view_w) : u_color;
    vec3 diffuse = vec3(0.0);
    float specular = 0.0;
    for (int i = 0; i < u_light_count; ++i) {
        vec3 L = u_lights[i];
        float weight = i == 0 ? 1.0 : 0.45;
        diffuse += weight * vec3(max(dot(N, L), 0.0));
        specular += weight * pow(max(dot(N, normalize(L + V)), 0.0), 48.0);
    }
    float rim = 1.0 - 0.35 * pow(1.0 - max(dot(N, V), 0.0), 3.0);  // darken grazing views
    return (base * (0.22 + 0.78 * diffuse) + 0.28 * specular) * rim;
}
