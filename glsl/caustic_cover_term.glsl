// caustic_cover_term.glsl: one covering photon's term of the conserving estimate,
// w(d / h) f_r(wi, wo) Phi / h^2, with the tests of caustic_estimate.glsl: front side
// (dot(wi, n) > 0), the stored normal (caustic_normal_cos), the flattened neighbourhood
// (height over the tangent plane at most caustic_disc * h, the photon's own radius: there is
// no search radius here), the filter.  Shared by the cover gather (caustic_cover.glsl) and the
// photon-splatting pass (splat_pass.frag).
// Takes: caustic_cover_point (the shading point's normal, viewer direction and material),
// then per photon its record's second texel w (octahedral wi, octahedral normal, c1 | c2,
// c3 | c4), d = p - q, d2 = |d|^2 and h2.  CPU reference: blockhash/frame/cover_estimate.py.
#ifndef CAUSTIC_COVER_TERM_GLSL
#define CAUSTIC_COVER_TERM_GLSL
#include "caustic_common.glsl"
#include "bh_octahedral.glsl"

vec3 cc_n;
vec3 cc_wo;
vec3 cc_diffuse;   // kd / pi
vec3 cc_specular;  // ks (e + 2) / (2 pi)
float cc_e;

void caustic_cover_point(vec3 n, vec3 wo, vec3 kd, vec3 ks, float e) {
    cc_n = n;
    cc_wo = wo;
    cc_diffuse = kd / CAUSTIC_PI;
    cc_specular = ks * ((e + 2.0) / (2.0 * CAUSTIC_PI));
    cc_e = e;
}

// The term before the division by pi (caustic_phong with its per-point parts hoisted:
// cos alpha = dot(reflect(wi about n), wo) = 2 (wi.n)(n.wo) - wi.wo).
vec3 caustic_cover_term(uvec4 w, vec3 d, float d2, float h2) {
    vec3 wi = bh_octahedral(w.x);
    float win = dot(wi, cc_n);
    if (win <= 0.0) {
        return vec3(0.0);
    }
    if (caustic_normal_cos > -1.5 && dot(bh_octahedral(w.y), cc_n) < caustic_normal_cos) {
        return vec3(0.0);  // the photon landed on a surface facing elsewhere
    }
    if (caustic_disc > -1.5 && abs(dot(d, cc_n)) > caustic_disc * sqrt(h2)) {
        return vec3(0.0);  // outside the flattened neighbourhood
    }
    vec2 c12 = unpackHalf2x16(w.z);
    vec2 c34 = unpackHalf2x16(w.w);
    vec3 power = vec3(c12, c34.x) * bh_power_scale;
    float c = max(2.0 * win * dot(cc_n, cc_wo) - dot(wi, cc_wo), 0.0);
    vec3 f = cc_diffuse + cc_specular * caustic_lobe(c, cc_e);
    float inv = 1.0 / h2;
    return (caustic_filter(d2 * inv) * inv) * f * power;
}

#endif
