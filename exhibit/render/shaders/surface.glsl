// Surfaces: 4D positions and two unit 4D normals per vertex, uploaded once. Per frame only the
// uniforms change; the vertex shader does the paper's whole pipeline.
#include "pipeline.glsl"

#if defined VERTEX_SHADER
in vec4 in_pos;
in vec4 in_n1;
in vec4 in_n2;
out vec3 v_normal;
out vec3 v_to_eye;
#if defined DEPTH_COLOUR || defined GBUFFER
out float v_w;
#endif
#if defined GBUFFER
out vec2 v_clip_zw;
#endif

void main() {
    vec4 q = u_R * in_pos + u_t;
    vec4 m1 = u_R * in_n1;
    vec4 m2 = u_R * in_n2;
    vec4 rho = sensor_ray(q);
    // Lemma 1(c): the combination of n1, n2 orthogonal to the ray; dropping w gives the normal
    // of the projected surface v(S) at v(p).
    v_normal = (dot(m2, rho) * m1 - dot(m1, rho) * m2).xyz;
    // Towards the eye from v(p) = q.xyz / H, times r2 * H > 0 so it stays finite: (0, 0, H) - r2 q.
    v_to_eye = vec3(0.0, 0.0, rho.w) - u_r2 * q.xyz;
#if defined DEPTH_COLOUR || defined GBUFFER
    v_w = q.w;
#endif
    gl_Position = to_clip(in_pos);
#if defined GBUFFER
    v_clip_zw = gl_Position.zw;
#endif
    gl_ClipDistance[0] = sensor_plane(in_pos);
    gl_ClipDistance[1] = front_plane(in_pos);
}
#endif

#if defined FRAGMENT_SHADER
#if defined TRIANGLE_IDS || defined OBJECT_IDS
uniform int u_id_offset;
out vec4 f_color;
void main() {
#if defined OBJECT_IDS
    // The whole surface in one flat colour, its object id (exhibit/render/passes/ids.py).
    int id = u_id_offset;
#else
    // Each triangle in a unique flat colour (id + 1; 0 is the background): tests read it back.
    int id = gl_PrimitiveID + u_id_offset + 1;
#endif
    f_color = vec4(float(id & 255), float((id >> 8) & 255), float((id >> 16) & 255), 255.0) / 255.0;
}
#else
#include "lighting.glsl"
in vec3 v_normal;
in vec3 v_to_eye;
#if defined DEPTH_COLOUR || defined GBUFFER
in float v_w;
#else
const float v_w = 0.0;
#endif
layout(location = 0) out vec4 f_color;
#if defined GBUFFER
// The intersection pass (intersect.glsl) reads, per pixel, which sheet of the 4D surface is in
// front and the plane of its depth on screen: (4D depth w after the pose, offset per surface so
// that different parts are always different sheets; window depth + 1, so 0 means empty; and
// the depth's screen gradient). The window depth is affine in screen space over a triangle, so
// the plane extrapolates exactly to the neighbouring pixels.
uniform float u_sheet;
in vec2 v_clip_zw;
layout(location = 1) out vec4 f_geometry;
#endif
void main() {
    // Alpha 254/255 marks a surface pixel for the FXAA pass (composite.glsl), which leaves the
    // already antialiased lines (alpha 255 or fractional) alone; it is opaque to the eye.
    f_color = vec4(shade(v_normal, v_to_eye, v_w), 254.0 / 255.0);
#if defined GBUFFER
    // The depth without the polygon offset (which differs between triangles and would move the
    // crossing): clip z / clip w, interpolated perspective-correctly, is affine on screen.
    float z = 0.5 + 0.5 * v_clip_zw.x / v_clip_zw.y;
    f_geometry = vec4(v_w + u_sheet, z, dFdx(z), dFdy(z));
#endif
}
#endif
#endif
