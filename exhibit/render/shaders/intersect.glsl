// Intersection curves of the 3D image: where one sheet of the projected surface passes through
// another (or through another part), ink the crossing as an antialiased curve instead of the
// z-buffer's staircase. One full-screen pass over the scene after the surfaces, reading what
// the surface pass wrote beside the colour (surface.glsl, GBUFFER): per pixel the front sheet's
// 4D depth w (offset per part) and the plane of its window depth, z(x) = z + dz/dx dx + dz/dy dy.
//
// For the pixel p (sheet A in front) and each of its 8 neighbours q (sheet B in front):
//  * A and B are different sheets when their w differ by more than u_sheet_gap: the same 3D
//    point is the image of two 4D points (a mesh edge or a fold of one sheet is continuous in w);
//  * their depth planes cross near p, at an angle (coinciding sheets z-fight, and two halves
//    meeting at a fold are nearly parallel, instead): the line
//    h(x) = zA(x) - zB(x) = 0 passes within the curve's half width of p's centre. At an
//    occluding contour (A ends at its silhouette in front of B) the planes are far apart in
//    depth there, so their crossing is far away. There is no sign test between p and q: the
//    colours are depth-tested with a polygon offset that differs per triangle, so next to the
//    crossing the "wrong" sheet may be in front by a fraction of a pixel; the planes here are
//    the true ones (clip z / clip w, no offset);
//  * the ink's strength grows linearly with the sine of the crossing angle from u_min_angle to
//    u_full_angle: a hard cut-off turned the facets' noise in the angle (a few hundredths of the
//    sine from one triangle to the next) into dashes wherever a curve's angle passed it
//    (Figure 16), and every crossing curve that ends with its sheets turning tangent passes it;
//  * the crossing line h = 0 is exact to float precision within the two triangles, so its
//    distance from p's centre, |h(p)| / |grad h|, gives an analytic coverage: a crisp curve at
//    subpixel position, whatever the pixel grid.
// The ink is blended over the scene's colour only (the second attachment is not bound here).
uniform vec2 u_size;
uniform float u_half_width;   // half the curve's width in pixels
uniform float u_sheet_gap;    // smallest w difference between two sheets
uniform float u_min_angle;    // smallest crossing inked: sine of the angle between the planes
uniform float u_full_angle;   // the ink is full from this sine on, fading linearly down to u_min_angle
uniform float u_depth_scale;  // window depth to pixels
uniform vec3 u_ink;
#define TILE 8
#if defined MULTISAMPLE
uniform sampler2DMS u_geometry;
#define FETCH(p) texelFetch(u_geometry, p, 0)
#else
uniform sampler2D u_geometry;
#define FETCH(p) texelFetch(u_geometry, p, 0)
#endif

#if defined VERTEX_SHADER
#include "fullscreen.glsl"
#if defined TILES
// One point per TILE x TILE block of pixels, drawn (as a TILE-pixel square) only where the gate
// pass found two sheets in or around the block; elsewhere it is sent outside the clip volume.
uniform sampler2D u_gate;
uniform int u_tiles_x;
void main() {
    ivec2 t = ivec2(gl_VertexID % u_tiles_x, gl_VertexID / u_tiles_x);
    vec2 c = (vec2(t) * float(TILE) + 0.5 * float(TILE)) / u_size * 2.0 - 1.0;
    gl_Position = texelFetch(u_gate, t, 0).r > 0.5 ? vec4(c, 0.0, 1.0) : vec4(2.0, 2.0, 2.0, 1.0);
    gl_PointSize = float(TILE);
}
#else
void main() {
    vec2 p = fullscreen_corner();
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif
#endif

#if defined FRAGMENT_SHADER && defined GATE
// The gate, one pixel per TILE x TILE block: whether the block and a one-pixel border around it
// hold two sheets (w apart by more than u_sheet_gap) at an angle. A pixel can only be inked where it and a
// neighbour are different sheets, both inside its block's bordered footprint.
out vec4 f_gate;
void main() {
    ivec2 base = ivec2(gl_FragCoord.xy) * TILE - 1;
    ivec2 hi = ivec2(u_size) - 1;
    vec3 lo = vec3(1e30), up = vec3(-1e30);   // w and the depth slopes
    for (int j = 0; j < TILE + 2; j++) {
        for (int i = 0; i < TILE + 2; i++) {
            vec4 t = FETCH(clamp(base + ivec2(i, j), ivec2(0), hi));
            if (t.y > 0.0) { lo = min(lo, t.xzw); up = max(up, t.xzw); }
        }
    }
    // Two planes crossing at an angle theta have slopes (depth scaled to pixels) at least theta
    // apart, so a footprint whose slopes all agree (sheets that coincide and z-fight, as the two
    // halves of a torus symmetric in w seen from infinitely far) has no crossing to ink.
    vec3 spread = up - lo;
    bool angled = u_depth_scale * max(spread.y, spread.z) > 0.7 * u_min_angle;
    f_gate = vec4(spread.x > u_sheet_gap && angled ? 1.0 : 0.0);
}
#endif

#if defined FRAGMENT_SHADER && !defined GATE
out vec4 f_color;

// The coverage of the crossing of sheet a (at p) with sheet b (at p + o), times the ink's
// strength at its angle; 0 if none.
float crossing(vec4 a, vec4 b, ivec2 o) {
    vec2 d = vec2(o);
    vec2 grad = a.zw - b.zw;                      // gradient of h = zA - zB
    float hp = a.y - (b.y - dot(b.zw, d));        // h at p (B's plane carried from q)
    float g = length(grad);
    // Sheets that coincide in 3D (the two halves of a torus symmetric in w, seen from
    // infinitely far in 4D) z-fight rather than cross, and near a fold both are steep and
    // nearly parallel: ask for a crossing angle between the planes' normals, with depth scaled
    // to pixels (u_depth_scale, from the mesh's extent on screen).
    vec3 na = vec3(-u_depth_scale * a.zw, 1.0), nb = vec3(-u_depth_scale * b.zw, 1.0);
    float sine = length(cross(na, nb)) / (length(na) * length(nb));
    float strength = clamp((sine - u_min_angle) / (u_full_angle - u_min_angle), 0.0, 1.0);
    bool crosses = b.y > 0.0 && abs(a.x - b.x) > u_sheet_gap && strength > 0.0;
    float dist = crosses ? abs(hp) / g : 1e9;
    // The crossing past p, away from q (h has one sign at both), within a pixel and a half: the
    // depth test put the sheets' boundary a pixel off the planes' crossing (a steep sheet is
    // pushed back by a pixel of its slope by the polygon offset), and p is the last pixel of its
    // sheet before it; the pixels beyond have no other sheet around them and draw nothing. Ink p
    // whole, or the curve is drawn on one side only, in beads (near the clifford torus's pinch
    // points, where one sheet is steep).
    float hq = hp + dot(grad, d);
    if (crosses && hp * hq > 0.0 && abs(hp) < abs(hq) && dist < 1.5) dist = 0.0;
    return strength * clamp(u_half_width + 0.5 - dist, 0.0, 1.0);
}

bool other(vec4 a, vec4 b) { return b.y > 0.0 && abs(a.x - b.x) > u_sheet_gap; }

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 hi = ivec2(u_size) - 1;
    vec4 a = FETCH(p);
    vec4 b[8];
    ivec2 o[8] = ivec2[8](ivec2(0, 1), ivec2(0, -1), ivec2(1, 0), ivec2(-1, 0),
                          ivec2(1, 1), ivec2(1, -1), ivec2(-1, 1), ivec2(-1, -1));
    bool any_other = false;
    for (int i = 0; i < 8; i++) {
        b[i] = FETCH(clamp(p + o[i], ivec2(0), hi));
        any_other = any_other || other(a, b[i]);
    }
    // Almost every pixel has the same sheet all around: stop there (on a software rasteriser a
    // discard that kills a whole block of pixels skips the rest of the shader for it). Every
    // pixel within one pixel of a crossing has one of its 8 neighbours across it, which is why
    // the curve's half width is at most half a pixel plus its antialiased rim.
    if (a.y <= 0.0 || !any_other) discard;
    float coverage = 0.0;
    for (int i = 0; i < 8; i++) coverage = max(coverage, crossing(a, b[i], o[i]));
    if (coverage <= 0.0) discard;
    f_color = vec4(u_ink, coverage);
}
#endif
