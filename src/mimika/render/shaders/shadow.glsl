// The key light's shadow: a depth map seen from the light (orthographic), compared with
// hardware filtering (2×2 per tap) over 4 taps of a disc turned per pixel: a penumbra of
// u_shadow_radius texels. v_shadow is the light-space position, offset along the normal.
uniform sampler2DShadow u_shadow_map;
uniform float u_shadow_radius;  // texels
uniform vec2 u_shadow_texel;    // 1 / map size

const vec2 DISC[4] = vec2[4](vec2(-0.25, -0.75), vec2(0.75, -0.25), vec2(0.25, 0.75),
                             vec2(-0.75, 0.25));

float key_visibility(vec4 s) {
    vec3 p = s.xyz / s.w * 0.5 + 0.5;
    if (p.x <= 0.0 || p.x >= 1.0 || p.y <= 0.0 || p.y >= 1.0 || p.z >= 1.0) return 1.0;
    float a = fract(sin(dot(gl_FragCoord.xy, vec2(12.9898, 78.233))) * 43758.5453) * 6.2832;
    mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a));
    float sum = 0.0;
    for (int i = 0; i < 4; i++) {
        vec2 o = rot * DISC[i] * u_shadow_radius * u_shadow_texel;
        sum += texture(u_shadow_map, vec3(p.xy + o, p.z));
    }
    return sum * 0.25;
}
