// Photon splat as additive Gaussian point sprites (Shah et al. III-F): one point per photon, sized to
// cover the kernel of caustic_light_space.glsl, so it deposits what the compute splat deposits.
// FOOTPRINT 1: each photon's own Gaussian from caustic_footprint.comp (in_shape: shape, flux scale).
// Host defines: FOOTPRINT (0).
#version 430 core
#ifndef FOOTPRINT
#define FOOTPRINT 0
#endif
#include "passes/caustics/caustic_light_space.glsl"
#if FOOTPRINT
#include "passes/caustics/caustic_footprint.glsl"
in vec4 in_shape;
flat out vec3 shape;
#endif
in vec4 in_position;
in vec4 in_flux;
uniform float splat_radius;
flat out vec2 centre;
flat out vec3 flux;
flat out int face;

void main() {
    bool inside;
    centre = view_pixel(0, in_position.xyz, face, inside);
    int n = view_size[0];
    vec2 size = vec2(float((view_kind[0] == VIEW_CUBE ? 6 : 1) * n), float(n));
#if FOOTPRINT
    shape = in_shape.xyz;
    flux = in_flux.rgb * in_shape.w;
    bool keep = inside && in_position.w > 0.0 && in_shape.w > 0.0;
    ivec2 reach = keep ? footprint_reach(in_shape.xyz) : ivec2(0);
    gl_PointSize = 2.0 * float(max(reach.x, reach.y)) + 2.0;  // covers the texel centres within reach
#else
    flux = in_flux.rgb * splat_normaliser(centre, splat_radius);
    bool keep = inside && in_position.w > 0.0;
    gl_PointSize = 2.0 * ceil(splat_radius) + 2.0;
#endif
    gl_Position = keep ? vec4(centre / size * 2.0 - 1.0, 0.0, 1.0) : vec4(2.0, 2.0, 2.0, 1.0);
}
