// Caustic map resolve: irradiance = splatted flux / receiver area of the texel (the texel's solid angle
// times d^2 over the cosine at the receiver, or its perpendicular area over that cosine), alpha = the
// receiver's distance to the light (0 where the texel sees no receiver). Host defines: none.
#version 430 core
#include "passes/caustics/caustic_light_space.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D flux_r;
uniform sampler2D flux_g;
uniform sampler2D flux_b;
uniform sampler2D receiver_position;
uniform sampler2D receiver_normal;
layout(rgba32f, binding = 0) writeonly uniform image2D caustic_map;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(caustic_map);
    if (t.x >= size.x || t.y >= size.y) return;
    vec4 receiver = texelFetch(receiver_position, t, 0);
    if (receiver.a <= 0.0) {
        imageStore(caustic_map, t, vec4(0.0));
        return;
    }
    vec3 flux = vec3(texelFetch(flux_r, t, 0).r, texelFetch(flux_g, t, 0).r, texelFetch(flux_b, t, 0).r);
    vec3 ray = light_ray(receiver.xyz);
    float cos_r = max(abs(dot(normalize(texelFetch(receiver_normal, t, 0).xyz), ray)), 1e-3);
    float d = length(receiver.xyz - ls_light_position);
    float area = texel_measure(0, t.x / view_size[0], receiver.xyz) * (view_ortho[0] != 0 ? 1.0 : d * d) / cos_r;
    imageStore(caustic_map, t, vec4(flux / area, receiver.a));
}
