// Which CELL x CELL blocks of the flux atlases hold any photon (r32f: their summed flux, 0 if none),
// so that impostor_caustic_filter.comp skips the empty ones (most of each tile). Host defines: CELL.
#version 430 core
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D flux_r;
uniform sampler2D flux_g;
uniform sampler2D flux_b;
layout(r32f, binding = 0) writeonly uniform image2D occupancy;

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, imageSize(occupancy)))) return;
    ivec2 size = textureSize(flux_r, 0);
    float sum = 0.0;
    for (int j = 0; j < CELL; ++j)
        for (int i = 0; i < CELL; ++i) {
            ivec2 q = min(cell * CELL + ivec2(i, j), size - 1);
            sum += texelFetch(flux_r, q, 0).r + texelFetch(flux_g, q, 0).r + texelFetch(flux_b, q, 0).r;
        }
    imageStore(occupancy, cell, vec4(sum));
}
