#version 330
// News studio backdrop: a deep blue-grey gradient, soft out-of-focus light panels behind the
// reader, a warm glow around the head and a vignette — no logos. Colours sRGB.
in vec2 v_uv;

uniform vec3 u_top;
uniform vec3 u_bottom;
uniform vec3 u_glow;
uniform float u_aspect;

out vec4 f_color;

float panel(vec2 p, vec2 c, vec2 half_size, float soft) {
    vec2 d = abs(p - c) - half_size;
    float r = length(max(d, 0.0)) + min(max(d.x, d.y), 0.0);
    return 1.0 - smoothstep(-soft, soft, r);
}

void main() {
    vec2 p = vec2((v_uv.x - 0.5) * u_aspect, v_uv.y - 0.5);
    vec3 c = mix(u_bottom, u_top, smoothstep(0.0, 1.0, v_uv.y));
    // blurred light panels of the set (bokeh-like), cool on the sides
    vec3 cool = vec3(0.10, 0.16, 0.26);
    c += cool * 0.55 * panel(p, vec2(-0.62, 0.08), vec2(0.10, 0.32), 0.10);
    c += cool * 0.55 * panel(p, vec2(0.62, 0.08), vec2(0.10, 0.32), 0.10);
    c += cool * 0.25 * panel(p, vec2(-0.38, 0.22), vec2(0.05, 0.20), 0.08);
    c += cool * 0.25 * panel(p, vec2(0.38, 0.22), vec2(0.05, 0.20), 0.08);
    // a horizontal light strip low in the set
    c += vec3(0.05, 0.07, 0.10) * exp(-pow((v_uv.y - 0.26) / 0.035, 2.0));
    // warm glow behind the head
    vec2 g = p - vec2(0.0, 0.08);
    c += u_glow * exp(-3.0 * dot(g, g) / 0.25);
    c *= 1.0 - 0.4 * smoothstep(0.4, 1.0, length(p * vec2(0.8, 1.2)));
    float dither = fract(sin(dot(gl_FragCoord.xy, vec2(12.9898, 78.233))) * 43758.5453);
    f_color = vec4(c + (dither - 0.5) / 255.0, 1.0);
}
