// Curves (fibres, axes, scene silhouettes, wire meshes) and markers: one instance per segment,
// four strip vertices per instance. A marker is a segment of length zero (a disc).
#include "pipeline.glsl"
#include "lines_common.glsl"

#if defined VERTEX_SHADER
in vec4 in_p0;
in vec4 in_p1;
in vec4 in_style;   // rgb, width in px (before u_width_scale)
in float in_layer;  // the curve's place in the mesh (0 first; markers 0)
uniform float u_width_scale;
// NDC depth between two layers: curves that coincide in the picture (a fibre seen edge-on along
// an axis) are drawn in the mesh's order instead of fighting pixel by pixel; 16 steps of a
// 24-bit depth buffer, and at most LAYERS of them, a fifth of u_line_bias.
const float LAYER_STEP = 2e-6;
flat out vec4 v_ends;
flat out vec4 v_color;
flat out float v_half_width;
out float v_hidden;
#include "centre_test.glsl"

void main() {
    vec4 c0 = to_clip(in_p0), c1 = to_clip(in_p1);
    v_color = vec4(in_style.rgb, 1.0);
    v_half_width = 0.5 * max(in_style.w * u_width_scale, 1.0);
    if (!clip_segment(c0, c1, line_distances(in_p0, c0), line_distances(in_p1, c1))) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // wholly clipped: a degenerate, culled quad
        v_ends = vec4(0.0);
        v_hidden = 0.0;
        return;
    }
    gl_Position = line_corner(c0, c1, v_half_width, gl_VertexID, v_ends);
    gl_Position.z += in_layer * LAYER_STEP * gl_Position.w;
    // This corner's end of the centre line: hidden behind a surface or not (its window depth
    // as the fragments get it, bias and layer included).
    vec4 e = gl_VertexID >= 2 ? c1 : c0;
    float z = 0.5 + 0.5 * (e.z / e.w - u_line_bias + in_layer * LAYER_STEP);
    v_hidden = centre_hidden(gl_VertexID >= 2 ? v_ends.zw : v_ends.xy, z, e);
}
#endif

#if defined FRAGMENT_SHADER
#define CENTRE_TEST
#include "line_fragment.glsl"
#endif
