// The texture coordinates of a textured diffuse receiver, passed from a mesh vertex stage to the
// surface shaders (common/surface_inputs.glsl). Host defines: ALBEDO_TEXTURE (0 default; 1: the mesh
// has uvs and its material a texture, ShadeSurfaces' textured variant). A vertex stage includes this
// and calls pass_surface_uv() in main.
#ifndef ALBEDO_TEXTURE
#define ALBEDO_TEXTURE 0
#endif
#if ALBEDO_TEXTURE
in vec2 in_uv;            // glTF TEXCOORD_0: (0, 0) the image's top-left corner (scene/textures.py)
out vec2 surface_uv;
void pass_surface_uv() { surface_uv = in_uv; }
#else
void pass_surface_uv() {}
#endif
