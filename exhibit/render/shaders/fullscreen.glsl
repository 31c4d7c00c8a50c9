// One triangle that covers the whole viewport, made from gl_VertexID alone (draw 3 vertices, no
// buffer): corners (-1, -1), (3, -1), (-1, 3). Included by every full-screen pass's vertex stage.
vec2 fullscreen_corner() {
    return vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID >> 1) * 4 - 1));
}
