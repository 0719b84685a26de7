#version 330
// Skin pass (c): albedo × scattered irradiance + specular. The diffuse light is a per-channel
// mix of the sharp per-pixel irradiance and the texture-space blurred one (red scatters
// farthest: softer, warmer terminator); specular is Torrance–Sparrow with a Beckmann
// distribution, Schlick Fresnel (skin F0 = 0.028) and the Kelemen–Szirmay-Kalos visibility.
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
in vec2 v_tex;
in vec3 v_occ;  // ambient occlusion, visibility through the mouth opening, inside the mouth
#ifdef SHADOWS
in vec4 v_shadow;
#include "shadow.glsl"
#endif
#ifdef WRINKLES
#include "wrinkles.glsl"
#endif
#ifdef DETAIL
#include "frame.glsl"
#include "detail.glsl"
#endif

uniform sampler2D u_irr;
uniform vec3 u_base;
uniform bool u_textured;    // albedo from u_albedo (RGB sRGB, A gloss) instead of u_base
uniform sampler2D u_albedo;
uniform float u_specular;
uniform float u_roughness;
uniform vec3 u_mix;        // share of blurred irradiance per channel
uniform float u_backface;
uniform float u_ao;
uniform vec3 u_mucosa;
#include "skin_light.glsl"

#include "tone.glsl"

out vec4 f_color;

float roughness;  // u_roughness scaled by the detail map

vec3 specular(vec3 n, vec3 v, vec3 l, vec3 col) {
    float ndl = dot(n, l);
    if (ndl <= 0.0) return vec3(0.0);
    vec3 hu = l + v;
    vec3 h = normalize(hu);
    float ndh = max(dot(n, h), 1e-4);
    float m2 = roughness * roughness;
    float t2 = (1.0 - ndh * ndh) / (ndh * ndh);
    float d = exp(-t2 / m2) / (3.14159 * m2 * ndh * ndh * ndh * ndh);
    float s = 1.0 - max(dot(h, v), 0.0), s2 = s * s;
    float f = 0.028 + 0.972 * s2 * s2 * s;  // Schlick: (1 - h·v)^5
    return col * (u_specular * d * f * ndl * 4.0 / max(dot(hu, hu), 1e-4));
}

void main() {
    vec3 n = normalize(v_normal);
    float facing = 1.0;
    if (!gl_FrontFacing) {
        n = -n;
        facing = u_backface;
    }
    vec3 v = normalize(-v_pos);
    float cavity = 1.0;
#ifdef WRINKLES
    n = wrinkled_normal(n, v_pos, cavity);
#endif
    roughness = u_roughness;
#ifdef DETAIL
    float rough;
    n = detail_normal(n, v_pos, v_tex, rough);
    roughness *= rough;
#endif
    float kv = 1.0;
#ifdef SHADOWS
    kv = key_visibility(v_shadow);
#endif
    float ao = mix(1.0, v_occ.x, u_ao * (1.0 - v_occ.z));  // inside: the opening rules
    vec3 direct = skin_diffuse(n, kv, ao) * v_occ.y;
    vec4 t = texture(u_irr, v_uv);
    vec3 blurred = t.a > 1e-3 ? t.rgb / t.a : direct;
    float cover = smoothstep(0.05, 0.6, t.a);
    vec3 irr = mix(direct, blurred, u_mix * cover);
    vec3 spec = (kv * specular(n, v, u_key_dir, u_key_col)
                 + sqrt(ao) * specular(n, v, u_fill_dir, u_fill_col)
                 + ao * specular(n, v, u_rim_dir, u_rim_col)) * v_occ.y;
    vec3 base = u_base;
    if (u_textured) {
        vec4 a = texture(u_albedo, v_tex);
        base = srgb_decode(a.rgb);
        spec *= a.a;
    }
    base = mix(base, u_mucosa, v_occ.z);
    vec3 c = (base * irr * cavity + spec) * facing;
    f_color = vec4(to_srgb(tonemap(c)), 1.0);
}
