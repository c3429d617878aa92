// Glass along a direction into an rgba32f target (the environment lobes' tinted glass shadows;
// passes/shading/environment.py EnvironmentLobeMaps), cleared to (0, 0, 0, FAR): rgb its optical depth, every fragment summed with
// additive blending (a + 0 stays FAR); then, host define NEAREST_DISTANCE 1, a the nearest fragment's
// distance along the direction by MIN blending (rgb = min(depth, FAR) stays).
// Along the straight line through the glass, -log T = sigma (z_out - z_in) - log(1 - F_in) - log(1 - F_out)
// per channel: each face adds its Fresnel loss and +-sigma z (z: the distance along the direction; + where
// the ray leaves, - where it enters), so any number of closed objects telescope into their chords. Open
// meshes (solid 0) add their interfaces' losses only. The light's displacement by refraction is not
// traced: for the soft light of a sky stratum the shadow is the same within the stratum's spread.
#version 430 core
#ifndef NEAREST_DISTANCE
#define NEAREST_DISTANCE 0
#endif
#define FAR 1e30
#include "common/optics.glsl"
uniform vec3 origin;
uniform vec3 direction;
uniform vec3 sigma;        // absorption coefficient per channel (Glass.absorption_coefficient)
uniform vec3 ior;          // per channel (Glass.ior_rgb)
uniform float solid;       // 1 for a closed mesh, 0 for an open one
in vec3 world_position;
in vec3 world_normal;
out vec4 depth_out;

void main() {
    float z = dot(world_position - origin, direction);
#if NEAREST_DISTANCE
    depth_out = vec4(vec3(FAR), z);
    return;
#endif
    float facing = dot(normalize(world_normal), direction);
    float c = abs(facing);
    vec3 loss = -log(max(vec3(1.0 - fresnel_dielectric(c, 1.0, ior.r), 1.0 - fresnel_dielectric(c, 1.0, ior.g),
                                  1.0 - fresnel_dielectric(c, 1.0, ior.b)), vec3(1e-6)));
    depth_out = vec4(loss + solid * sign(facing) * sigma * z, 0.0);
}
