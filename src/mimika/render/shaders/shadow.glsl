// The key light's shadow: a depth map seen from the light (orthographic), compared with
// hardware filtering (2×2 per tap) over 4 taps of a disc turned per pixel: a penumbra of
// u_shadow_radius texels. v_shadow is the light-space position, offset along the normal.
//
// SOFT_SHADOWS (on skin): the key is an area light (a softbox), so where a shadow falls far
// from what casts it, its penumbra widens (percentage-closer soft shadows) — the jaw's shadow
// fades over the neck while the nose's on the lip stays crisp. A blocker search finds the
// mean depth of what lies nearer the light, and four more taps filter over the penumbra that
// follows from it. (Every pixel pays for them: llvmpipe runs the branches not taken too.)
uniform sampler2DShadow u_shadow_map;
uniform float u_shadow_radius;  // texels: the least penumbra
uniform vec2 u_shadow_texel;    // 1 / map size
#ifdef SOFT_SHADOWS
uniform sampler2D u_shadow_depth;  // the same map, its depths (the blocker search)
uniform float u_shadow_max;        // texels: the widest penumbra
uniform float u_shadow_spread;     // penumbra texels per depth unit from blocker to receiver
uniform float u_shadow_slope;      // depth units per texel a tap may lie nearer on a curve
#endif

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
#ifdef SOFT_SHADOWS
    mat2 turn = mat2(0.7071, 0.7071, -0.7071, 0.7071) * rot;  // between the first taps
    float found = 0.0, depth = 0.0;
    for (int i = 0; i < 4; i++) {
        vec2 o = turn * DISC[i] * u_shadow_max;
        float d = texture(u_shadow_depth, p.xy + o * u_shadow_texel).r;
        // a tap off to the side may see the receiver's own curve nearer the light
        if (d < p.z - max(length(o) - u_shadow_radius, 0.0) * u_shadow_slope) {
            found += 1.0;
            depth += d;
        }
    }
    if (found == 0.0) return sum * 0.25;
    float radius = min(u_shadow_radius + (p.z - depth / found) * u_shadow_spread, u_shadow_max);
    for (int i = 0; i < 4; i++) {
        vec2 o = turn * DISC[i] * radius;
        float reach = max(length(o) - u_shadow_radius, 0.0) * u_shadow_slope;
        sum += texture(u_shadow_map, vec3(p.xy + o * u_shadow_texel, p.z - reach));
    }
    return sum * 0.125;
#else
    return sum * 0.25;
#endif
}
