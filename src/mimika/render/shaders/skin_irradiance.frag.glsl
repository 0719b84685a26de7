#version 330
// Skin pass (a): diffuse irradiance (wrap lighting, the light tinted where it wraps past the
// terminator; the key light's shadow and the occlusion) of every skin texel, linear RGB; alpha
// marks covered texels. The second target stores cm per texel along u and v, for the blur's
// radius in cm.
in vec3 v_normal;
in vec3 v_world;
in vec3 v_occ;
#ifdef SHADOWS
in vec4 v_shadow;
#include "shadow.glsl"
#endif

uniform float u_ao;
#include "skin_light.glsl"

layout(location = 0) out vec4 f_irradiance;
layout(location = 1) out vec4 f_stretch;

void main() {
    vec3 n = normalize(v_normal);
    float kv = 1.0;
#ifdef SHADOWS
    kv = key_visibility(v_shadow);
#endif
    f_irradiance = vec4(skin_diffuse(n, kv, mix(1.0, v_occ.x, u_ao * (1.0 - v_occ.z))) * v_occ.y, 1.0);
    f_stretch = vec4(length(dFdx(v_world)), length(dFdy(v_world)), 0.0, 1.0);
}
