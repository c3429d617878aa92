// Inputs and outputs every surface-shading fragment shader shares (ShadeSurfaces).
// A technique's shader includes this, defines
//     vec3 shade_refractor(vec3 v, vec3 n, out vec4 exit_direction)
// for glass (v: unit view direction towards the surface, n: outward unit normal facing the
// eye), then includes "common/surface_main.glsl", which shades every material.
// Host defines: MATERIAL_DIFFUSE, _MIRROR, _GLASS (scene/codes.py: material_kind's and SURFACE_KIND's
// codes; the shader library sets them in every program); ALBEDO_TEXTURE (0; 1: a textured diffuse receiver);
// an opaque PBR receiver's (below).
#include "common/optics.glsl"
#include "common/environment.glsl"
#include "common/microfacet.glsl"
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
#ifndef SURFACE_UV
#define SURFACE_UV 0  // 1: the vertex stage passes surface_uv (a textured receiver's)
#endif
#if SURFACE_UV || ALBEDO_TEXTURE
in vec2 surface_uv;
#endif
#if ALBEDO_TEXTURE
uniform sampler2D albedo_texture;
vec3 surface_albedo() { return material_color * texture(albedo_texture, surface_uv).rgb; }
#else
vec3 surface_albedo() { return material_color; }
#endif

// An opaque glTF metallic-roughness receiver (a Principled drawn "diffuse"; ShadeSurfaces' variants): host
// defines GLOSSY (1: its GGX specular lobe), METALLIC_ROUGHNESS_TEXTURE, NORMAL_TEXTURE, OCCLUSION_TEXTURE,
// EMISSION_TEXTURE (1: that map at surface_uv, SURFACE_UV 1 with them), EMISSIVE (1: material_emission added).
// PRINCIPLED is 1 where any is: surface_main.glsl's shade_principled then shades the receiver. Maps are linear
// (scene/textures.py's convention): metallic-roughness's G roughness and B metallic multiply the factors,
// occlusion's R dims the ambient and environment light by occlusion_strength, the normal map's tangent-space
// normal (n * 0.5 + 0.5, green up the image) tilts the shading normal in the mesh's tangent frame.
#ifndef GLOSSY
#define GLOSSY 0
#endif
#ifndef METALLIC_ROUGHNESS_TEXTURE
#define METALLIC_ROUGHNESS_TEXTURE 0
#endif
#ifndef NORMAL_TEXTURE
#define NORMAL_TEXTURE 0
#endif
#ifndef OCCLUSION_TEXTURE
#define OCCLUSION_TEXTURE 0
#endif
#ifndef EMISSION_TEXTURE
#define EMISSION_TEXTURE 0
#endif
#ifndef EMISSIVE
#define EMISSIVE 0
#endif
#define PRINCIPLED (GLOSSY || METALLIC_ROUGHNESS_TEXTURE || NORMAL_TEXTURE || OCCLUSION_TEXTURE || EMISSIVE)
#if (METALLIC_ROUGHNESS_TEXTURE || NORMAL_TEXTURE || OCCLUSION_TEXTURE || EMISSION_TEXTURE) && !SURFACE_UV
#error "a receiver's maps are looked up at surface_uv: SURFACE_UV 1"
#endif
#if PRINCIPLED
uniform float material_metallic;
uniform float material_roughness;
uniform vec3 material_dielectric_f0;  // min(0.04 specular_color, 1) specular
uniform vec3 material_emission;
uniform float material_normal_scale;
uniform float material_occlusion_strength;
uniform sampler2D prefiltered_environment;  // common/environment.glsl prefiltered_radiance's atlas
uniform int prefiltered_levels;
#endif
#if METALLIC_ROUGHNESS_TEXTURE
uniform sampler2D metallic_roughness_texture;
#endif
#if NORMAL_TEXTURE
uniform sampler2D normal_texture;
in vec4 world_tangent;  // xyz along +u, w: the bitangent w cross(n, t) points up the image (common/albedo_vertex.glsl)
#endif
#if OCCLUSION_TEXTURE
uniform sampler2D occlusion_texture;
#endif
#if EMISSION_TEXTURE
uniform sampler2D emission_texture;
#endif

// What shade_principled reads at a fragment: the factors times the maps, and the shading normal.
struct SurfaceMaterial {
    vec3 base;
    float metallic;
    float roughness;
    vec3 normal;      // unit, the normal map's where there is one
    float occlusion;  // 1: none
    vec3 emission;
};

#if PRINCIPLED
// The fragment's material, ``n`` the unit surface normal facing the eye.
SurfaceMaterial surface_material(vec3 n) {
    SurfaceMaterial m;
    m.base = surface_albedo();
    m.metallic = material_metallic;
    m.roughness = material_roughness;
#if METALLIC_ROUGHNESS_TEXTURE
    vec3 mr = texture(metallic_roughness_texture, surface_uv).rgb;
    m.roughness *= mr.g;
    m.metallic *= mr.b;
#endif
    m.normal = n;
#if NORMAL_TEXTURE
    vec3 t = normalize(world_tangent.xyz - n * dot(n, world_tangent.xyz));
    // The bitangent of the face's own side: a back face's n is flipped, its frame's up the image is not.
    vec3 b = (world_tangent.w < 0.0 ? -1.0 : 1.0) * (gl_FrontFacing ? 1.0 : -1.0) * cross(n, t);
    vec3 tilted = texture(normal_texture, surface_uv).rgb * 2.0 - 1.0;
    tilted.xy *= material_normal_scale;
    m.normal = normalize(tilted.x * t + tilted.y * b + tilted.z * n);
#endif
    m.occlusion = 1.0;
#if OCCLUSION_TEXTURE
    m.occlusion = 1.0 + material_occlusion_strength * (texture(occlusion_texture, surface_uv).r - 1.0);
#endif
    m.emission = vec3(0.0);
#if EMISSIVE
    m.emission = material_emission;
#endif
#if EMISSION_TEXTURE
    m.emission *= texture(emission_texture, surface_uv).rgb;
#endif
    return m;
}
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
