// Fragment of a Gaussian photon sprite: the kernel weight at this texel's centre, into three r32f
// targets (R, G, B) with additive blending. Host defines: none.
#version 430 core
#include "passes/caustic_light_space.glsl"
uniform float splat_radius;
flat in vec2 centre;
flat in vec3 flux;
flat in int face;
layout(location = 0) out float out_r;
layout(location = 1) out float out_g;
layout(location = 2) out float out_b;

void main() {
    int n = view_size[0];
    if (gl_FragCoord.x < float(face * n) || gl_FragCoord.x > float(face * n + n)) discard;
    float w = splat_kernel(centre, gl_FragCoord.xy, splat_radius);
    if (w <= 0.0) discard;
    out_r = w * flux.r;
    out_g = w * flux.g;
    out_b = w * flux.b;
}
