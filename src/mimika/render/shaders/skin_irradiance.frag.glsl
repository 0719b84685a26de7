#version 330
// Skin pass (a): diffuse irradiance (wrap lighting, the light tinted where it wraps past the
// terminator) of every skin texel, linear RGB; alpha marks covered texels. The second target
// stores cm per texel along u and v, for the blur's radius in cm.
in vec3 v_normal;
in vec3 v_world;

uniform float u_wrap;
uniform vec3 u_scatter;
uniform vec3 u_key_dir;
uniform vec3 u_key_col;
uniform vec3 u_fill_dir;
uniform vec3 u_fill_col;
uniform vec3 u_rim_dir;
uniform vec3 u_rim_col;
uniform vec3 u_sky;
uniform vec3 u_ground;

layout(location = 0) out vec4 f_irradiance;
layout(location = 1) out vec4 f_stretch;

vec3 wrapped(vec3 n, vec3 l, vec3 col) {
    float ndl = dot(n, l);
    float lambert = max(ndl, 0.0);
    float w = max((ndl + u_wrap) / (1.0 + u_wrap), 0.0);
    return col * (lambert + max(w - lambert, 0.0) * u_scatter);
}

void main() {
    vec3 n = normalize(v_normal);
    vec3 e = wrapped(n, u_key_dir, u_key_col) + wrapped(n, u_fill_dir, u_fill_col)
           + wrapped(n, u_rim_dir, u_rim_col) + mix(u_ground, u_sky, 0.5 + 0.5 * n.y);
    f_irradiance = vec4(e, 1.0);
    f_stretch = vec4(length(dFdx(v_world)), length(dFdy(v_world)), 0.0, 1.0);
}
