// Fixed-point flux sums (fixed_point_flux.glsl) back into three r32f images (R, G, B), one invocation
// per texel. Host defines: none.
#version 430 core
#include "passes/caustics/fixed_point_flux.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = 0) writeonly uniform image2D flux_r;
layout(r32f, binding = 1) writeonly uniform image2D flux_g;
layout(r32f, binding = 2) writeonly uniform image2D flux_b;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (t.x >= flux_size.x || t.y >= flux_size.y) return;
    int e = flux_step_exponent();
    imageStore(flux_r, t, vec4(flux_sum(0, t, e)));
    imageStore(flux_g, t, vec4(flux_sum(1, t, e)));
    imageStore(flux_b, t, vec4(flux_sum(2, t, e)));
}
