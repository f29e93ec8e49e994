// bh_box.glsl: the photon map's fixed-point box (paper 3.2, blockhash/index/records/fixedpoint.py).
// Takes: nothing.  Returns: the uniforms both hashing and photon decoding use:
// lower corner, code step and its float32 reciprocal, each exactly the float32
// values of the Python Quantizer; bh_quantize, a query's codes (Quantizer.quantize_query).
#ifndef BH_BOX_GLSL
#define BH_BOX_GLSL

uniform vec3 bh_lo;
uniform vec3 bh_step;
uniform vec3 bh_inv_step;

uvec3 bh_quantize(vec3 q) {
    precise vec3 t = (q - bh_lo) * bh_inv_step;
    t = min(max(t, vec3(0.0)), vec3(4294967040.0));  // largest float32 below 2^32
    return uvec3(t);
}

#endif
