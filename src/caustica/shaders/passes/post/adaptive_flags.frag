// Adaptive anti-aliasing's flags (passes/post/adaptive.py): 1 where some channel of the pixel's compressed
// colour c / (1 + c) differs from an 8-neighbour's by more than THRESHOLD, else 0. The compression keeps a
// bright caustic from flagging every pixel near it; per channel, so a chromatic edge of equal luminance
// (dispersion) flags too. Host defines: THRESHOLD.
#version 430 core
uniform sampler2D source;
out vec4 flag;

vec3 compressed(ivec2 pixel) {
    ivec2 last = textureSize(source, 0) - 1;
    vec3 c = max(texelFetch(source, clamp(pixel, ivec2(0), last), 0).rgb, vec3(0.0));
    return c / (1.0 + c);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec3 centre = compressed(pixel);
    vec3 contrast = vec3(0.0);
    for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) contrast = max(contrast, abs(compressed(pixel + ivec2(i, j)) - centre));
    flag = vec4(max(contrast.r, max(contrast.g, contrast.b)) > THRESHOLD ? 1.0 : 0.0, 0.0, 0.0, 1.0);
}
