#version 330
// Skin pass (b): one direction of a separable Gaussian blur with 8 importance-sampled taps
// (equal weights at the Gaussian's octile midpoints), radius given in cm and turned into texels
// with the stretch map. Premultiplied by coverage, so empty texels around UV islands do not
// darken the edges; uncovered texels stay empty.
in vec2 v_uv;

uniform sampler2D u_src;
uniform sampler2D u_stretch;
uniform vec2 u_dir;        // (1, 0) along u or (0, 1) along v
uniform float u_sigma_cm;  // Gaussian standard deviation of this pass, cm
uniform vec2 u_texel;      // 1 / texture size

out vec4 f_color;

// Φ⁻¹((i + 0.5) / 8), i = 0 … 7: equal-probability tap positions of a unit Gaussian
const float TAPS[8] = float[8](-1.5341, -0.8871, -0.4888, -0.1573,
                               0.1573, 0.4888, 0.8871, 1.5341);

void main() {
    vec4 c = texture(u_src, v_uv);
    if (c.a <= 0.0) {
        f_color = vec4(0.0);
        return;
    }
    vec2 s = texture(u_stretch, v_uv).xy;               // cm per texel along u, v
    float cm_per_texel = max(dot(s, u_dir), 1e-4);
    float step_texels = min(u_sigma_cm / cm_per_texel, 24.0);
    vec2 d = u_dir * u_texel * step_texels;
    vec4 acc = vec4(0.0);
    for (int i = 0; i < 8; i++) {
        acc += texture(u_src, v_uv + TAPS[i] * d);
    }
    vec3 rgb = acc.a > 0.0 ? acc.rgb / acc.a : c.rgb / c.a;
    f_color = vec4(rgb * c.a, c.a);
}
