// Inputs and outputs every surface-shading fragment shader shares (ShadeSurfaces).
// A technique's shader includes this, defines
//     vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_direction)
// for glass (v: unit view direction towards the surface, n: outward unit normal facing the
// eye), then includes "common/surface_main.glsl", which shades every material.
// Host defines: MATERIAL_DIFFUSE, _MIRROR, _GLASS (scene/codes.py: material_kind's and SURFACE_KIND's
// codes; the shader library sets them in every program); ALBEDO_TEXTURE (0; 1: a textured diffuse receiver).
#include "common/optics.glsl"
#include "common/environment.glsl"
#include "common/lighting.glsl"
#include "common/caustics.glsl"

#ifndef DISPERSION
#define DISPERSION 1  // 1: one IOR per channel; ShadeSurfaces sets 0 for glass with a single IOR
#endif

#if !defined(MATERIAL_DIFFUSE) || !defined(MATERIAL_MIRROR) || !defined(MATERIAL_GLASS)
#error "MATERIAL_* come from the host (scene/codes.py); surface_main.glsl's #if would read them as 0"
#endif

uniform sampler2D environment;
uniform vec3 camera_position;
uniform mat4 camera_clip_from_world;
uniform int material_kind;
uniform vec3 material_color;
uniform vec3 ior_rgb;                  // glass: one IOR per channel (dispersion)
uniform vec3 absorption_coefficient;   // glass: Beer-Lambert sigma_a per channel
uniform float intensity_scale;

// Deferred shading (ShadeSurfaces' ``deferred``): small triangles make a rasterizer shade many
// partly covered pixel blocks, which a costly shader pays for on a CPU. A deferring run draws
// every object with DEFER_SHADE_NOW (shaded as usual, G-buffer cleared) or, for the deferred
// kinds, DEFER_GBUFFER (G-buffer only: the eye-facing normal times the object's id, and the
// distance along the pixel's ray from the near plane); then each deferred object is shaded
// over the whole screen with DEFER_RESOLVE, where the depth test passes only its pixels.
#define DEFER_NONE 0
#define DEFER_SHADE_NOW 1
#define DEFER_GBUFFER 2
#define DEFER_RESOLVE 3
#ifndef CAPTURE_FRONT_SURFACE
#define CAPTURE_FRONT_SURFACE 0  // 1: a glass G-buffer draw also writes the front-surface buffer (ShadeSurfaces)
#endif
#ifndef DEFERRED_SHADING
#define DEFERRED_SHADING DEFER_NONE
#endif
#ifndef DEFER_STAGE
#define DEFER_STAGE 0  // a resolve in one stage; 1, 2: the first or second of two (ShadeSurfaces' ``staged``)
#endif

#if DEFERRED_SHADING == DEFER_GBUFFER || DEFERRED_SHADING == DEFER_RESOLVE
uniform mat4 deferred_world_from_clip;
uniform vec2 deferred_viewport;  // pixels

// The ray of this pixel: its point on the near plane and unit direction.
void deferred_pixel_ray(out vec3 origin, out vec3 direction) {
    vec2 ndc = gl_FragCoord.xy / deferred_viewport * 2.0 - 1.0;
    vec4 near = deferred_world_from_clip * vec4(ndc, -1.0, 1.0);
    vec4 far = deferred_world_from_clip * vec4(ndc, 1.0, 1.0);
    origin = near.xyz / near.w;
    direction = normalize(far.xyz / far.w - origin);
}
#endif
#if DEFERRED_SHADING == DEFER_RESOLVE
uniform sampler2D deferred_surface;  // eye-facing unit normal times the object id xyz, distance along the ray w
vec3 world_position;
vec3 world_normal;
#else
in vec3 world_position;
in vec3 world_normal;
#endif

// Diffuse albedo: material_color, times the texture at the surface's uvs in the textured variant
// (ALBEDO_TEXTURE 1: linear RGB, bilinear with mipmaps, repeating; scene/textures.py's convention).
#ifndef ALBEDO_TEXTURE
#define ALBEDO_TEXTURE 0
#endif
#if ALBEDO_TEXTURE && DEFERRED_SHADING == DEFER_RESOLVE
#error "a textured receiver is shaded per fragment (its uvs are not in the G-buffer)"
#endif
#if ALBEDO_TEXTURE
uniform sampler2D albedo_texture;
in vec2 surface_uv;
vec3 surface_albedo() { return material_color * texture(albedo_texture, surface_uv).rgb; }
#else
vec3 surface_albedo() { return material_color; }
#endif
#if DEFERRED_SHADING == DEFER_GBUFFER
layout(location = 0) out vec4 deferred_surface_out;
uniform float deferred_id;  // this object's id in the G-buffer (1, 2, ...)
#if CAPTURE_FRONT_SURFACE
layout(location = 1) out vec4 front_surface_out;  // RefractorSurfaces' front buffer, written by the glass G-buffer draw
#endif
vec4 color;
vec4 exit_direction;
#else
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 exit_direction;  // debug: world direction leaving the refractor, w = 1 where defined
#endif
#if DEFERRED_SHADING == DEFER_SHADE_NOW
layout(location = 2) out vec4 deferred_surface_out;
#endif
#if DEFERRED_SHADING == DEFER_RESOLVE && DEFER_STAGE == 1
// The first of two resolve stages: a shader sets deferred_refine where the second stage must
// shade the pixel again (its costlier path); main() writes the object's key there, 0 elsewhere.
layout(location = 2) out float deferred_refine_out;
uniform float deferred_key;  // this object's key (deferred_resolve.vert)
bool deferred_refine = false;
#endif
