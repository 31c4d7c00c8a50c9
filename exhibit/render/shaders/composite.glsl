// The passes after the scene, which is drawn offscreen premultiplied (transparent where nothing
// was drawn): one full-screen triangle each, so the background costs a few instructions in a
// pass that runs anyway instead of a pass of its own.
//
//  * FXAA (the default on software GL): the scene over the background, antialiased, texel for
//    pixel. A console-class FXAA without the edge search: five unfiltered taps (the pixel and
//    its four neighbours: texelFetch costs a third of a filtered tap on llvmpipe, and on a
//    software rasteriser every tap is paid for every pixel, branches or not); where the local
//    luma contrast is high, the pixel is blended towards the neighbour across the edge by
//    FXAA 3.11's sub-pixel amount, so stair steps and single-pixel specks soften. Only surface
//    edges are treated: lines carry their own antialiasing (see the alpha test below).
//  * PLAIN: the scene over the background as it is (after an MSAA resolve, or no antialiasing).
//  * UPSCALE: a lower render scale's picture stretched to the screen with bilinear filtering
//    (after an FXAA pass at the scene's own size, or straight from the scene).
// FXAA's output is opaque (the background is in it), so an UPSCALE pass can follow it.
uniform sampler2D u_scene;
uniform vec3 u_top;          // background gradient
uniform vec3 u_bottom;
uniform vec2 u_size;         // size of the picture this pass writes, in pixels

#if defined VERTEX_SHADER
#include "fullscreen.glsl"
void main() {
    vec2 p = fullscreen_corner();
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
out vec4 f_color;

vec3 background() {
    return mix(u_bottom, u_top, clamp(gl_FragCoord.y / u_size.y, 0.0, 1.0));
}

float luma(vec3 c) { return dot(c, vec3(0.299, 0.587, 0.114)); }

#if defined UPSCALE
void main() {
    vec4 s = texture(u_scene, gl_FragCoord.xy / u_size);
    f_color = vec4(s.rgb + background() * (1.0 - s.a), 1.0);
}
#else
// The scene over this row's background at a texel offset from this pixel.
vec3 over(ivec2 p, vec3 bg) {
    vec4 s = texelFetch(u_scene, p, 0);
    return s.rgb + bg * (1.0 - s.a);
}

void main() {
    vec3 bg = background();
    ivec2 p = ivec2(gl_FragCoord.xy);
#if defined FXAA
    const float EDGE_THRESHOLD = 0.125;      // no edge below this fraction of the local max...
    const float EDGE_THRESHOLD_MIN = 0.0312; // ...nor below this (dark areas)
    const float SUBPIX = 0.75;               // FXAA 3.11's default sub-pixel removal
    ivec2 hi = textureSize(u_scene, 0) - 1;
    vec4 sM = texelFetch(u_scene, p, 0);
    vec4 sN = texelFetch(u_scene, min(p + ivec2(0, 1), hi), 0);
    vec4 sS = texelFetch(u_scene, max(p - ivec2(0, 1), ivec2(0)), 0);
    vec4 sE = texelFetch(u_scene, min(p + ivec2(1, 0), hi), 0);
    vec4 sW = texelFetch(u_scene, max(p - ivec2(1, 0), ivec2(0)), 0);
    vec3 rgbM = sM.rgb + bg * (1.0 - sM.a), rgbN = sN.rgb + bg * (1.0 - sN.a);
    vec3 rgbS = sS.rgb + bg * (1.0 - sS.a), rgbE = sE.rgb + bg * (1.0 - sE.a);
    vec3 rgbW = sW.rgb + bg * (1.0 - sW.a);
    // Lines (curves, markers, live silhouettes) are antialiased by their own coverage: their
    // pixels have alpha 1 (a core) or a fraction (a rim), while surfaces write 254/255 and the
    // background is empty (0). A pixel with a line among its taps is left as it is (FXAA would
    // only blur them).
    vec4 a4 = vec4(sN.a, sS.a, sE.a, sW.a);
    bvec4 line4 = bvec4(step(0.5 / 255.0, a4) * step(0.5 / 255.0, abs(a4 - 254.0 / 255.0)));
    bool line = any(line4) || (sM.a > 0.5 / 255.0 && abs(sM.a - 254.0 / 255.0) > 0.5 / 255.0);
    float lM = luma(rgbM), lN = luma(rgbN), lS = luma(rgbS), lE = luma(rgbE), lW = luma(rgbW);
    float lMax = max(max(max(lN, lS), max(lE, lW)), lM);
    float lMin = min(min(min(lN, lS), min(lE, lW)), lM);
    float range = lMax - lMin;
    // FXAA 3.11's sub-pixel amount: how far this pixel stands out from its neighbours' mean.
    float sub = clamp(abs(0.25 * (lN + lS + lE + lW) - lM) / max(range, 1e-6), 0.0, 1.0);
    sub = sub * sub * (3.0 - 2.0 * sub);
    // The edge runs along the axis with the smaller second difference; blend across it,
    // towards the side with the larger step (as FXAA's offset bilinear tap does).
    bool horizontal = abs(lN + lS - 2.0 * lM) >= abs(lE + lW - 2.0 * lM);
    vec3 a = horizontal ? rgbN : rgbE, b = horizontal ? rgbS : rgbW;
    float da = abs((horizontal ? lN : lE) - lM), db = abs((horizontal ? lS : lW) - lM);
    bool edge = !line && range >= max(EDGE_THRESHOLD_MIN, lMax * EDGE_THRESHOLD);
    f_color = vec4(mix(rgbM, da >= db ? a : b, edge ? sub * sub * SUBPIX : 0.0), 1.0);
#else
    f_color = vec4(over(p, bg), 1.0);
#endif
}
#endif
#endif
