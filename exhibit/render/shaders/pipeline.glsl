// The paper's whole 4D -> clip map as uniforms (exhibit.geometry.pipeline.ClipTransform):
//   clip = u_M * p + u_m            (the 4x5 matrix split into its 4x4 block and last column)
//   view = u_R * p + u_t            (the 5x5 pose: 4D rotation + offset; u_R also turns normals)
//   gl_ClipDistance[i] = dot(u_plane_n[i], p) + u_plane_d[i]   (sensor hyperplane, front plane)
uniform mat4 u_M;
uniform vec4 u_m;
uniform mat4 u_R;
uniform vec4 u_t;
uniform vec4 u_plane_n0;
uniform float u_plane_d0;
uniform vec4 u_plane_n1;
uniform float u_plane_d1;
uniform float u_r1;        // 1 / sensor distance (0: orthographic 4D -> 3D)
uniform float u_r2;        // 1 / eye distance (0: orthographic 3D -> 2D)
uniform vec2 u_viewport;   // framebuffer size in pixels

vec4 to_clip(vec4 p) { return u_M * p + u_m; }
float sensor_plane(vec4 p) { return dot(u_plane_n0, p) + u_plane_d0; }
float front_plane(vec4 p) { return dot(u_plane_n1, p) + u_plane_d1; }

// Ray from view point q towards the sensor, scaled by r1 so it stays finite (e_w at infinity).
vec4 sensor_ray(vec4 q) { return vec4(-u_r1 * q.xyz, 1.0 - u_r1 * q.w); }
// Ray from q towards the eye on the view z-axis, scaled by r2 (e_z at infinity): Lemma 3's rho2.
vec4 eye_ray(vec4 q) { return vec4(-u_r2 * q.xy, 1.0 - u_r2 * q.z, -u_r2 * q.w); }
