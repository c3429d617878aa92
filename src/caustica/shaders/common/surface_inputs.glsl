// Inputs and outputs every surface-shading fragment shader shares (ShadeSurfaces).
// A technique's shader includes this, defines
//     vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_direction)
// for glass (v: unit view direction towards the surface, n: outward unit normal facing the
// eye), then includes "common/surface_main.glsl", which shades every material.
#include "common/optics.glsl"
#include "common/environment.glsl"
#include "common/lighting.glsl"
#include "common/caustics.glsl"

#ifndef DISPERSION
#define DISPERSION 1  // 1: one IOR per channel; ShadeSurfaces sets 0 for glass with a single IOR
#endif

#define MATERIAL_DIFFUSE 0
#define MATERIAL_MIRROR 1
#define MATERIAL_GLASS 2

uniform sampler2D environment;
uniform vec3 camera_position;
uniform mat4 camera_clip_from_world;
uniform int material_kind;
uniform vec3 material_color;
uniform vec3 ior_rgb;                  // glass: one IOR per channel (dispersion)
uniform vec3 absorption_coefficient;   // glass: Beer-Lambert sigma_a per channel
uniform float intensity_scale;

in vec3 world_position;
in vec3 world_normal;
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 exit_direction;  // debug: world direction leaving the refractor, w = 1 where defined
