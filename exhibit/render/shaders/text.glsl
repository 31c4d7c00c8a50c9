// HUD text and panels: a Pillow-rasterised coverage texture placed texel-for-pixel (crisp at
// every resolution because it is rasterised at that resolution), tinted by u_color.
uniform vec2 u_viewport;
uniform vec4 u_rect;    // x, y (bottom-left, GL pixels), width, height

#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
    v_uv = vec2(corner.x, 1.0 - corner.y);   // texture rows run top-down
    vec2 px = u_rect.xy + corner * u_rect.zw;
    gl_Position = vec4(px / u_viewport * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
uniform sampler2D u_texture;
uniform vec4 u_color;
in vec2 v_uv;
out vec4 f_color;
void main() {
    f_color = vec4(u_color.rgb, u_color.a * texture(u_texture, v_uv).r);
}
#endif
