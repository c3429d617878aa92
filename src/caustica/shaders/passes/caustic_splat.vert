// Photon splat as additive Gaussian point sprites (Shah et al. III-F): one point per photon, sized to
// cover the kernel of caustic_light_space.glsl, so it deposits what the compute splat deposits.
// Host defines: none.
#version 430 core
#include "passes/caustic_light_space.glsl"
in vec4 in_position;
in vec4 in_flux;
uniform float splat_radius;
flat out vec2 centre;
flat out vec3 flux;
flat out int face;

void main() {
    bool inside;
    centre = view_pixel(0, in_position.xyz, face, inside);
    flux = in_flux.rgb * splat_normaliser(centre, splat_radius);
    int n = view_size[0];
    vec2 size = vec2(float((view_kind[0] == VIEW_CUBE ? 6 : 1) * n), float(n));
    bool keep = inside && in_position.w > 0.0;
    gl_Position = keep ? vec4(centre / size * 2.0 - 1.0, 0.0, 1.0) : vec4(2.0, 2.0, 2.0, 1.0);
    gl_PointSize = 2.0 * ceil(splat_radius) + 2.0;
}
