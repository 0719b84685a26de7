#version 430
// Which wrinkle groups reach which triangles: the face drawn in face units (its own plane, so
// every triangle shows), one point per vertex as well.
uniform vec4 u_box;  // face units → [0, 1]²: (f - xy) * zw

in vec3 in_face;
out vec3 v_face;

void main() {
    v_face = in_face;
    gl_Position = vec4((in_face.xy - u_box.xy) * u_box.zw * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = 1.0;
}
