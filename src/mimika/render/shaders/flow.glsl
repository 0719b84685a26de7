// Hair strand flow (FLOW): per texel the strands' root→tip direction as a·∇u + b·∇v (RG:
// 0.5 + 0.5·(a, b)) and how well the surface carries it (B: 1 along the surface), painted
// with the hair (face/makehuman/paint/hair.py), so the strand highlights run across the
// strands as they are drawn, however they are combed.
uniform sampler2D u_detail;

// The strands' direction at the pixel, tip to root, in the surface: unit where the surface
// carries it, shorter where it does not or where the triangle stands across the smoothed
// normal (the shader falls back to world up there).
vec3 strand_direction(vec3 n, vec3 p, vec2 uv) {
    vec3 f = texture(u_detail, uv).rgb;
    vec2 d = f.rg * 2.0 - 1.0;
    // the triangle's own frame: hair's smoothed normals lean far off its crumpled cards,
    // and a frame built on them is skewed differently on every triangle (facets of light)
    vec3 nf = normalize(cross(dFdx(p), dFdy(p)));
    vec3 gu, gv;
    uv_frame(nf * sign(dot(nf, n)), p, uv, gu, gv);
    vec3 t = -(d.x * gu + d.y * gv);
    t *= inversesqrt(max(dot(t, t), 1e-12));
    // in the plane of the smooth normal: short where the triangle stands across it
    return (t - dot(t, n) * n) * f.b;
}
