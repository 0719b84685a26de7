#version 330
// Skin pass (a): unwrap the skin into texture space. The vertex's UV becomes its position, so
// the rasteriser fills the irradiance texture; normals go to view space for lighting and the
// world position is kept to measure how many cm one texel spans (the stretch map).
uniform mat4 u_view;
uniform vec4 u_uv_xform;  // uv' = (uv - xy) * zw, into [0, 1]²
#ifdef SHADOWS
uniform mat4 u_shadow_matrix;
uniform float u_shadow_offset;
out vec4 v_shadow;
#endif

in vec3 in_position;
in vec3 in_normal;
in vec3 in_occ;
in vec2 in_uv;

out vec3 v_normal;  // view space
out vec3 v_world;   // cm
out vec3 v_occ;

void main() {
    vec2 uv = (in_uv - u_uv_xform.xy) * u_uv_xform.zw;
    v_normal = mat3(u_view) * in_normal;
    v_world = in_position;
    v_occ = in_occ;
#ifdef SHADOWS
    v_shadow = u_shadow_matrix * vec4(in_position + u_shadow_offset * in_normal, 1.0);
#endif
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
