// caustic_cover.glsl: the conserving estimate over the cover gather (bh_cover.glsl):
// L = sum w(d / h) f_r(wi, wo) Phi / (pi h^2) over every photon whose own disc covers q
// (d < h, its own radius h; blockhash/frame/photon_radius.py); the term and its tests are
// caustic_cover_term.glsl's.
// Takes: q, its unit normal n, the unit direction toward the viewer wo, a modified Phong
// material.  Returns: the radiance.  CPU reference: blockhash/frame/cover_estimate.py.
#ifndef CAUSTIC_COVER_GLSL
#define CAUSTIC_COVER_GLSL
#include "caustic_cover_term.glsl"

void caustic_cover_visit(uint r, vec3 d, float d2, float h2);
#define BH_COVER_VISIT(r, d, d2, h2) caustic_cover_visit(r, d, d2, h2)
#include "bh_cover.glsl"

vec3 cc_sum;

void caustic_cover_visit(uint r, vec3 d, float d2, float h2) {
    cc_sum += caustic_cover_term(bh_fetch4(bh_cover_records, uint(BH_COVER_REC_W), 2u * r + 1u),
                                 d, d2, h2);
}

vec3 caustic_radiance(vec3 q, vec3 n, vec3 wo, vec3 kd, vec3 ks, float e) {
    cc_sum = vec3(0.0);
    caustic_cover_point(n, wo, kd, ks, e);
    bh_cover_gather(q);
    return cc_sum / CAUSTIC_PI;
}

#endif
