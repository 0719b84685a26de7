#version 330
// Studio lighting in view space: warm key (upper left of the camera), cool fill (right),
// rim light from behind, hemispheric ambient. Wrap diffuse with a scatter tint for skin,
// normalised Blinn-Phong specular (key and fill). Linear lighting, sRGB output.
// Kept cheap: it runs per pixel on llvmpipe (no pow in the sRGB encode, one pow per light).
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;

uniform vec3 u_base;        // linear base colour
uniform bool u_textured;    // base colour (sRGB) and alpha from u_tex instead
uniform sampler2D u_tex;
uniform int u_alpha_mode;   // 0 opaque, 1 cut at 0.5, 3 soft fringe below 0.5 (blended)
uniform float u_specular;   // specular strength
uniform float u_shininess;  // Blinn-Phong exponent
uniform float u_wrap;       // wrap diffuse (0 = Lambert)
uniform vec3 u_scatter;     // tint of light wrapped past the terminator (skin: reddish)
uniform float u_alpha;      // < 1: glass-like, premultiplied (specular stays)
uniform float u_backface;   // brightness of back faces (cavities seen from outside)

#include "lights.glsl"
uniform float u_exposure;

out vec4 f_color;

// Linear to sRGB without pow (fit within ~0.5/255 of the exact curve; llvmpipe-cheap).
vec3 to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 s1 = sqrt(c);
    vec3 s2 = sqrt(s1);
    vec3 s3 = sqrt(s2);
    return clamp(0.662002687 * s1 + 0.684122060 * s2 - 0.323583601 * s3 - 0.0225411470 * c,
                 0.0, 1.0);
}

// Soft shoulder so bright highlights roll off instead of clipping.
vec3 tonemap(vec3 c) {
    vec3 x = c * u_exposure;
    vec3 knee = vec3(0.8);
    vec3 over = max(x - knee, 0.0);
    return min(x, knee) + over / (1.0 + over / (1.0 - knee.x));
}

vec3 base;

vec3 diffuse(vec3 n, vec3 l) {
    float ndl = dot(n, l);
    float lambert = max(ndl, 0.0);
    float wrapped = max((ndl + u_wrap) / (1.0 + u_wrap), 0.0);
    return base * (lambert + max(wrapped - lambert, 0.0) * u_scatter);
}

float specular(vec3 n, vec3 v, vec3 l) {
    float ndl = max(dot(n, l), 0.0);
    vec3 h = normalize(l + v);
    float norm = (u_shininess + 8.0) / 25.1327;  // (n + 8) / (8 pi)
    float x = 1.0 - max(dot(v, h), 0.0);
    float x2 = x * x;
    float fres = 1.0 + 2.0 * x2 * x2 * x;  // Schlick-style boost at grazing angles
    return u_specular * norm * fres * pow(max(dot(n, h), 1e-4), u_shininess) * ndl;
}

void main() {
    base = u_base;
    float a = 1.0;
    if (u_textured) {
        vec4 t = texture(u_tex, v_uv);
        base = pow(t.rgb, vec3(2.2));
        a = t.a;
        if (u_alpha_mode == 1 && a < 0.5) discard;
        if (u_alpha_mode == 3 && (a >= 0.5 || a < 0.02)) discard;
    }
    vec3 n = normalize(v_normal);
    float facing = 1.0;
    if (!gl_FrontFacing) {
        n = -n;
        facing = u_backface;
    }
    vec3 v = normalize(-v_pos);
    // key and fill: diffuse + specular; rim: diffuse only (it lights silhouettes)
    vec3 c = u_key_col * (diffuse(n, u_key_dir) * u_alpha + specular(n, v, u_key_dir))
           + u_fill_col * (diffuse(n, u_fill_dir) * u_alpha + specular(n, v, u_fill_dir))
           + u_rim_col * diffuse(n, u_rim_dir) * u_alpha;
    vec3 ambient = mix(u_ground, u_sky, 0.5 + 0.5 * n.y) * base * u_alpha;
    c = (c + ambient) * facing;
    if (u_alpha_mode == 3) {  // premultiplied soft edge
        f_color = vec4(to_srgb(tonemap(c)) * a, a);
        return;
    }
    f_color = vec4(to_srgb(tonemap(c)), u_alpha);
}
