// Per-pixel labels of the first surface the camera sees (passes/post/labels.py, LabelSurfaces; docs/labels.md).
// surface: world normal facing the eye xyz, view-space depth w (distance along the camera's -Z; 0: nothing).
// ids: object index + 1, material index + 1, 1 on glass, 1 (covered); all 0 on the background.
// caustic (LABEL_CAUSTIC): intensity_scale times the caustic irradiance on a diffuse receiver, 0 elsewhere.
// Host defines: COVERAGE_ONLY (0; 1: write 1 to the only target, the supersampled coverage), ID_DEPTH (0;
// 1: write object index + 1 and view-space depth to the only target, for multisampled outlines, passes/post/subpixel.py),
// LABEL_CAUSTIC (0/1: the third target), CAUSTIC_RECEIVER (0/1: look the caustic up; the variant for diffuse
// objects, since a CPU rasterizer pays for both sides of a branch), CAUSTICS, CAUSTIC_TILES, MAX_LIGHTS,
// MAX_CAUSTIC_TILES (common/caustics.glsl).
#version 430 core
#ifndef COVERAGE_ONLY
#define COVERAGE_ONLY 0
#endif
#ifndef ID_DEPTH
#define ID_DEPTH 0
#endif
#ifndef LABEL_CAUSTIC
#define LABEL_CAUSTIC 0
#endif
#ifndef CAUSTIC_RECEIVER
#define CAUSTIC_RECEIVER 0
#endif
#if CAUSTIC_RECEIVER
#include "common/lighting.glsl"
#include "common/caustics.glsl"
uniform float intensity_scale;
#endif

in vec3 world_position;
in vec3 world_normal;
layout(location = 0) out vec4 surface;
#if !COVERAGE_ONLY
uniform vec3 camera_position;
uniform vec3 camera_forward;  // unit, world space
uniform float object_id;      // index + 1
uniform float material_id;    // index + 1
uniform float glass;          // 1 on glass
#if !ID_DEPTH
layout(location = 1) out vec4 ids;
#endif
#if LABEL_CAUSTIC
layout(location = 2) out vec4 caustic;
#endif
#endif

void main() {
#if COVERAGE_ONLY
    surface = vec4(1.0);
#else
    vec3 to_surface = world_position - camera_position;
    vec3 n = normalize(world_normal);
    if (dot(n, to_surface) > 0.0) n = -n;  // facing the eye
#if ID_DEPTH
    surface = vec4(object_id, dot(to_surface, camera_forward), 0.0, 0.0);
#else
    surface = vec4(n, dot(to_surface, camera_forward));
    ids = vec4(object_id, material_id, glass, 1.0);
#endif
#if LABEL_CAUSTIC
#if CAUSTIC_RECEIVER
    caustic = vec4(intensity_scale * caustic_irradiance(world_position, n), 1.0);
#else
    caustic = vec4(0.0, 0.0, 0.0, 1.0);
#endif
#endif
#endif
}
