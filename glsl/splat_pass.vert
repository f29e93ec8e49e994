// splat_pass.vert: photon splatting (image-space photon mapping: McGuire & Luebke, HPG 2009;
// Mara, Luebke & McGuire, I3D 2013), the same conserving estimate as the cover gather,
// scattered instead of gathered.  One instance per photon, 4 vertices (a triangle strip):
// the screen rectangle of the photon's cube [p - h, p + h]^3, widened by half a pixel, holds
// the pixel centre of every surface point within h of the photon seen directly by the camera.
// A cube with a corner behind the camera covers the whole screen.
// Takes: per instance the cover gather's record (blockhash/index/lookups/cover.py: position and h^2,
// then its second texel); view_proj, splat_half_pixel (half a pixel in NDC).
uniform mat4 view_proj;
uniform vec2 splat_half_pixel;
in vec4 in_position_h2;
in uvec4 in_payload;
flat out vec4 v_position_h2;
flat out uvec4 v_payload;

void main() {
    vec3 p = in_position_h2.xyz;
    float h = sqrt(in_position_h2.w);
    vec2 lo = vec2(1.0e30);
    vec2 hi = vec2(-1.0e30);
    bool behind = false;
    for (int c = 0; c < 8; ++c) {
        vec3 corner = p + h * vec3((c & 1) != 0 ? 1.0 : -1.0, (c & 2) != 0 ? 1.0 : -1.0,
                                   (c & 4) != 0 ? 1.0 : -1.0);
        vec4 clip = view_proj * vec4(corner, 1.0);
        if (clip.w <= 0.0) {
            behind = true;
        } else {
            lo = min(lo, clip.xy / clip.w);
            hi = max(hi, clip.xy / clip.w);
        }
    }
    if (behind) {
        lo = vec2(-1.0);
        hi = vec2(1.0);
    }
    lo = max(lo - splat_half_pixel, vec2(-1.0));
    hi = min(hi + splat_half_pixel, vec2(1.0));  // off screen: lo > hi, nothing is drawn
    gl_Position = vec4((gl_VertexID & 1) != 0 ? hi.x : lo.x, (gl_VertexID & 2) != 0 ? hi.y : lo.y,
                       0.0, 1.0);
    v_position_h2 = in_position_h2;
    v_payload = in_payload;
}
