// Skin detail (DETAIL): a tangent-space normal map of the fine relief — pores, a millimetre
// grain, fine lines (RGB; +x along u, +y along v) — and a roughness scale (A: 0.5 + a) at the
// part's UVs, painted once per character (face/makehuman/paint/skin.py), in the frame of
// frame.glsl.
uniform sampler2D u_detail;

vec3 detail_normal(vec3 n, vec3 p, vec2 uv, out float rough) {
    vec4 t = texture(u_detail, uv);
    rough = 0.5 + t.a;
    vec3 m = t.rgb * 2.0 - 1.0;
    vec3 tu, tv;
    uv_frame(n, p, uv, tu, tv);
    return normalize(m.x * tu + m.y * tv + m.z * n);
}
