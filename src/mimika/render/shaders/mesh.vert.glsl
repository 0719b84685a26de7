#version 330
// Mesh vertex shader: world-space position + smooth normal in, view-space out; the
// per-vertex occlusion (ambient occlusion, visibility through the mouth opening, inside the
// mouth) passes through; SHADOWS adds the light-space position for the key light's shadow.
uniform mat4 u_view;
uniform mat4 u_proj;
#ifdef SHADOWS
uniform mat4 u_shadow_matrix;   // world → the key light's clip space
uniform float u_shadow_offset;  // cm along the normal (against shadow acne)
out vec4 v_shadow;
#endif

in vec3 in_position;
in vec3 in_normal;
in vec3 in_occ;     // ambient occlusion, mouth visibility, inside the mouth (0 … 1)
in vec2 in_uv;      // (0, 0) for objects without textures
in vec3 in_face;    // face units (x, y) and how much of the face it is: 0 off the face

out vec3 v_pos;     // view space
out vec3 v_normal;  // view space
out vec2 v_uv;
out vec3 v_occ;
out vec3 v_face;

void main() {
    vec4 p = u_view * vec4(in_position, 1.0);
    v_pos = p.xyz;
    v_normal = mat3(u_view) * in_normal;
    v_uv = in_uv;
    v_occ = in_occ;
    v_face = in_face;
#ifdef SHADOWS
    v_shadow = u_shadow_matrix * vec4(in_position + u_shadow_offset * in_normal, 1.0);
#endif
    gl_Position = u_proj * p;
}
