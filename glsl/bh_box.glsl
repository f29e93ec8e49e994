// bh_box.glsl: the photon map's fixed-point box (paper 3.2, blockhash/fixedpoint.py).
// Takes: nothing.  Returns: the uniforms both hashing and photon decoding use:
// lower corner, code step and its float32 reciprocal, each exactly the float32
// values of the Python Quantizer.
#ifndef BH_BOX_GLSL
#define BH_BOX_GLSL

uniform vec3 bh_lo;
uniform vec3 bh_step;
uniform vec3 bh_inv_step;

#endif
