#version 330
// Skin pass (c): the skin seen by the camera, with its texture coordinates for the lookup of
// the blurred irradiance.
uniform mat4 u_view;
uniform mat4 u_proj;
uniform vec4 u_uv_xform;
#ifdef SHADOWS
uniform mat4 u_shadow_matrix;
uniform float u_shadow_offset;
out vec4 v_shadow;
#endif

in vec3 in_position;
in vec3 in_normal;
in vec3 in_occ;
in vec2 in_uv;
in vec3 in_face;

out vec3 v_pos;     // view space
out vec3 v_normal;  // view space
out vec2 v_uv;      // in the irradiance texture
out vec2 v_tex;     // the object's own UVs (albedo)
out vec3 v_occ;
out vec3 v_face;

void main() {
    vec4 p = u_view * vec4(in_position, 1.0);
    v_pos = p.xyz;
    v_normal = mat3(u_view) * in_normal;
    v_uv = (in_uv - u_uv_xform.xy) * u_uv_xform.zw;
    v_tex = in_uv;
    v_occ = in_occ;
    v_face = in_face;
#ifdef SHADOWS
    v_shadow = u_shadow_matrix * vec4(in_position + u_shadow_offset * in_normal, 1.0);
#endif
    gl_Position = u_proj * p;
}
