// Light-space surface buffer (Shah et al. III-B, first two passes): world position and distance to the
// light, and outward world normal with an object code (casters: index + 1; receivers and occluders: 0).
// Host defines: ALONG_DIRECTION (0): 1 stores dot(p - origin, direction) (directional lights);
// PEEL (0): 1 keeps only fragments farther from the light than the surface `peel` holds at their texel
// (same view; a depth peel: the glass's second layer behind its nearest back faces).
#version 430 core
#ifndef ALONG_DIRECTION
#define ALONG_DIRECTION 0
#endif
#ifndef PEEL
#define PEEL 0
#endif
#if PEEL
uniform sampler2D peel;  // position + distance (0: nothing to peel behind)
#endif
uniform vec3 origin;
uniform vec3 direction;
uniform float object_code;
in vec3 world_position;
in vec3 world_normal;
layout(location = 0) out vec4 position_out;
layout(location = 1) out vec4 normal_out;

void main() {
#if ALONG_DIRECTION
    float d = dot(world_position - origin, direction);
#else
    float d = length(world_position - origin);
#endif
#if PEEL
    float behind = texelFetch(peel, ivec2(gl_FragCoord.xy), 0).a;
    if (behind <= 0.0 || d <= behind * (1.0 + 1e-5)) discard;
#endif
    position_out = vec4(world_position, max(d, 1e-20));
    normal_out = vec4(normalize(world_normal), object_code);
}
