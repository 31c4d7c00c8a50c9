// HUD quads, one instance each, drawn texel for pixel: glyphs from the atlas (single-channel
// coverage tinted by the instance's colour), panels (the atlas's solid texels stretched), or with
// RGBA_TEXTURE a cached premultiplied image (the title and caption block). Output is
// premultiplied: blend with (ONE, ONE_MINUS_SRC_ALPHA).
uniform vec2 u_viewport;

#if defined VERTEX_SHADER
in vec4 in_rect;     // x, y of the top-left corner in pixels from the top-left; width, height
in vec4 in_uv;       // texel rectangle in the texture: u, v (top row), width, height
in vec4 in_color;    // rgba, straight alpha
uniform vec2 u_texture_size;
out vec2 v_uv;
flat out vec4 v_color;
void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
    vec2 px = in_rect.xy + corner * in_rect.zw;
    v_uv = (in_uv.xy + corner * in_uv.zw) / u_texture_size;
    v_color = vec4(in_color.rgb * in_color.a, in_color.a);
    gl_Position = vec4(px.x / u_viewport.x * 2.0 - 1.0, 1.0 - px.y / u_viewport.y * 2.0, 0.0, 1.0);
}
#endif

#if defined FRAGMENT_SHADER
uniform sampler2D u_texture;
in vec2 v_uv;
flat in vec4 v_color;
out vec4 f_color;
void main() {
#if defined RGBA_TEXTURE
    f_color = texture(u_texture, v_uv) * v_color.a;   // the instance's alpha fades it
#else
    f_color = v_color * texture(u_texture, v_uv).r;
#endif
}
#endif
