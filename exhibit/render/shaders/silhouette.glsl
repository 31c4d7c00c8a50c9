// Live silhouettes for the current view, on the GPU, every frame.
//  * Lemma 3: the 4D -> 2D silhouette is the zero set of
//      s = (n1.rho1)(n2.rho2) - (n1.rho2)(n2.rho1)      (rho1 towards the sensor, rho2 the eye);
//    the geometry shader finds the segment where s changes sign in each triangle (marching
//    triangles, as exhibit.geometry.zero_set_segments) and emits it as a thick screen-space line.
//  * Lemma 2: points where the projected normal vanishes (rho in the tangent plane, i.e.
//    n1.rho1 = n2.rho1 = 0); generically isolated, claimed by the one triangle around which
//    u = P_N rho1 winds (exhibit/geometry/lemma2_marks.py, its CPU mirror) and marked with a disc.
//  * The slice S ∩ {x_a = c} (exhibit/surfaces/slice.py on the CPU): the zero set of
//    h = u_slice_axis.p - u_slice_at over the scene's own coordinates, drawn as a bright, wide
//    line (one opaque colour: a rim or a translucent halo drawn segment by segment would show
//    beads where neighbouring capsules overlap), singular points included. Where h touches
//    zero without changing sign (the hyperplane tangent to the surface along a curve) `touching()`
//    finds the dips of |h| on the triangle's edges (exhibit/geometry/touching.py in numpy).
// OUTLINES compiles the Lemma 3 ink alone (the outline pass): its vertices hand the geometry
// stage 10 components instead of 21, and on llvmpipe that stage's cost grows with every one.
#include "pipeline.glsl"
#include "lines_common.glsl"

#if defined VERTEX_SHADER
in vec4 in_pos;
in vec4 in_n1;
in vec4 in_n2;
in float in_mark;            // 1 where the vertex may mark Lemma 2 points (0 next to a singular one)
out vec4 g_clip;
out vec4 g_dist;
out float g_s;
// Two things in one value, since on llvmpipe the geometry stage's cost grows with every
// component a vertex hands it (a flat int of its own made a frame 3-5 ms slower): the vertex's
// index times 4 (exact below 2^22 vertices; an edge's two triangles agree on its frame by it)
// plus 2 at a singular point (zero normals), 1 next to one (no Lemma 2 mark), 0 elsewhere.
out float g_vertex;
#if !defined OUTLINES
out vec4 g_m1;
out vec4 g_m2;
out vec2 g_ab;
out float g_h;
#endif
#if defined TOUCHING
out vec4 g_hp;               // the scene position, and h's gradient along the surface (the
out vec4 g_hg;               // axis less its normal parts; normals are orthonormal or zero)
#endif
uniform vec4 u_slice_axis;   // unit vector of the slicing axis (scene coordinates)
uniform float u_slice_at;

void main() {
#if !defined OUTLINES
    g_h = dot(u_slice_axis, in_pos) - u_slice_at;
#endif
#if defined TOUCHING
    g_hp = in_pos;
    g_hg = u_slice_axis - dot(u_slice_axis, in_n1) * in_n1 - dot(u_slice_axis, in_n2) * in_n2;
#endif
    vec4 q = u_R * in_pos + u_t;
    vec4 m1 = u_R * in_n1;
    vec4 m2 = u_R * in_n2;
    vec4 rho1 = sensor_ray(q);
    vec4 rho2 = eye_ray(q);
    g_s = dot(m1, rho1) * dot(m2, rho2) - dot(m1, rho2) * dot(m2, rho1);
    float flag = dot(m1, m1) < 0.25 ? 2.0 : (in_mark > 0.5 ? 0.0 : 1.0);
    g_vertex = 4.0 * float(gl_VertexID) + flag;
    g_clip = to_clip(in_pos);
    g_dist = line_distances(in_pos, g_clip);
#if !defined OUTLINES
    g_m1 = m1;
    g_m2 = m2;
    g_ab = vec2(dot(m1, rho1), dot(m2, rho1));
#endif
}
#endif

#if defined GEOMETRY_SHADER
layout(triangles) in;
layout(triangle_strip, max_vertices = 16) out;
in vec4 g_clip[];
in vec4 g_dist[];
in float g_s[];
in float g_vertex[];
#if !defined OUTLINES
in vec4 g_m1[];
in vec4 g_m2[];
in vec2 g_ab[];
in float g_h[];
#endif
#if defined TOUCHING
in vec4 g_hp[];
in vec4 g_hg[];
#endif
uniform vec4 u_slice_style;  // rgb, core width in px (0: no slice drawn)
uniform vec4 u_ink;          // rgb, width in px (0: no silhouettes drawn)
uniform vec4 u_pinch;        // rgb, diameter in px (0: Lemma 2 points not marked)
uniform float u_width_scale;
flat out vec4 v_ends;
flat out vec4 v_color;
flat out float v_half_width;

void emit_segment(vec4 c0, vec4 c1, vec4 d0, vec4 d1, vec4 style, float lift, float alpha) {
    if (!clip_segment(c0, c1, d0, d1)) return;
    float hw = 0.5 * max(style.w * u_width_scale, 1.0);
    for (int k = 0; k < 4; ++k) {
        vec4 ends;
        gl_Position = line_corner(c0, c1, hw, k, ends);
        gl_Position.z -= lift * gl_Position.w;
        v_ends = ends;
        v_color = vec4(style.rgb, alpha);
        v_half_width = hw;
        EmitVertex();
    }
    EndPrimitive();
}

// A corner's flag: 2 singular, 1 next to a singular point, 0 (see g_vertex).
float flag_of(int k) { return g_vertex[k] - 4.0 * floor(0.25 * g_vertex[k]); }

// The segment where a per-vertex value changes sign on this triangle, as clip positions and
// clip distances at its two ends; false when it does not cross.
bool crossing(float v[3], out vec4 c[2], out vec4 d[2]) {
    int n = 0;
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        float a = v[i], b = v[j];
        if ((a > 0.0) != (b > 0.0) && n < 2) {
            float t = a / (a - b);
            c[n] = mix(g_clip[i], g_clip[j], t);
            d[n] = mix(g_dist[i], g_dist[j], t);
            ++n;
        }
    }
    return n == 2;
}

#if defined OUTLINES
void main() {
    vec4 c[2];
    vec4 d[2];
    if (max(max(flag_of(0), flag_of(1)), flag_of(2)) >= 2.0) return;  // never silhouettes
    if (u_ink.w > 0.0 && crossing(float[3](g_s[0], g_s[1], g_s[2]), c, d))
        emit_segment(c[0], c[1], d[0], d[1], u_ink, 0.0, 1.0);
}
#else
// How far outside a triangle (in barycentric coordinates) u's interpolant may vanish for the
// triangle to be checked for a winding (exhibit.geometry.lemma2_marks.MARGIN).
const float LEMMA2_MARGIN = 0.5;

// The angle by which u turns from ua to ub, both seen in the normal frame (m1, m2) of ua's
// corner (exhibit.geometry.lemma2_marks.edge_turns).
float turn_in(vec4 ua, vec4 ub, vec4 m1, vec4 m2) {
    vec2 a = vec2(dot(ua, m1), dot(ua, m2));
    vec2 b = vec2(dot(ub, m1), dot(ub, m2));
    float y = a.x * b.y - a.y * b.x, x = dot(a, b);
    return (x == 0.0 && y == 0.0) ? 0.0 : atan(y, x);
}

// The turn from corner i to corner j, measured from the corner with the lower vertex index.
// Both orders are computed and one chosen, with constant indices only: indexing the corners'
// arrays by a value known at run time made llvmpipe's geometry stage 5 ms slower a frame.
#define EDGE_TURN(i, j) (g_vertex[i] < g_vertex[j] \
    ? turn_in(u[i], u[j], g_m1[i], g_m2[i]) : -turn_in(u[j], u[i], g_m1[j], g_m2[j]))

#if defined TOUCHING  // only the sliced frames' program (the slice at tangency)
// The segment where h touches zero on this triangle without changing sign, or false: on each
// edge whose ends have the same sign (neither singular), the cubic Hermite interpolant of h and
// its derivatives along the surface; where |h| dips, its lowest value must be within
// TOUCH_TOLERANCE of the derivative's change across the edge (about curvature x length^2), and
// reach zero or come within SAME_SIDE_TOLERANCE of it (exhibit/geometry/touching.py).
const float TOUCH_TOLERANCE = 0.02;
const float SAME_SIDE_TOLERANCE = 2e-3;
bool touching(out vec4 c[2], out vec4 d[2]) {
    int n = 0;
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        float h0 = g_h[i], h1 = g_h[j];
        if (n == 2 || (h0 > 0.0) != (h1 > 0.0) || h0 == 0.0 || h1 == 0.0) continue;
        if (max(flag_of(i), flag_of(j)) >= 2.0) continue;
        vec4 e = g_hp[j] - g_hp[i];
        float sg = h0 > 0.0 ? 1.0 : -1.0;
        float d0 = dot(g_hg[i], e), d1 = dot(g_hg[j], e);
        if (sg * d0 >= 0.0 || sg * d1 <= 0.0) continue;   // |h| does not dip
        float a = 3.0 * (h1 - h0) - 2.0 * d0 - d1;
        float b = 2.0 * (h0 - h1) + d0 + d1;
        float lo = 0.0, hi = 1.0;
        for (int k = 0; k < 16; ++k) {                     // the root of H' on [0, 1]
            float m = 0.5 * (lo + hi);
            if (sg * (d0 + m * (2.0 * a + 3.0 * b * m)) < 0.0) lo = m; else hi = m;
        }
        float t = 0.5 * (lo + hi);
        float low = h0 + t * (d0 + t * (a + b * t)), rise = sg * (d1 - d0);
        if (abs(low) > TOUCH_TOLERANCE * rise || sg * low > SAME_SIDE_TOLERANCE * rise) continue;
        c[n] = mix(g_clip[i], g_clip[j], t);
        d[n] = mix(g_dist[i], g_dist[j], t);
        ++n;
    }
    return n == 2;
}
#endif

void main() {
    vec4 c[2];
    vec4 d[2];
#if defined TOUCHING
    bool sliced = crossing(float[3](g_h[0], g_h[1], g_h[2]), c, d) || touching(c, d);
#else
    bool sliced = crossing(float[3](g_h[0], g_h[1], g_h[2]), c, d);
#endif
    if (u_slice_style.w > 0.0 && sliced) {
        emit_segment(c[0], c[1], d[0], d[1], u_slice_style, 10.0 * u_line_bias, 1.0);
    }
    if (max(max(flag_of(0), flag_of(1)), flag_of(2)) >= 2.0) return;  // never silhouettes
    // Lemma 3 segment: the two edges whose ends have opposite signs of s.
    if (u_ink.w > 0.0 && crossing(float[3](g_s[0], g_s[1], g_s[2]), c, d))
        emit_segment(c[0], c[1], d[0], d[1], u_ink, 0.0, 1.0);

    // Lemma 2 point: the normal-plane part u of rho1 vanishes. The triangle claims it when u
    // winds around its boundary; each edge's turn is measured in the normal frame of its
    // lower-numbered vertex, so the two triangles at an edge compute the same angle and a zero
    // is claimed once (solving each triangle's interpolant in a frame of its own claimed a
    // zero near an edge twice or not at all). The disc sits at the interpolant's zero.
    if (u_pinch.w <= 0.0 || flag_of(0) + flag_of(1) + flag_of(2) > 0.0) return;
    vec4 u[3];
    for (int k = 0; k < 3; ++k) u[k] = g_ab[k].x * g_m1[k] + g_ab[k].y * g_m2[k];
    vec2 A[3];
    for (int k = 0; k < 3; ++k) A[k] = vec2(dot(u[k], g_m1[0]), dot(u[k], g_m2[0]));
    vec2 e1 = A[1] - A[0], e2 = A[2] - A[0];
    float det = e1.x * e2.y - e1.y * e2.x;
    float scale = max(max(dot(A[0], A[0]), dot(A[1], A[1])), dot(A[2], A[2]));
    if (abs(det) <= 1e-6 * scale || scale <= 0.0) return;   // degenerate: a curve, not a point
    float l1 = (-A[0].x * e2.y + A[0].y * e2.x) / det;
    float l2 = (-e1.x * A[0].y + e1.y * A[0].x) / det;
    vec3 l = vec3(1.0 - l1 - l2, l1, l2);
    // Most triangles: the interpolant's zero is far outside, and u cannot wind around them
    // (the margin covers the frames' differences; the arc tangents are the costly part).
    if (min(l.x, min(l.y, l.z)) < -LEMMA2_MARGIN) return;
    float turn = EDGE_TURN(0, 1) + EDGE_TURN(1, 2) + EDGE_TURN(2, 0);
    if (abs(turn) < 3.14159265) return;   // no winding: |turn| is 0 or a multiple of 2 pi
    l = max(l, vec3(0.0));
    l /= max(l.x + l.y + l.z, 1e-30);
    vec4 cp = l.x * g_clip[0] + l.y * g_clip[1] + l.z * g_clip[2];
    vec4 dp = l.x * g_dist[0] + l.y * g_dist[1] + l.z * g_dist[2];
    if (any(lessThan(dp, vec4(0.0)))) return;
    // A Lemma 2 point lies on a fold of the 3D image, where the surface is seen edge-on: lift the
    // disc further towards the viewer so the surface it marks does not cut it in half.
    emit_segment(cp, cp, dp, dp, u_pinch, 10.0 * u_line_bias, 1.0);
}
#endif  // OUTLINES
#endif

#if defined FRAGMENT_SHADER
#include "line_fragment.glsl"
#endif
