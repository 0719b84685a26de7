#version 330
// Mesh vertex shader: world-space position + smooth normal in, view-space out.
uniform mat4 u_view;
uniform mat4 u_proj;

in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;      // (0, 0) for objects without textures

out vec3 v_pos;     // view space
out vec3 v_normal;  // view space
out vec2 v_uv;

void main() {
    vec4 p = u_view * vec4(in_position, 1.0);
    v_pos = p.xyz;
    v_normal = mat3(u_view) * in_normal;
    v_uv = in_uv;
    gl_Position = u_proj * p;
}
