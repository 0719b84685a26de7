#version 430
// Which wrinkle groups reach which triangles: every group whose branch is entered at the
// fragment's three samples (as wrinkled_normal takes them) is or-ed into the slot of the
// fragment's primitive, u_first + gl_PrimitiveID.
uint wr_hits = 0u;
#define WR_HIT(bits) wr_hits |= uint(bits)
#include "wrinkles.glsl"

layout(std430, binding = 0) buffer Reach { uint reach[]; };
uniform int u_first;

out vec4 f_color;

void main() {
    wrinkle_heights(v_face.xy);
    atomicOr(reach[u_first + gl_PrimitiveID], wr_hits);
    f_color = vec4(0.0);
}
