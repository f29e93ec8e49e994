// bh_octahedral.glsl: an octahedral unit vector from two snorm16
// (blockhash/index/records/octahedral.py, its CPU reference): no trigonometry.
#ifndef BH_OCTAHEDRAL_GLSL
#define BH_OCTAHEDRAL_GLSL

vec3 bh_octahedral(uint w) {
    vec2 f = unpackSnorm2x16(w);
    vec3 v = vec3(f, 1.0 - abs(f.x) - abs(f.y));
    float t = max(-v.z, 0.0);
    v.x += v.x >= 0.0 ? -t : t;
    v.y += v.y >= 0.0 ? -t : t;
    return normalize(v);
}

#endif
