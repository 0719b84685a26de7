// Diffuse light of skin: wrap lighting from the three studio lights, the light tinted by
// u_scatter where it wraps past the terminator, plus the sky/ground hemisphere; ``kv`` is the
// key light's visibility (its shadow), ``ao`` the ambient occlusion (darkens ambient, fill, rim).
#include "lights.glsl"
uniform float u_wrap;
uniform vec3 u_scatter;

vec3 wrapped(vec3 n, vec3 l, vec3 col) {
    float ndl = dot(n, l);
    float lambert = max(ndl, 0.0);
    float w = max((ndl + u_wrap) / (1.0 + u_wrap), 0.0);
    return col * (lambert + max(w - lambert, 0.0) * u_scatter);
}

vec3 skin_diffuse(vec3 n, float kv, float ao) {
    return kv * wrapped(n, u_key_dir, u_key_col) + sqrt(ao) * wrapped(n, u_fill_dir, u_fill_col)
         + ao * wrapped(n, u_rim_dir, u_rim_col) + ao * mix(u_ground, u_sky, 0.5 + 0.5 * n.y);
}
