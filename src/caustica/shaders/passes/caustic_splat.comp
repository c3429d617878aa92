// Photon splat with integer atomics: each photon adds its flux, spread by a normalised Gaussian over
// the caustic-map texels within splat_radius, to the fixed-point sums of fixed_point_flux.glsl (R, G, B;
// order-independent, so the same photons give the same bytes). FLUX_BOUND 1 only raises the bound.
// Host defines: FLUX_BOUND (0) (VIEW_COUNT 1: view 0 is the caustic map's view).
#version 430 core
#ifndef FLUX_BOUND
#define FLUX_BOUND 0
#endif
#include "passes/caustic_light_space.glsl"
#include "passes/fixed_point_flux.glsl"
layout(local_size_x = 64) in;

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) readonly buffer Photons { Photon photons[]; };
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
    vec3 flux = ph.flux.rgb * splat_normaliser(c, splat_radius);
    int e = flux_step_exponent();
    int k = int(ceil(splat_radius)) + 1;
    ivec2 base = ivec2(floor(c));
    for (int j = -k; j <= k; ++j)
        for (int q = -k; q <= k; ++q) {
            ivec2 texel = base + ivec2(q, j);
            if (texel.x < face * n || texel.x >= face * n + n || texel.y < 0 || texel.y >= n) continue;
            float w = splat_kernel(c, vec2(texel) + 0.5, splat_radius);
            if (w <= 0.0) continue;
            for (int channel = 0; channel < 3; ++channel) flux_add(channel, texel, w * flux[channel], e);
        }
#endif
}
