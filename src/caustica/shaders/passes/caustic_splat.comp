// Photon splat with float atomics (GL_NV_shader_atomic_float): each photon adds its flux, spread by a
// normalised Gaussian over the caustic-map texels within splat_radius, to three r32f images (R, G, B).
// Host defines: none (VIEW_COUNT 1: view 0 is the caustic map's view).
#version 430 core
#extension GL_NV_shader_atomic_float : require
#include "passes/caustic_light_space.glsl"
layout(local_size_x = 64) in;

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) readonly buffer Photons { Photon photons[]; };
layout(r32f, binding = 0) uniform image2D flux_r;
layout(r32f, binding = 1) uniform image2D flux_g;
layout(r32f, binding = 2) uniform image2D flux_b;
uniform int photon_count;
uniform float splat_radius;

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= photon_count) return;
    Photon ph = photons[i];
    if (ph.position.w <= 0.0 || all(equal(ph.flux.rgb, vec3(0.0)))) return;
    int face;
    bool inside;
    vec2 c = view_pixel(0, ph.position.xyz, face, inside);
    if (!inside) return;
    int n = view_size[0];
    vec3 flux = ph.flux.rgb * splat_normaliser(c, splat_radius);
    int k = int(ceil(splat_radius)) + 1;
    ivec2 base = ivec2(floor(c));
    for (int j = -k; j <= k; ++j)
        for (int q = -k; q <= k; ++q) {
            ivec2 texel = base + ivec2(q, j);
            if (texel.x < face * n || texel.x >= face * n + n || texel.y < 0 || texel.y >= n) continue;
            float w = splat_kernel(c, vec2(texel) + 0.5, splat_radius);
            if (w <= 0.0) continue;
            if (flux.r != 0.0) imageAtomicAdd(flux_r, texel, w * flux.r);
            if (flux.g != 0.0) imageAtomicAdd(flux_g, texel, w * flux.g);
            if (flux.b != 0.0) imageAtomicAdd(flux_b, texel, w * flux.b);
        }
}
