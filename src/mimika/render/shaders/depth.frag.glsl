#version 330
// Depth only; TEXTURED parts (hair, lashes, cut-outs) cover only where their alpha reaches 0.5.
in vec2 v_uv;
uniform sampler2D u_tex;
out vec4 f_color;

void main() {
#ifdef TEXTURED
    if (texture(u_tex, v_uv).a < 0.5) discard;
#endif
    f_color = vec4(1.0);
}
