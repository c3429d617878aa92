// TVCG 3.2: photon buffer -> caustic textures, on the GPU (the paper reads the buffer back; no readback here).
// A photon buffer texel holds the throughput rgb (colour) and the record (u, v, k + 1, hit) of the
// rectangle its refracted or reflected ray met (3.1). Its flux is the light's intensity times the
// texel's solid angle (cos^3 fall-off off the axis; spot cone smoothstep) times the throughput, added
// with integer atomics into the fixed-point sums of fixed_point_flux.glsl over an atlas of C x C tiles
// (order-independent), spread over the texel's footprint on tile k: the parallelogram spanned by the
// landing points of its neighbours in the photon buffer (the paper adds each photon to one texel and
// lets a fixed filter fill between them; where the neighbours land far apart, as for rays grazing a
// ball, such a filter leaves gaps between photon rows). FLUX_BOUND 1 only raises the bound.
// Host defines: FLUX_BOUND (0), MAX_FOOTPRINT (texels: the longest footprint side, larger ones shrink to it).
#version 430 core
#ifndef FLUX_BOUND
#define FLUX_BOUND 0
#endif
#ifndef MAX_FOOTPRINT
#define MAX_FOOTPRINT 16
#endif
#include "passes/caustics/fixed_point_flux.glsl"
#include "passes/caustics/texel_solid_angle.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D throughput;
uniform sampler2D record;
uniform vec3 light_position;
uniform vec3 light_intensity;     // W/sr (directional: irradiance times the pinhole distance squared)
uniform vec3 light_axis;          // the spot's axis
uniform vec2 light_cone;          // spot: cos(inner), cos(outer); (-2, -2) for none
uniform mat4 world_from_clip;     // the photon camera
uniform vec3 camera_forward;
uniform float unit_area;          // texel area on the photon camera's image plane at unit distance
uniform float intensity_scale;    // the shading pass multiplied the throughput by this
uniform int tile_size;
uniform int tile_count;

// Where photon buffer texel q landed on tile k, in tile texels; false if it met no rectangle or another one.
bool landing(ivec2 q, int k, out vec2 x) {
    x = vec2(0.0);
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, textureSize(record, 0)))) return false;
    vec4 rec = texelFetch(record, q, 0);
    if (rec.w < 0.5 || int(rec.z + 0.5) - 1 != k) return false;
    x = rec.xy * float(tile_size);
    return true;
}

// One side of texel t's footprint on tile k (landing at x): the step to its neighbour along `step`, the
// shorter of the two one-sided steps where both neighbours landed on the tile (a neighbour across a
// discontinuity of the refraction, or off the caster, does not stretch it), zero where neither did.
vec2 footprint_side(ivec2 t, ivec2 step, int k, vec2 x) {
    vec2 ahead, behind;
    bool has_ahead = landing(t + step, k, ahead), has_behind = landing(t - step, k, behind);
    vec2 forward = ahead - x, backward = x - behind;
    vec2 side = has_ahead && has_behind ? (dot(forward, forward) <= dot(backward, backward) ? forward : backward)
              : has_ahead ? forward : has_behind ? backward : vec2(0.0);
    float extent = length(side);
    return extent > float(MAX_FOOTPRINT) ? side * (float(MAX_FOOTPRINT) / extent) : side;
}

// Bilinear (tent) deposit of `flux` around x (tile texels), clamped into tile k: the weights sum to 1.
void deposit(vec2 x, vec3 flux, int k, int e) {
    vec2 corner = x - 0.5;
    vec2 base = floor(corner), f = corner - base;
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) {
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            ivec2 texel = clamp(ivec2(base) + ivec2(i, j), ivec2(0), ivec2(tile_size - 1)) + ivec2(k * tile_size, 0);
            for (int channel = 0; channel < 3; ++channel) flux_add(channel, texel, w * flux[channel], e);
        }
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(record, 0);
    if (t.x >= size.x || t.y >= size.y) return;
    vec4 rec = texelFetch(record, t, 0);
    int k = int(rec.z + 0.5) - 1;
    if (rec.w < 0.5 || k < 0 || k >= tile_count) return;
    vec2 ndc = (vec2(t) + 0.5) / vec2(size) * 2.0 - 1.0;
    vec4 far_point = world_from_clip * vec4(ndc, 1.0, 1.0);
    vec3 ray = normalize(far_point.xyz / far_point.w - light_position);
    float c = dot(ray, camera_forward);
    vec3 intensity = light_intensity;
    if (light_cone.x > -1.5) {
        float s = clamp((dot(ray, light_axis) - light_cone.y) / max(light_cone.x - light_cone.y, 1e-9), 0.0, 1.0);
        intensity *= s * s * (3.0 - 2.0 * s);
    }
    vec3 flux = texel_flux(texelFetch(throughput, t, 0).rgb / intensity_scale * intensity, unit_area, c);
    // The flux spread evenly over the footprint parallelogram x + a s + b t (s, t in [-1/2, 1/2]) by a
    // grid of sub-photons at most a texel apart, each deposited bilinearly (a bilinear deposit alone,
    // for a footprint under a texel, keeps a photon grid as fine as the tile from beating against it:
    // tests/test_caustic_radiometry.py). The sub-photons' weights sum to 1: the flux is kept.
    vec2 x = clamp(rec.xy, 0.0, 1.0) * float(tile_size);
#if FLUX_BOUND
    flux_bound(flux);
#else
    vec2 a = footprint_side(t, ivec2(1, 0), k, x), b = footprint_side(t, ivec2(0, 1), k, x);
    int na = max(int(ceil(length(a))), 1), nb = max(int(ceil(length(b))), 1);
    vec3 share = flux / float(na * nb);
    int e = flux_step_exponent();
    for (int j = 0; j < nb; ++j)
        for (int i = 0; i < na; ++i)
            deposit(x + a * ((float(i) + 0.5) / float(na) - 0.5) + b * ((float(j) + 0.5) / float(nb) - 0.5),
                    share, k, e);
#endif
}
