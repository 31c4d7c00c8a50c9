// The crossfade between two kiosk frames: the last frame of what was on screen (a snapshot
// taken when the next timeline or scene began) laid over the new frame with alpha u_alpha,
// which falls from 1 to 0 over the fade. One full-screen triangle; the snapshot is opaque, so
// the screen always shows a mix of two whole pictures, never black.
uniform sampler2D u_snapshot;
uniform float u_alpha;

#if defined VERTEX_SHADER
#include "fullscreen.glsl"
void main() {
    vec2 p = fullscreen_corner();
    gl_Position = vec4(p, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
out vec4 f_color;
void main() {
    f_color = vec4(texelFetch(u_snapshot, ivec2(gl_FragCoord.xy), 0).rgb, u_alpha);
}
#endif
