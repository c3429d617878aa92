// One bounce through the environment lobes' maps (passes/shading/environment.py EnvironmentLobeMaps): per lobe texel,
// the radiance of the nearest opaque surface facing along the lobe (the surface a receiver behind the
// occluder sees where the lobe's sky is blocked), albedo / pi times its irradiance from the lights (the
// environment's sun, shadowed) and from the sky above its horizon (irradiance_sh: the environment without
// its sun and with nothing below the horizon, as the floor under an occluder lies in its shadow). Faces
// turned towards the lobe are discarded; the depth test keeps the nearest. Host defines: MAX_LIGHTS.
#version 430 core
#include "common/lighting.glsl"
uniform vec3 direction;    // the lobe's direction of travel
uniform vec3 albedo;       // the surface's diffuse albedo (0 for mirrors)
in vec3 world_position;
in vec3 world_normal;
out vec4 radiance_out;

void main() {
    vec3 n = normalize(world_normal);
    if (dot(n, direction) <= 0.0) discard;
    radiance_out = vec4(albedo / 3.14159265 * (direct_irradiance(world_position, n) + ambient_irradiance(n)), 1.0);
}
