// Fragment of a Gaussian photon sprite: the kernel weight at this texel's centre, into three r32f
// targets (R, G, B) with additive blending. FOOTPRINT 1: the photon's own kernel (caustic_footprint.glsl).
// Host defines: FOOTPRINT (0).
#version 430 core
#ifndef FOOTPRINT
#define FOOTPRINT 0
#endif
#include "passes/caustics/caustic_light_space.glsl"
#if FOOTPRINT
#include "passes/caustics/caustic_footprint.glsl"
flat in vec3 shape;
#endif
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
#if FOOTPRINT
    // The compute splat's texels: those within footprint_reach of the photon's texel.
    if (!footprint_covers(centre, ivec2(floor(gl_FragCoord.xy)), footprint_reach(shape))) discard;
    float w = footprint_kernel(centre, gl_FragCoord.xy, shape);
#else
    float w = splat_kernel(centre, gl_FragCoord.xy, splat_radius);
#endif
    if (w <= 0.0) discard;
    out_r = w * flux.r;
    out_g = w * flux.g;
    out_b = w * flux.b;
}
