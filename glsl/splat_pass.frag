// splat_pass.frag: one photon's term at the pixels of its rectangle (splat_pass.vert), added
// (blending ONE, ONE) into the caustic: the shading point the pixel sees directly
// (cp_position, cp_normal, cp_view, as caustic_pass.frag takes them) gets the term of
// caustic_cover_term.glsl when the photon's disc covers it.  Points seen in a mirror or through
// glass lie elsewhere than where their photons project, and get nothing.
// Returns: radiance / path weight, summed over the photons (RGBA32F).
#include "caustic_cover_term.glsl"

uniform sampler2D cp_position;
uniform sampler2D cp_normal;
uniform sampler2D cp_view;
uniform vec3 cp_kd[16];
uniform vec3 cp_ks[16];
uniform float cp_exponent[16];
flat in vec4 v_position_h2;
flat in uvec4 v_payload;
out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 pos = texelFetch(cp_position, px, 0);
    if (pos.w < 0.0 || any(isnan(pos.xyz)) || any(isinf(pos.xyz))) {
        discard;
    }
    precise vec3 d = v_position_h2.xyz - pos.xyz;
    precise float d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
    if (!(d2 < v_position_h2.w)) {
        discard;
    }
    int m = int(pos.w);
    caustic_cover_point(texelFetch(cp_normal, px, 0).xyz, texelFetch(cp_view, px, 0).xyz,
                        cp_kd[m], cp_ks[m], cp_exponent[m]);
    frag_color = vec4(caustic_cover_term(v_payload, d, d2, v_position_h2.w) / CAUSTIC_PI, 0.0);
}
