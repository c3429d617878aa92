// Photon splats, photon buffer (Wyman, "Rendering From the Light", step 2): each photon leaving the
// refractors (exit point, direction and flux from photon_refract.frag, one texel each, CHANNELS photons
// a texel) lands on the receivers: the intersection estimate (land_photon) against the receivers'
// light-space position texture (view 0). The first guess is the distance to the receiver behind the
// exit point, or, in a second pass, to where the first pass landed the photon. Photons of a single
// surface (water) are absorbed (Beer-Lambert) from the surface down to the receiver; those with exit point w = 2
// landed already (under glass standing on the receiver).
// Writes the photon buffer in the layout of light_space.py's Photons: {vec4 position (w = 1 landed);
// vec4 flux}, entry (texel row * width + column) * CHANNELS + channel.
// Host defines: CHANNELS (1 or 3), MAX_CASTERS (32), VIEW_COUNT (1).
#version 430 core
#ifndef CHANNELS
#define CHANNELS 1
#endif
#ifndef MAX_CASTERS
#define MAX_CASTERS 32
#endif
#include "passes/caustics/caustic_light_space.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

struct Photon { vec4 position; vec4 flux; };
layout(std430, binding = 0) writeonly buffer Photons { Photon photons[]; };
layout(std430, binding = 1) readonly buffer Initial { Photon initial[]; };
uniform int has_initial;

uniform sampler2D photon_flux;  // rgb W, a: caster index + 1 where the photon is absorbed down to the receiver
uniform sampler2D photon_origin0;  // channel c: exit point, w = 1 where the photon exists
uniform sampler2D photon_direction0;  // channel c: exit direction
#if CHANNELS == 3
uniform sampler2D photon_origin1;
uniform sampler2D photon_direction1;
uniform sampler2D photon_origin2;
uniform sampler2D photon_direction2;
#endif
uniform sampler2D receiver_position;  // view 0
uniform vec3 caster_sigma[MAX_CASTERS];
uniform int iterations;
uniform int estimator;
uniform float fallback_distance;  // first guess where no receiver lies behind the exit point

// Channel c's exit point and direction at texel t (separate samplers: Mesa mis-indexes sampler arrays here).
void exit_ray(int c, ivec2 t, out vec4 o, out vec3 r) {
    o = texelFetch(photon_origin0, t, 0);
    r = texelFetch(photon_direction0, t, 0).xyz;
#if CHANNELS == 3
    if (c == 1) {
        o = texelFetch(photon_origin1, t, 0);
        r = texelFetch(photon_direction1, t, 0).xyz;
    } else if (c == 2) {
        o = texelFetch(photon_origin2, t, 0);
        r = texelFetch(photon_direction2, t, 0).xyz;
    }
#endif
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(photon_flux, 0);
    if (t.x >= size.x || t.y >= size.y) return;
    int first = (t.y * size.x + t.x) * CHANNELS;
    vec4 flux = texelFetch(photon_flux, t, 0);
    int absorber = int(flux.a + 0.5) - 1;
    for (int c = 0; c < CHANNELS; ++c) {
        int index = first + c;
        photons[index] = Photon(vec4(0.0), vec4(0.0));
        vec4 o;
        vec3 r;
        exit_ray(c, t, o, r);
        vec3 mask = CHANNELS == 1 ? vec3(1.0) : vec3(c == 0, c == 1, c == 2);
        vec3 carried = flux.rgb * mask;
        if (o.w <= 0.0 || all(equal(carried, vec3(0.0)))) continue;
        if (o.w > 1.5) {  // landed already: on the receiver under a face the glass stands on (photon_refract.frag)
            photons[index] = Photon(vec4(o.xyz, 1.0), vec4(carried, 0.0));
            continue;
        }
        // Land: from where the first pass landed, or the receiver seen through the exit point.
        float d0 = has_initial != 0 && initial[index].position.w > 0.0 ? max(dot(initial[index].position.xyz - o.xyz, r), 1e-4 * length_unit)
                                                                        : 0.0;
        vec4 hit = land_photon(receiver_position, 0, o.xyz, r, d0, fallback_distance, iterations, estimator);
        if (hit.w <= 0.0) continue;
        if (absorber >= 0 && absorber < MAX_CASTERS) carried *= exp(-caster_sigma[absorber] * length(hit.xyz - o.xyz));
        photons[index] = Photon(hit, vec4(carried, 0.0));
    }
}
