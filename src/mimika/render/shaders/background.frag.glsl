#version 330
// Soft studio backdrop: vertical grey-blue gradient, a faint glow behind the head and a
// gentle vignette. Colours are sRGB (written directly).
in vec2 v_uv;

uniform vec3 u_top;
uniform vec3 u_bottom;
uniform vec3 u_glow;
uniform float u_aspect;

out vec4 f_color;

void main() {
    vec3 c = mix(u_bottom, u_top, smoothstep(0.0, 1.0, v_uv.y));
    vec2 d = (v_uv - vec2(0.5, 0.58)) * vec2(u_aspect, 1.0);
    float r = length(d);
    c += u_glow * exp(-3.5 * r * r);
    c *= 1.0 - 0.35 * smoothstep(0.45, 1.1, length((v_uv - 0.5) * vec2(u_aspect, 1.0)));
    // tiny ordered dither against banding in 8-bit output
    float dither = fract(sin(dot(gl_FragCoord.xy, vec2(12.9898, 78.233))) * 43758.5453);
    f_color = vec4(c + (dither - 0.5) / 255.0, 1.0);
}
