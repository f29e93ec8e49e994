// caustic_estimate.glsl: caustic radiance from the k nearest photons (Jensen's
// density estimate; paper sections 1 and 6, the "Caustic RMS Error" images).
// Takes: the shading point q, its unit normal n, the unit direction toward the
// viewer wo, a modified Phong material (kd, ks, exponent: Lafortune & Willems,
// f = kd/pi + ks (e+2)/(2 pi) cos^e(alpha)), and bh_best from bh_lookup.
// Returns: L = sum f_r(wi, wo) Phi_p / (pi r^2) over the found photons that
// arrive from the front (dot(-d_p, n) > 0), r the distance to the farthest of
// them (the k-th when k were found), but never below sqrt(caustic_min_r2), the
// photon map's position error (blockhash/render/caustic.py min_radius): photons
// that coincide with the shading point give a large finite radiance, not 0 or inf.
// Powers are float16 times bh_power_scale.
// Defines: BH_K.  The CPU reference is blockhash/caustic.py estimate_cpu.
#ifndef CAUSTIC_ESTIMATE_GLSL
#define CAUSTIC_ESTIMATE_GLSL
#include "bh_blocks.glsl"
#include "bh_select.glsl"

#define CAUSTIC_PI 3.14159265358979
uniform float bh_power_scale;
uniform float caustic_min_r2;

// Jensen's polar code: theta byte | phi byte << 8, decoded at the cell centre, pole +y.
vec3 caustic_polar(uint code) {
    float theta = (float(code & 0xFFu) + 0.5) * (CAUSTIC_PI / 256.0);
    float phi = (float(code >> 8u) + 0.5) * (2.0 * CAUSTIC_PI / 256.0);
    return vec3(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
}

vec3 caustic_phong(vec3 wi, vec3 wo, vec3 n, vec3 kd, vec3 ks, float e) {
    vec3 r = 2.0 * dot(n, wi) * n - wi;
    float c = max(dot(r, wo), 0.0);
    return kd / CAUSTIC_PI + ks * ((e + 2.0) / (2.0 * CAUSTIC_PI)) * pow(c, e);
}

vec3 caustic_radiance(vec3 q, vec3 n, vec3 wo, vec3 kd, vec3 ks, float e) {
    vec3 sum = vec3(0.0);
    float r2 = 0.0;
    for (int i = 0; i < BH_K; ++i) {
        uvec2 key = bh_best[i];
        if (key.y == 0xFFFFFFFFu) {
            break;
        }
        r2 = max(uintBitsToFloat(key.x), caustic_min_r2);
        uint b = key.y / 10u;
        uint j = key.y % 10u;
        uint texel = b * uint(BH_BLOCK_TEXELS) + ((6u * j + 3u) >> 2u);
        uvec4 a = bh_fetch4(bh_blocks, BH_BLK_W, texel);
        uvec3 w = ((j & 1u) == 0u) ? uvec3(a.w, bh_fetch4(bh_blocks, BH_BLK_W, texel + 1u).xy)
                                   : a.yzw;  // words 6j+3 .. 6j+5
        vec3 wi = -caustic_polar(w.x & 0xFFFFu);
        if (dot(wi, n) <= 0.0) {
            continue;
        }
        vec2 c12 = unpackHalf2x16(w.y);
        vec2 c34 = unpackHalf2x16(w.z);
        vec3 power = vec3(c12, c34.x) * bh_power_scale;
        sum += caustic_phong(wi, wo, n, kd, ks, e) * power;
    }
    return r2 > 0.0 ? sum / (CAUSTIC_PI * r2) : vec3(0.0);
}

#endif
