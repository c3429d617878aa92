// TVCG 3.2: photon buffer -> caustic textures, on the GPU (the paper reads the buffer back; no readback here).
// A photon buffer texel holds the throughput rgb (colour) and the record (u, v, k + 1, hit) of the
// rectangle its refracted or reflected ray met (3.1). Its flux is the light's intensity times the
// texel's solid angle (cos^3 fall-off off the axis; spot cone smoothstep) times the throughput, added
// with integer atomics, bilinearly around texel (k * C + u C, v C), into the fixed-point sums of fixed_point_flux.glsl
// over an atlas of C x C tiles (order-independent). FLUX_BOUND 1 only raises the bound.
// Host defines: FLUX_BOUND (0).
#version 430 core
#ifndef FLUX_BOUND
#define FLUX_BOUND 0
#endif
#include "passes/fixed_point_flux.glsl"
#include "passes/texel_solid_angle.glsl"
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
    // Bilinear (tent) deposit over the four texels around (u, v), clamped into tile k: a photon grid
    // about as fine as the tile's texels no longer beats against them (nearest-texel adds rang by
    // 30 percent under a spot light: tests/test_caustic_radiometry.py). The weights sum to 1.
    vec2 x = clamp(rec.xy, 0.0, 1.0) * float(tile_size) - 0.5;
    vec2 base = floor(x), f = x - base;
#if FLUX_BOUND
    flux_bound(flux);
#else
    int e = flux_step_exponent();
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) {
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            ivec2 texel = clamp(ivec2(base) + ivec2(i, j), ivec2(0), ivec2(tile_size - 1)) + ivec2(k * tile_size, 0);
            for (int channel = 0; channel < 3; ++channel) flux_add(channel, texel, w * flux[channel], e);
        }
#endif
}
