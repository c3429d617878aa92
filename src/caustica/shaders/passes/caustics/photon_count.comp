// Photons that landed and are splatted (live: adaptive_states.glsl, the w of every regular-grid photon),
// counted into one uint (passes/caustics/light_space.py, Photons.live): a readback of 4 bytes, not of the photons.
#version 430 core
#include "passes/post/adaptive_states.glsl"
layout(local_size_x = 64) in;

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) readonly buffer Photons { Photon photons[]; };
layout(std430, binding = 1) buffer Count { uint live; };
uniform int photon_count;

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= photon_count) return;
    Photon ph = photons[i];
    if (ph.position.w > 0.5 && ph.flux.w == STATE_LIVE && any(notEqual(ph.flux.rgb, vec3(0.0)))) atomicAdd(live, 1u);
}
