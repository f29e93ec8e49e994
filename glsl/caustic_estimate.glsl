// caustic_estimate.glsl: caustic radiance from the k nearest photons (Jensen's
// density estimate; paper sections 1 and 6, the "Caustic RMS Error" images).
// Takes: the shading point q, its unit normal n, the unit direction toward the
// viewer wo, a modified Phong material (kd, ks, exponent: Lafortune & Willems,
// f = kd/pi + ks (e+2)/(2 pi) cos^e(alpha)), and bh_best from bh_lookup.
// Returns: L = sum w(d/r) f_r(wi, wo) Phi_p / (pi r^2) over the found photons that
// arrive from the front (dot(-d_p, n) > 0) and pass the tests below, r the distance
// to the farthest photon found (the k-th when k were found), but never below
// sqrt(caustic_min_r2), the photon map's position error (blockhash/frame/caustic.py
// min_radius): photons that coincide with the shading point give a large finite
// radiance, not 0 or inf.  Powers are float16 times bh_power_scale.
// Tests (uniforms, -2 = off): the photon's stored surface normal (Fig. 4) must have
// dot(n_p, n) >= caustic_normal_cos; its height over the tangent plane must be at
// most caustic_disc * r (Jensen's flattened neighbourhood).
// Defines: BH_K; CAUSTIC_ESTIMATE 0 paper (all m found), 1 unbiased (the m-th,
// which lies on the circle, left out: no m/(m-1) bias) or 2 conserving (each photon
// over its own disc: r^2 replaced by the photon's own squared radius h^2, read from
// caustic_own_r2 (R32F, wrapped rows of width 2^CAUSTIC_OWN_W, by the photon's slot),
// and only photons with d < h counted; blockhash/frame/photon_radius.py); CAUSTIC_FILTER 0 none,
// 1 cone 3(1-t), 2 epanechnikov 2(1-t^2), 3 silverman 3(1-t^2)^2, t = d/r.
// The CPU reference is blockhash/frame/caustic.py estimate_cpu; the options
// blockhash/frame/estimate.py EstimateOptions.
#ifndef CAUSTIC_ESTIMATE_GLSL
#define CAUSTIC_ESTIMATE_GLSL
#include "bh_blocks.glsl"
#if !BH_CELLS
#include "bh_select.glsl"
#endif

#include "caustic_common.glsl"
#if CAUSTIC_ESTIMATE == 2
uniform sampler2D caustic_own_r2;
#endif

#if !BH_CELLS
// Number of photons found: bh_best holds them first, nearest first, then empty keys.
// A binary search of constant count (unrolled: it adds nothing to llvmpipe's loop budget).
int caustic_found() {
    int lo = 0;
    int hi = BH_K;
    for (int s = 0; s < 8; ++s) {  // 2^8 > MAX_K = 128
        if (lo < hi) {
            int mid = (lo + hi) >> 1;
            if (bh_best[mid].y == 0xFFFFFFFFu) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
    }
    return lo;
}
#endif

// The contribution of the photon in slot `slot` at squared distance d2 from q, before the
// division by pi r^2 (0 when a test rejects it).
vec3 caustic_photon(uint slot, float d2, vec3 q, vec3 n, vec3 wo, vec3 kd, vec3 ks, float e,
                    float r2, float height) {
    uint b = slot / 10u;
    uint j = slot % 10u;
    uint texel = b * uint(BH_BLOCK_TEXELS) + ((6u * j + 3u) >> 2u);
    uvec4 a = bh_fetch4(bh_blocks, BH_BLK_W, texel);
    uvec3 w = ((j & 1u) == 0u) ? uvec3(a.w, bh_fetch4(bh_blocks, BH_BLK_W, texel + 1u).xy)
                               : a.yzw;  // words 6j+3 .. 6j+5
    vec3 wi = -caustic_polar(w.x & 0xFFFFu);
    if (dot(wi, n) <= 0.0) {
        return vec3(0.0);
    }
    if (caustic_normal_cos > -1.5 && dot(caustic_polar(w.x >> 16u), n) < caustic_normal_cos) {
        return vec3(0.0);  // the photon landed on a surface facing elsewhere
    }
    if (caustic_disc > -1.5 && abs(dot(bh_photon_position(b, j) - q, n)) > height) {
        return vec3(0.0);  // outside the flattened neighbourhood
    }
    vec2 c12 = unpackHalf2x16(w.y);
    vec2 c34 = unpackHalf2x16(w.z);
    vec3 power = vec3(c12, c34.x) * bh_power_scale;
#if CAUSTIC_ESTIMATE == 2
    float h2 = texelFetch(caustic_own_r2, bh_texel(slot, uint(CAUSTIC_OWN_W)), 0).r;
    float t2 = d2 / h2;
    if (!(t2 < 1.0)) {
        return vec3(0.0);  // the photon's own disc does not reach the shading point
    }
    return caustic_filter(t2) * caustic_phong(wi, wo, n, kd, ks, e) * power * (r2 / h2);
#else
    float t2 = d2 / r2;
    return caustic_filter(t2) * caustic_phong(wi, wo, n, kd, ks, e) * power;
#endif
}

#if BH_CELLS
// The cell lookup keeps no list: the selected photons are visited again (bh_cells_pass,
// BH_PASS_VISIT), each through caustic_visit with the estimate's inputs held here.
vec3 ce_sum;
vec3 ce_q;
vec3 ce_n;
vec3 ce_wo;
vec3 ce_kd;
vec3 ce_ks;
float ce_e;
float ce_r2;
float ce_height;
bool ce_skip;  // unbiased: the farthest selected photon (bh_max_bits, bh_max_slot) left out

void caustic_visit(uint s, uint bits) {
    if (ce_skip && bits == bh_max_bits && s == bh_max_slot) {
        return;
    }
    ce_sum += caustic_photon(s, uintBitsToFloat(bits), ce_q, ce_n, ce_wo, ce_kd, ce_ks, ce_e,
                             ce_r2, ce_height);
}

vec3 caustic_radiance(vec3 q, vec3 n, vec3 wo, vec3 kd, vec3 ks, float e) {
    uint m = bh_cells_select(q);
    if (m == 0u) {
        return vec3(0.0);
    }
    // The radius is the farthest selected photon's distance: one more pass finds it where
    // the form needs it (the conserving form's r^2 cancels unless the disc test is on).
#if CAUSTIC_ESTIMATE == 2
    bool need = caustic_disc > -1.5;
#else
    bool need = true;
#endif
    float r2 = 1.0;
    bh_max_bits = 0u;
    bh_max_slot = 0u;
    if (need) {
        bh_cells_pass(BH_PASS_MAX, q, 0u);
        r2 = max(uintBitsToFloat(bh_max_bits), caustic_min_r2);
    }
    ce_skip = CAUSTIC_ESTIMATE == 1;
    ce_sum = vec3(0.0);
    ce_q = q;
    ce_n = n;
    ce_wo = wo;
    ce_kd = kd;
    ce_ks = ks;
    ce_e = e;
    ce_r2 = r2;
    ce_height = caustic_disc * sqrt(r2);
    bh_cells_pass(BH_PASS_VISIT, q, 0u);
    return ce_sum / (CAUSTIC_PI * r2);
}
#else
vec3 caustic_radiance(vec3 q, vec3 n, vec3 wo, vec3 kd, vec3 ks, float e) {
    int m = caustic_found();
    if (m == 0) {
        return vec3(0.0);
    }
    float r2 = max(uintBitsToFloat(bh_best[m - 1].x), caustic_min_r2);
#if CAUSTIC_ESTIMATE == 0 || CAUSTIC_ESTIMATE == 2
    int used = m;      // paper, conserving: all m photons
#elif CAUSTIC_ESTIMATE == 1
    int used = m - 1;  // unbiased: the m-th, on the circle, left out
#else
#error unknown CAUSTIC_ESTIMATE
#endif
    float height = caustic_disc * sqrt(r2);
    vec3 sum = vec3(0.0);
    for (int i = 0; i < used; ++i) {
        uvec2 key = bh_best[i];
        sum += caustic_photon(key.y, uintBitsToFloat(key.x), q, n, wo, kd, ks, e, r2, height);
    }
    return sum / (CAUSTIC_PI * r2);
}
#endif

#endif
