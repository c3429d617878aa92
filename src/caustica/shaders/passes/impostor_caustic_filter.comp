// TVCG 3.2: the caustic texture filter c(u, v) = s sum_{i,j=-k..k} p(u + i, v + j) sqrt(1 + 2k^2 - (i^2 + j^2)),
// p the photons' flux per unit area of the rectangle (W/m^2, per tile's texel area); taps outside the
// tile count 0. Output rgba32f: rgb = c, a = 1 where any photon fell within the kernel.
// Host defines: FILTER_K (the kernel half-width k), CELL (occupancy cell size). Texels whose kernel
// meets no occupied cell skip the taps: the loops run to a per-texel bound, and a CPU rasterizer
// leaves a loop once no lane of the vector needs it (it would run every tap of an unrolled loop).
#version 430 core
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D flux_r;
uniform sampler2D flux_g;
uniform sampler2D flux_b;
uniform sampler2D occupancy;     // photons' summed flux per CELL x CELL block (impostor_caustic_occupancy.comp)
uniform int tile_size;
uniform float filter_s;
uniform float texel_area[16];    // per tile: area of one texel on its rectangle
layout(rgba32f, binding = 0) writeonly uniform image2D caustic;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(caustic);
    if (t.x >= size.x || t.y >= size.y) return;
    int tile = t.x / tile_size;
    int x0 = tile * tile_size;
    ivec2 lo = max(t - FILTER_K, ivec2(x0, 0)) / CELL, hi = min(t + FILTER_K, ivec2(x0 + tile_size, size.y) - 1) / CELL;
    float photons = 0.0;
    for (int cy = lo.y; cy <= hi.y; ++cy)
        for (int cx = lo.x; cx <= hi.x; ++cx) photons += texelFetch(occupancy, ivec2(cx, cy), 0).r;
    int last = photons > 0.0 ? FILTER_K : -FILTER_K - 1;  // no taps where no photon is near
    vec3 sum = vec3(0.0);
    const float k2 = float(FILTER_K * FILTER_K);
    for (int j = -FILTER_K; j <= last; ++j)
        for (int i = -FILTER_K; i <= last; ++i) {
            ivec2 q = t + ivec2(i, j);
            if (q.x < x0 || q.x >= x0 + tile_size || q.y < 0 || q.y >= size.y) continue;
            vec3 p = vec3(texelFetch(flux_r, q, 0).r, texelFetch(flux_g, q, 0).r, texelFetch(flux_b, q, 0).r);
            sum += p * sqrt(1.0 + 2.0 * k2 - float(i * i + j * j));
        }
    vec3 c = filter_s * sum / texel_area[tile];
    imageStore(caustic, t, vec4(c, any(greaterThan(c, vec3(0.0))) ? 1.0 : 0.0));
}
