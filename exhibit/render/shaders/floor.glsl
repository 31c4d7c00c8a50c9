// The benchmark's floor: the same vertex buffers and triangles through a bare pass-through
// shader (one matrix, so the same pixels are covered; flat colour, no normals, no lighting).
#include "pipeline.glsl"
#if defined VERTEX_SHADER
in vec4 in_pos;
void main() { gl_Position = to_clip(in_pos); }
#endif
#if defined FRAGMENT_SHADER
out vec4 f_color;
void main() { f_color = vec4(0.8, 0.8, 0.8, 1.0); }
#endif
