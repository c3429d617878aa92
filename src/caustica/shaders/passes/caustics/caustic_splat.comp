// Photon splat with integer atomics: each photon adds its flux, spread by a normalised Gaussian over
// the caustic-map texels within splat_radius, to the fixed-point sums of fixed_point_flux.glsl (R, G, B;
// order-independent, so the same photons give the same bytes). FLUX_BOUND 1 only raises the bound.
// FOOTPRINT 1: each photon's Gaussian is its own, from caustic_footprint.comp (binding 1: shape and flux
// scale per photon, caustic_footprint.glsl), instead of splat_radius's.
// Host defines: FLUX_BOUND (0), FOOTPRINT (0) (VIEW_COUNT 1: view 0 is the caustic map's view).
#version 430 core
#ifndef FLUX_BOUND
#define FLUX_BOUND 0
#endif
#ifndef FOOTPRINT
#define FOOTPRINT 0
#endif
#include "passes/caustics/caustic_light_space.glsl"
#include "passes/caustics/fixed_point_flux.glsl"
#if FOOTPRINT
#include "passes/caustics/caustic_footprint.glsl"
#endif
layout(local_size_x = 64) in;

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) readonly buffer Photons { Photon photons[]; };
#if FOOTPRINT
layout(std430, binding = 1) readonly buffer Footprints { vec4 footprints[]; };
#endif
uniform int photon_count;
uniform float splat_radius;

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= photon_count) return;
    Photon ph = photons[i];
    if (ph.position.w <= 0.0 || all(equal(ph.flux.rgb, vec3(0.0)))) return;
#if FLUX_BOUND
    flux_bound(ph.flux.rgb);  // a texel takes w / sum(w) <= 1 of the photon's flux
#else
    int face;
    bool inside;
    vec2 c = view_pixel(0, ph.position.xyz, face, inside);
    if (!inside) return;
    int n = view_size[0];
    int e = flux_step_exponent();
    ivec2 base = ivec2(floor(c));
#if FOOTPRINT
    vec4 shape = footprints[i];
    if (shape.w <= 0.0) return;
    vec3 flux = ph.flux.rgb * shape.w;
    ivec2 k = footprint_reach(shape.xyz);
#else
    vec3 flux = ph.flux.rgb * splat_normaliser(c, splat_radius);
    ivec2 k = ivec2(int(ceil(splat_radius)) + 1);
#endif
    for (int j = -k.y; j <= k.y; ++j) {
#if FOOTPRINT
        ivec2 row = footprint_row(c, j, shape.xyz, k.x);
#else
        ivec2 row = ivec2(-k.x, k.x);
#endif
        for (int q = row.x; q <= row.y; ++q) {
            ivec2 texel = base + ivec2(q, j);
            if (texel.x < face * n || texel.x >= face * n + n || texel.y < 0 || texel.y >= n) continue;
#if FOOTPRINT
            float w = footprint_kernel(c, vec2(texel) + 0.5, shape.xyz);
#else
            float w = splat_kernel(c, vec2(texel) + 0.5, splat_radius);
#endif
            if (w <= 0.0) continue;
            for (int channel = 0; channel < 3; ++channel) flux_add(channel, texel, w * flux[channel], e);
        }
    }
#endif
}
