// Distance from a reference point (or along a direction) per fragment, into an r32f target.
// Used by shadow maps (distance to the light) and back-face depth (distance to the eye).
// Host defines: ALONG_DIRECTION (0): 1 stores dot(p - origin, direction) instead of |p - origin|.
#version 430 core
#ifndef ALONG_DIRECTION
#define ALONG_DIRECTION 0
#endif
uniform vec3 origin;
uniform vec3 direction;
in vec3 world_position;
in vec3 world_normal;
out float distance_out;

void main() {
#if ALONG_DIRECTION
    distance_out = dot(world_position - origin, direction);
#else
    distance_out = length(world_position - origin);
#endif
}
