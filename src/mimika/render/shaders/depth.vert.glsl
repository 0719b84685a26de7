#version 330
// Depth only, seen from a light (the key light's shadow map, ambient-occlusion views).
uniform mat4 u_view;
uniform mat4 u_proj;

in vec3 in_position;
in vec2 in_uv;

out vec2 v_uv;

void main() {
    v_uv = in_uv;
    gl_Position = u_proj * (u_view * vec4(in_position, 1.0));
}
