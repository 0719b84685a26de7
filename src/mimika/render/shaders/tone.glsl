// The tone curve of the shaded parts: exposure, a soft shoulder, sRGB encoding; and the
// decoding of sRGB textures. Kept cheap: it runs per pixel on llvmpipe (no pow).
uniform float u_exposure;

// Linear to sRGB without pow (fit within ~0.5/255 of the exact curve; llvmpipe-cheap).
vec3 to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 s1 = sqrt(c);
    vec3 s2 = sqrt(s1);
    vec3 s3 = sqrt(s2);
    return clamp(0.662002687 * s1 + 0.684122060 * s2 - 0.323583601 * s3 - 0.0225411470 * c,
                 0.0, 1.0);
}

// Soft shoulder so bright highlights roll off instead of clipping.
vec3 tonemap(vec3 c) {
    vec3 x = c * u_exposure;
    vec3 knee = vec3(0.8);
    vec3 over = max(x - knee, 0.0);
    return min(x, knee) + over / (1.0 + over / (1.0 - knee.x));
}

// sRGB to linear (Taylor's cubic fit, within 0.3 % of the exact curve; no pow on llvmpipe)
vec3 srgb_decode(vec3 c) {
    return c * (c * (c * 0.305306011 + 0.682171111) + 0.012522878);
}
