#version 330
// Skin pass (a): diffuse irradiance (wrap lighting, the light tinted where it wraps past the
// terminator) of every skin texel, linear RGB; alpha marks covered texels. The second target
// stores cm per texel along u and v, for the blur's radius in cm.
in vec3 v_normal;
in vec3 v_world;

#include "skin_light.glsl"

layout(location = 0) out vec4 f_irradiance;
layout(location = 1) out vec4 f_stretch;

void main() {
    vec3 n = normalize(v_normal);
    f_irradiance = vec4(skin_diffuse(n), 1.0);
    f_stretch = vec4(length(dFdx(v_world)), length(dFdy(v_world)), 0.0, 1.0);
}
