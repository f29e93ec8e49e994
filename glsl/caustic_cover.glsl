// caustic_cover.glsl: the conserving estimate over the cover gather (bh_cover.glsl):
// L = sum w(d / h) f_r(wi, wo) Phi / (pi h^2) over every photon whose own disc covers q
// (d < h, its own radius h; blockhash/render/photon_radius.py), with the tests of
// caustic_estimate.glsl: front side (dot(wi, n) > 0), the stored normal (caustic_normal_cos),
// the flattened neighbourhood (height over the tangent plane at most caustic_disc * h, the
// photon's own radius: there is no search radius here), the filter.
// Takes: q, its unit normal n, the unit direction toward the viewer wo, a modified Phong
// material.  Returns: the radiance.  CPU reference: blockhash/render/cover_estimate.py.
#ifndef CAUSTIC_COVER_GLSL
#define CAUSTIC_COVER_GLSL
#include "caustic_common.glsl"

void caustic_cover_visit(uint r, vec3 d, float d2, float h2);
#define BH_COVER_VISIT(r, d, d2, h2) caustic_cover_visit(r, d, d2, h2)
#include "bh_cover.glsl"

vec3 cc_sum;
vec3 cc_n;
vec3 cc_wo;
vec3 cc_diffuse;   // kd / pi
vec3 cc_specular;  // ks (e + 2) / (2 pi)
float cc_e;
float cc_nwo;      // dot(n, wo)

// One covering photon's term: the tests, then w(d / h) f_r Phi / h^2 (caustic_phong with its
// per-point parts hoisted: cos alpha = dot(reflect(wi about n), wo) = 2 (wi.n)(n.wo) - wi.wo).
void caustic_cover_visit(uint r, vec3 d, float d2, float h2) {
    uvec4 w = bh_fetch4(bh_cover_records, uint(BH_COVER_REC_W), 2u * r + 1u);
    vec3 wi = bh_octahedral(w.x);
    float win = dot(wi, cc_n);
    if (win <= 0.0) {
        return;
    }
    if (caustic_normal_cos > -1.5 && dot(bh_octahedral(w.y), cc_n) < caustic_normal_cos) {
        return;  // the photon landed on a surface facing elsewhere
    }
    if (caustic_disc > -1.5 && abs(dot(d, cc_n)) > caustic_disc * sqrt(h2)) {
        return;  // outside the flattened neighbourhood
    }
    vec2 c12 = unpackHalf2x16(w.z);
    vec2 c34 = unpackHalf2x16(w.w);
    vec3 power = vec3(c12, c34.x) * bh_power_scale;
    float c = max(2.0 * win * cc_nwo - dot(wi, cc_wo), 0.0);
    vec3 f = cc_diffuse + cc_specular * pow(c, cc_e);
    float inv = 1.0 / h2;
    cc_sum += (caustic_filter(d2 * inv) * inv) * f * power;
}

vec3 caustic_radiance(vec3 q, vec3 n, vec3 wo, vec3 kd, vec3 ks, float e) {
    cc_sum = vec3(0.0);
    cc_n = n;
    cc_wo = wo;
    cc_diffuse = kd / CAUSTIC_PI;
    cc_specular = ks * ((e + 2.0) / (2.0 * CAUSTIC_PI));
    cc_e = e;
    cc_nwo = dot(n, wo);
    bh_cover_gather(q);
    return cc_sum / CAUSTIC_PI;
}

#endif
