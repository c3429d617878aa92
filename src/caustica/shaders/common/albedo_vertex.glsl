// The texture coordinates of a textured diffuse receiver, passed from a mesh vertex stage to the
// surface shaders (common/surface_inputs.glsl), and a normal-mapped receiver's tangent frames. Host defines:
// ALBEDO_TEXTURE (0 default; 1: the mesh has uvs and its material a texture, ShadeSurfaces' textured
// variant), SURFACE_UV (1: uvs for other maps), NORMAL_TEXTURE (1: pass world_tangent). A vertex stage
// includes this and calls pass_surface_uv() and pass_surface_tangent(mat3(world_from_object)) in main.
#ifndef ALBEDO_TEXTURE
#define ALBEDO_TEXTURE 0
#endif
#ifndef SURFACE_UV
#define SURFACE_UV 0
#endif
#ifndef NORMAL_TEXTURE
#define NORMAL_TEXTURE 0
#endif
#if ALBEDO_TEXTURE || SURFACE_UV
in vec2 in_uv;            // glTF TEXCOORD_0: (0, 0) the image's top-left corner (scene/textures.py)
out vec2 surface_uv;
void pass_surface_uv() { surface_uv = in_uv; }
#else
void pass_surface_uv() {}
#endif
#if NORMAL_TEXTURE
in vec4 in_tangent;       // render/draw.py's TANGENT_ATTRIBUTE: scene/tangents.py's frames
out vec4 world_tangent;
// The tangent in world space (``linear``: the object-to-world matrix's linear part); w flips with a
// mirroring transform, which flips cross(normal, tangent) but not the bitangent.
void pass_surface_tangent(mat3 linear) {
    world_tangent = vec4(linear * in_tangent.xyz, determinant(linear) < 0.0 ? -in_tangent.w : in_tangent.w);
}
#else
void pass_surface_tangent(mat3 linear) {}
#endif
