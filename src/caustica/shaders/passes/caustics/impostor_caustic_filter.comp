// TVCG 3.2: the caustic texture filter c(u, v) = s sum_{i,j=-k..k} p(u + i, v + j) sqrt(1 + 2k^2 - (i^2 + j^2)),
// p the photons' flux per unit area of the rectangle (W/m^2, per tile's texel area); taps outside the
// tile count 0. Output rgba32f (cleared to 0 by the host): rgb = c, a = 1 where any photon fell within
// the kernel.
// One invocation per CELL x CELL block: blocks with no photon within the kernel's reach (the
// occupancy map says) write nothing; the loops over a block's texels run to a per-invocation bound,
// and a CPU rasterizer leaves a loop once no lane of the vector needs it.
// Host defines: FILTER_K (the kernel half-width k), CELL (the occupancy block size).
#version 430 core
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D flux_rgb;      // the photons' flux per texel, rgb (impostor_caustic_occupancy.comp)
uniform sampler2D occupancy;     // photons' summed flux per CELL x CELL block (impostor_caustic_occupancy.comp)
uniform int tile_size;
uniform float filter_s;
uniform float texel_area[16];    // per tile: area of one texel on its rectangle
layout(rgba32f, binding = 0) writeonly uniform image2D caustic;

void filter_texel(ivec2 t, ivec2 size) {
    int tile = t.x / tile_size;
    int x0 = tile * tile_size;
    vec3 sum = vec3(0.0);
    const float k2 = float(FILTER_K * FILTER_K);
    for (int j = -FILTER_K; j <= FILTER_K; ++j)
        for (int i = -FILTER_K; i <= FILTER_K; ++i) {
            ivec2 q = t + ivec2(i, j);
            if (q.x < x0 || q.x >= x0 + tile_size || q.y < 0 || q.y >= size.y) continue;
            sum += texelFetch(flux_rgb, q, 0).rgb * sqrt(1.0 + 2.0 * k2 - float(i * i + j * j));
        }
    vec3 c = filter_s * sum / texel_area[tile];
    imageStore(caustic, t, vec4(c, any(greaterThan(c, vec3(0.0))) ? 1.0 : 0.0));
}

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, textureSize(occupancy, 0)))) return;
    ivec2 size = imageSize(caustic);
    ivec2 lo = max(cell * CELL - FILTER_K, ivec2(0)) / CELL;
    ivec2 hi = min(cell * CELL + CELL - 1 + FILTER_K, size - 1) / CELL;
    float photons = 0.0;
    for (int cy = lo.y; cy <= hi.y; ++cy)
        for (int cx = lo.x; cx <= hi.x; ++cx) photons += texelFetch(occupancy, ivec2(cx, cy), 0).r;
    int span = photons > 0.0 ? CELL : 0;  // no texel of the block has a photon within reach
    for (int y = 0; y < span; ++y)
        for (int x = 0; x < span; ++x) {
            ivec2 t = cell * CELL + ivec2(x, y);
            if (t.x < size.x && t.y < size.y) filter_texel(t, size);
        }
}
