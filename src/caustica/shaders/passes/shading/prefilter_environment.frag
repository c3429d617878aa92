// The prefiltered environment's atlas (passes/shading/prefiltered.py; read by common/environment.glsl's
// prefiltered_radiance): band k of ``levels`` bands, each ``width`` x width / 2 texels of the equirect mapping,
// holds the environment convolved with GGX's lobe at roughness k / (levels - 1) about each texel's direction r,
// taking n = v = r (the split-sum's first factor, Karis 2013): the mean of L(l) weighted by cos(n, l) over GGX
// half vectors. Each of ``samples`` Hammersley half vectors reads the mipmapped ``source`` at the level whose
// texels span the sample's share of solid angle (filtered importance sampling, Krivanek and Colbert 2008), so
// a few dozen samples give a smooth image; band 0 (a mirror) reads the level the atlas's own texels span.
#version 430 core
#include "common/environment.glsl"
#include "common/microfacet.glsl"

uniform sampler2D source;  // the environment image, mipmapped
uniform int levels;
uniform int width;
uniform int samples;
out vec4 prefiltered;

vec3 source_radiance(vec3 d, float lod) {
    vec2 uv = equirect_uv(d);
    return textureLod(source, vec2(uv.x, equirect_row_coordinate(uv.y, float(textureSize(source, 0).y))), lod).rgb;
}

void main() {
    int rows = width / 2;
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    int level = pixel.y / rows;
    vec2 uv = vec2((float(pixel.x) + 0.5) / float(width), float(pixel.y - level * rows) / float(rows - 1));
    vec3 r = equirect_direction(uv);
    vec2 size = vec2(textureSize(source, 0));
    if (level == 0) {
        prefiltered = vec4(source_radiance(r, max(log2(size.x / float(width)), 0.0)), 1.0);
        return;
    }
    float alpha = ggx_alpha(float(level) / float(levels - 1));
    vec3 helper = abs(r.y) < 0.999 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 tangent = normalize(cross(helper, r)), bitangent = cross(r, tangent);
    float texel_angle = (2.0 * PI / size.x) * (PI / size.y);  // a source texel's solid angle over sin(theta)
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int i = 0; i < samples; ++i) {
        float xi1 = (float(i) + 0.5) / float(samples);
        float xi2 = float(bitfieldReverse(uint(i))) * 2.3283064365386963e-10;
        float cos_h = sqrt((1.0 - xi1) / (1.0 + (alpha * alpha - 1.0) * xi1));
        float sin_h = sqrt(max(1.0 - cos_h * cos_h, 0.0));
        float phi = 2.0 * PI * xi2;
        vec3 h = sin_h * cos(phi) * tangent + sin_h * sin(phi) * bitangent + cos_h * r;
        vec3 l = 2.0 * dot(r, h) * h - r;
        float n_dot_l = dot(r, l);
        if (n_dot_l <= 0.0) continue;
        // pdf(l) = D(h) cos_h / (4 v.h) = D / 4 with v = n; the sample's solid angle is 1 / (samples pdf(l)).
        float sample_angle = 4.0 / (float(samples) * ggx_distribution(cos_h, alpha));
        float pixel_angle = texel_angle * max(sqrt(max(1.0 - l.y * l.y, 0.0)), 1e-3);
        float lod = max(0.5 * log2(sample_angle / pixel_angle), 0.0);
        sum += n_dot_l * source_radiance(l, lod);
        weight += n_dot_l;
    }
    prefiltered = vec4(sum / max(weight, 1e-12), 1.0);
}
