#version 330
// News desk in the foreground: a dark, softly lit surface across the bottom of the image with a
// thin warm highlight on its front edge (hides where the head's neck ends). Colours sRGB.
in vec2 v_uv;

uniform float u_top;  // desk edge height, fraction of the image from the bottom

out vec4 f_color;

void main() {
    if (v_uv.y > u_top + 0.004) discard;
    float y = clamp(v_uv.y / max(u_top, 1e-3), 0.0, 1.0);
    vec3 c = mix(vec3(0.045, 0.05, 0.065), vec3(0.12, 0.13, 0.16), y);
    c += vec3(0.10, 0.085, 0.07) * exp(-pow((v_uv.x - 0.5) / 0.35, 2.0)) * y;  // key light spill
    float edge = exp(-pow((v_uv.y - u_top) / 0.004, 2.0));
    c += vec3(0.35, 0.30, 0.24) * edge;
    float a = 1.0 - smoothstep(u_top - 0.001, u_top + 0.004, v_uv.y);
    float dither = fract(sin(dot(gl_FragCoord.xy, vec2(12.9898, 78.233))) * 43758.5453);
    f_color = vec4(c + (dither - 0.5) / 255.0, a);
}
