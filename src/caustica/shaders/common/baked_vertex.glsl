// The environment's light baked per vertex (passes/shading/environment.py scene_bake, common/lighting.glsl's light
// maps), passed from a mesh vertex stage to the surface shaders. Host define: ENVIRONMENT_BAKE_VERTICES (0
// default; 1: ShadeSurfaces' diffuse variants where the bake holds vertices). A vertex stage includes this and
// calls pass_baked_irradiance() in main: the object's vertex gl_VertexID (the index of an indexed draw) at
// env_bake_vertex_first + gl_VertexID of the atlas's vertex rows, from row env_bake_layout.z.
#ifndef ENVIRONMENT_BAKE_VERTICES
#define ENVIRONMENT_BAKE_VERTICES 0
#endif
#if ENVIRONMENT_BAKE_VERTICES
uniform sampler2D env_bake;
uniform ivec4 env_bake_layout;
uniform int env_bake_vertex_first;  // -1: the object is not baked per vertex
out vec3 baked_vertex_irradiance;
void pass_baked_irradiance() {
    baked_vertex_irradiance = vec3(0.0);
    if (env_bake_vertex_first < 0) return;
    int i = env_bake_vertex_first + gl_VertexID, width = textureSize(env_bake, 0).x;
    baked_vertex_irradiance = texelFetch(env_bake, ivec2(i % width, env_bake_layout.z + i / width), 0).rgb;
}
#else
void pass_baked_irradiance() {}
#endif
