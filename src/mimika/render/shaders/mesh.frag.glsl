#version 330
// Studio lighting in view space: warm key (upper left of the camera), cool fill (right),
// rim light from behind, hemispheric ambient. Wrap diffuse with a scatter tint for skin,
// normalised Blinn-Phong specular (key and fill). Linear lighting, sRGB output.
// Kept cheap: it runs per pixel on llvmpipe (no pow in the sRGB encode, one pow per light).
// Occlusion: ambient occlusion (baked at rest) darkens the ambient, fill and rim light; inside
// the mouth, the visibility through the lip opening darkens every light, and skin there takes
// the colour of the oral mucosa; the key light casts soft shadows (SHADOWS).
// Compiled in variants (llvmpipe pays for both sides of a branch on a uniform): TEXTURED for
// parts with a texture, HAIR for the strand shading model, DEPTH_ONLY for the depth pre-pass
// of cut-out parts (coverage only; they are then shaded once where the pre-pass left them),
// SHADOWS for the key light's shadow map, EYE, IRIS and CORNEA for the eye (eye.glsl: the wet
// reflection of the studio, the lids' shade, the iris under the cornea), DETAIL for a normal
// and roughness map (detail.glsl), FLOW for hair's strand directions (flow.glsl).
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
in vec3 v_occ;  // ambient occlusion, visibility through the mouth opening, inside the mouth
#ifdef SHADOWS
in vec4 v_shadow;
#include "shadow.glsl"
#endif
#ifdef WRINKLES
#include "wrinkles.glsl"
#endif
#if defined(DETAIL) || defined(FLOW)
#include "frame.glsl"
#endif
#ifdef DETAIL
#include "detail.glsl"
#endif
#ifdef FLOW
#include "flow.glsl"
#endif

uniform vec3 u_base;        // linear base colour
uniform sampler2D u_tex;
uniform int u_alpha_mode;   // 0 opaque, 1 cut at 0.5, 2 blended, 3 soft fringe below 0.5
uniform float u_specular;   // specular strength
uniform float u_shininess;  // Blinn-Phong exponent
uniform float u_wrap;       // wrap diffuse (0 = Lambert)
uniform vec3 u_scatter;     // tint of light wrapped past the terminator (skin: reddish)
uniform float u_alpha;      // < 1: glass-like, premultiplied (specular stays)
uniform float u_backface;   // brightness of back faces (cavities seen from outside)
uniform mat4 u_view;        // (shared with the vertex shader) world up for hair strands
uniform float u_ao;         // strength of the ambient occlusion (0 … 1)
uniform vec3 u_mucosa;      // linear colour of skin inside the mouth
uniform float u_tint;       // 1 for skin-like materials (take u_mucosa inside the mouth)

#include "lights.glsl"
#include "tone.glsl"
#if defined(EYE) || defined(IRIS) || defined(CORNEA)
#include "eye.glsl"
#endif

out vec4 f_color;

vec3 base;
float shininess;  // u_shininess, sharper or broader by the detail map's roughness

vec3 diffuse(vec3 n, vec3 l) {
    float ndl = dot(n, l);
    float lambert = max(ndl, 0.0);
    float wrapped = max((ndl + u_wrap) / (1.0 + u_wrap), 0.0);
    return base * (lambert + max(wrapped - lambert, 0.0) * u_scatter);
}

float specular(vec3 n, vec3 v, vec3 l) {
    float ndl = max(dot(n, l), 0.0);
    vec3 h = normalize(l + v);
    float norm = (shininess + 8.0) / 25.1327;  // (n + 8) / (8 pi)
    float x = 1.0 - max(dot(v, h), 0.0);
    float x2 = x * x;
    float fres = 1.0 + 2.0 * x2 * x2 * x;  // Schlick-style boost at grazing angles
    return u_specular * norm * fres * pow(max(dot(n, h), 1e-4), shininess) * ndl;
}

// Hair (Kajiya-Kay): strands run as the flow map says (FLOW), else along the surface's
// projection of world up (root to tip downward); two highlights — a white one shifted toward
// the root and a broader one tinted by the hair colour toward the tip. ``t`` is not
// normalised: short where strands are ill defined (the crown), where the standard highlight
// takes over.
float strand_spec(vec3 t, vec3 n, vec3 h, float shift, float e) {
    vec3 ts = normalize(t + shift * n);
    float th = dot(ts, h);
    return pow(sqrt(max(1.0 - th * th, 0.0)), e);
}

float strand_gloss = 1.0;  // strand brightness against the texture's mean (its last mip)
// share of the white highlight: on light hair the light scattered inside the strands
// outweighs it (a full one greyed daniel's light brown into a silver band); dark hair keeps it
float sheen = 1.0;

vec3 hair_specular(vec3 n, vec3 v, vec3 l, vec3 t) {
    vec3 h = normalize(l + v);
    float lit = smoothstep(0.0, 0.5, dot(n, l));
    float s1 = strand_spec(t, n, h, -0.1, u_shininess);
    float s2 = strand_spec(t, n, h, 0.15, 0.3 * u_shininess);
    return u_specular * lit * strand_gloss * (sheen * vec3(s1) + 0.8 * s2 * sqrt(base));
}

void main() {
    base = u_base;
    shininess = u_shininess;
    float a = 1.0;
    float gloss = 1.0;
    vec3 n = normalize(v_normal);
    vec3 v = normalize(-v_pos);
#ifdef TEXTURED
    {
#ifdef IRIS
        vec4 t = texture(u_tex, iris_uv(v_uv, v_pos, v));
#else
        vec4 t = texture(u_tex, v_uv);
#endif
        base = srgb_decode(t.rgb);
        a = t.a;
        if (u_alpha_mode == 0) gloss = a;  // opaque parts: alpha is a gloss map
#ifdef HAIR
        {
            // hair thins out toward its silhouette (strand ends seen edge-on); highlights
            // follow the strands (brighter strands shine more)
            a *= smoothstep(0.03, 0.45, abs(dot(n, v)));
            float mean = dot(textureLod(u_tex, v_uv, 16.0).rgb, vec3(0.3, 0.5, 0.2));  // sRGB
            strand_gloss = clamp(dot(t.rgb, vec3(0.3, 0.5, 0.2)) / max(mean, 0.02), 0.2, 2.0);
            sheen = mix(1.0, 0.2, smoothstep(0.08, 0.3, mean));
        }
#endif
    }
#endif
    base = mix(base, u_mucosa, v_occ.z * u_tint);
#ifdef DEPTH_ONLY
    // the depth pre-pass of cut-out parts, the only program that discards (a shader that
    // may discard loses early depth testing on llvmpipe): coverage only, colour masked off
    if (a < 0.5) discard;
    f_color = vec4(0.0);
    return;
#endif
    float facing = 1.0;
    if (!gl_FrontFacing) {
        n = -n;
        facing = u_backface;
    }
#ifdef WRINKLES
    float cavity;
    n = wrinkled_normal(n, v_pos, cavity);
    base *= cavity;
#endif
#ifdef DETAIL
    float rough;
    n = detail_normal(n, v_pos, v_uv, rough);
    shininess = u_shininess / (rough * rough);
#endif
#ifdef HAIR
    vec3 up = mat3(u_view) * vec3(0.0, 1.0, 0.0);
    vec3 t = up - dot(up, n) * n;
#ifdef FLOW
    {   // where the flow map's direction is unsure, world up as without one (not the plain
        // highlight: its glints lit single triangles of daniel's fringe)
        vec3 f = strand_direction(n, v_pos, v_uv);
        t = mix(t, f, smoothstep(0.3, 0.7, length(f)));
    }
#endif
    float defined = smoothstep(0.15, 0.5, length(t));
    vec3 sk = vec3(0.0), sf = vec3(0.0);
    if (defined < 1.0) {  // the crown, where strands converge: the standard highlight
        sk = vec3(specular(n, v, u_key_dir)) * (1.0 - defined);
        sf = vec3(specular(n, v, u_fill_dir)) * (1.0 - defined);
    }
    if (defined > 0.0) {  // elsewhere strand highlights (each branch is skipped per block)
        sk += hair_specular(n, v, u_key_dir, t) * defined;
        sf += hair_specular(n, v, u_fill_dir, t) * defined;
    }
#elif defined(EYE) || defined(CORNEA)
    vec3 sk = vec3(0.0), sf = vec3(0.0);  // the wet reflection below instead
#else
    vec3 sk = vec3(specular(n, v, u_key_dir));
    vec3 sf = vec3(specular(n, v, u_fill_dir));
#endif
    float ao = mix(1.0, v_occ.x, u_ao * (1.0 - v_occ.z));  // inside: the opening rules
    float kv = 1.0;
#ifdef SHADOWS
    kv = key_visibility(v_shadow);
#endif
#if defined(EYE) || defined(IRIS) || defined(CORNEA)
    float lid = lid_shade();
    kv *= lid;
#endif
#if defined(IRIS) && defined(TEXTURED)
    kv *= iris_key();
#endif
    // key and fill: diffuse + specular; rim: diffuse only (it lights silhouettes)
    vec3 c = u_key_col * kv * (diffuse(n, u_key_dir) * u_alpha + gloss * sk)
           + u_fill_col * sqrt(ao) * (diffuse(n, u_fill_dir) * u_alpha + gloss * sf)
           + u_rim_col * ao * diffuse(n, u_rim_dir) * u_alpha;
    vec3 ambient = mix(u_ground, u_sky, 0.5 + 0.5 * n.y) * base * u_alpha * ao;
#if defined(EYE) || defined(CORNEA)
    c += gloss * (0.25 + 0.75 * lid) * wet_reflection(n, v);
#endif
    // inside the mouth what light there is has bounced off its red walls
    c = (c + ambient) * facing * v_occ.y * mix(vec3(1.0), vec3(1.0, 0.86, 0.8), 1.0 - v_occ.y);
    if (u_alpha_mode >= 2) {  // premultiplied; a fringe's core (a >= 0.5) adds nothing
        a = (a >= 0.02 && (u_alpha_mode == 2 || a < 0.5)) ? a : 0.0;
        f_color = vec4(to_srgb(tonemap(c)) * a, a);
        return;
    }
    f_color = vec4(to_srgb(tonemap(c)), u_alpha);
}
