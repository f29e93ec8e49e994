// caustic_common.glsl: what every form of the caustic estimate shares (caustic_estimate.glsl
// over the k nearest, caustic_cover.glsl over the cover gather): the photon's polar codes
// (Fig. 4), the modified Phong BRDF, the filter weights and the tests' uniforms.
// Defines: CAUSTIC_FILTER 0 none, 1 cone 3(1-t), 2 epanechnikov 2(1-t^2), 3 silverman
// 3(1-t^2)^2, t = d/r.  CPU: blockhash/frame/estimate.py (kernel, photon_weights).
#ifndef CAUSTIC_COMMON_GLSL
#define CAUSTIC_COMMON_GLSL

#define CAUSTIC_PI 3.14159265358979
uniform float bh_power_scale;
uniform float caustic_min_r2;
uniform float caustic_normal_cos;
uniform float caustic_disc;

// Jensen's polar code: theta byte | phi byte << 8, decoded at the cell centre, pole +y.
vec3 caustic_polar(uint code) {
    float theta = (float(code & 0xFFu) + 0.5) * (CAUSTIC_PI / 256.0);
    float phi = (float(code >> 8u) + 0.5) * (2.0 * CAUSTIC_PI / 256.0);
    return vec3(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
}

// cos^e alpha of the Phong lobe for c = max(cos alpha, 0) >= 0 and e >= 0, with 0^0 = 1 as the
// CPU's c ** e: GLSL leaves pow(0, 0) undefined, and NVIDIA's exp2(e * log2(c)) makes it NaN,
// which a diffuse receiver's ks = 0 does not cancel (0 * NaN is NaN).
float caustic_lobe(float c, float e) {
    return e > 0.0 ? pow(c, e) : 1.0;
}

vec3 caustic_phong(vec3 wi, vec3 wo, vec3 n, vec3 kd, vec3 ks, float e) {
    vec3 r = 2.0 * dot(n, wi) * n - wi;
    float c = max(dot(r, wo), 0.0);
    return kd / CAUSTIC_PI + ks * ((e + 2.0) / (2.0 * CAUSTIC_PI)) * caustic_lobe(c, e);
}

// Filter weight from t^2 = (d / r)^2, normalised to mean 1 over the unit disc.
float caustic_filter(float t2) {
    t2 = clamp(t2, 0.0, 1.0);
#if CAUSTIC_FILTER == 0
    return 1.0;
#elif CAUSTIC_FILTER == 1
    return 3.0 * (1.0 - sqrt(t2));
#elif CAUSTIC_FILTER == 2
    return 2.0 * (1.0 - t2);
#elif CAUSTIC_FILTER == 3
    return 3.0 * (1.0 - t2) * (1.0 - t2);
#else
#error unknown CAUSTIC_FILTER
#endif
}

#endif
