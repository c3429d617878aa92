// Which CELL x CELL blocks of the flux atlases hold any photon (r32f: their summed flux, 0 if none),
// so that impostor_caustic_filter.comp skips the empty ones; and the three r32f atlases (atomic
// adds need one channel each) packed into one rgba32f, one fetch per filter tap instead of three.
// Host defines: CELL.
#version 430 core
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D flux_r;
uniform sampler2D flux_g;
uniform sampler2D flux_b;
layout(r32f, binding = 0) writeonly uniform image2D occupancy;
layout(rgba32f, binding = 1) writeonly uniform image2D flux_rgb;

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, imageSize(occupancy)))) return;
    ivec2 size = textureSize(flux_r, 0);
    float sum = 0.0;
    for (int j = 0; j < CELL; ++j)
        for (int i = 0; i < CELL; ++i) {
            ivec2 q = cell * CELL + ivec2(i, j);
            if (q.x >= size.x || q.y >= size.y) continue;
            vec3 p = vec3(texelFetch(flux_r, q, 0).r, texelFetch(flux_g, q, 0).r, texelFetch(flux_b, q, 0).r);
            imageStore(flux_rgb, q, vec4(p, 0.0));
            sum += p.r + p.g + p.b;
        }
    imageStore(occupancy, cell, vec4(sum));
}
