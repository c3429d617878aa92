// A reflection probe's six faces (passes/shading/reflection_probes.py, each a 90-degree view from the probe's
// centre) resampled into one equirect image of the environment's mapping (common/environment.glsl), the source
// prefilter_environment.frag convolves: texel (i, j) of a width x height image holds direction
// equirect_direction(((i + 0.5) / width, j / (height - 1))), the face whose axis is nearest it looked up
// through that face's own projection. Where no object was drawn (alpha 0) the probe sees the environment
// (``environment``: the one glossy receivers reflect, less a sun that comes as a light), at the mip level
// whose texels this image's span. A face's radiance is divided by the scene's intensity scale: the probe
// holds radiance as the environment does.
#version 430 core
#include "common/environment.glsl"

uniform sampler2D face0;
uniform sampler2D face1;
uniform sampler2D face2;
uniform sampler2D face3;
uniform sampler2D face4;
uniform sampler2D face5;
uniform mat4 face_clip_from_world[6];  // in CUBE_FORWARD's order: +X, -X, +Y, -Y, +Z, -Z
uniform vec3 probe_centre;
uniform sampler2D environment;
uniform float environment_lod;
uniform float intensity_scale;
uniform ivec2 size;  // this image's width and height
out vec4 probe;

vec4 face_texel(int face, vec2 st) {
    if (face == 0) return textureLod(face0, st, 0.0);
    if (face == 1) return textureLod(face1, st, 0.0);
    if (face == 2) return textureLod(face2, st, 0.0);
    if (face == 3) return textureLod(face3, st, 0.0);
    if (face == 4) return textureLod(face4, st, 0.0);
    return textureLod(face5, st, 0.0);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec2 uv = vec2((float(pixel.x) + 0.5) / float(size.x), float(pixel.y) / float(size.y - 1));
    vec3 d = equirect_direction(uv);
    vec3 a = abs(d);
    int face = a.x >= a.y && a.x >= a.z ? (d.x > 0.0 ? 0 : 1) : (a.y >= a.z ? (d.y > 0.0 ? 2 : 3) : (d.z > 0.0 ? 4 : 5));
    vec4 clip = face_clip_from_world[face] * vec4(probe_centre + d, 1.0);
    vec4 seen = face_texel(face, clamp(clip.xy / clip.w * 0.5 + 0.5, 0.0, 1.0));
    if (seen.a > 0.5) {
        probe = vec4(seen.rgb / intensity_scale, 1.0);
        return;
    }
    vec2 at = vec2(uv.x, equirect_row_coordinate(uv.y, float(textureSize(environment, 0).y)));
    probe = vec4(textureLod(environment, at, environment_lod).rgb, 1.0);
}
