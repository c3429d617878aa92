// Adaptive anti-aliasing's resolve (passes/post/adaptive.py): the box-filtered 4 samples at flagged pixels,
// the 1-spp pixel elsewhere.
#version 430 core
uniform sampler2D source;          // the 1-spp colour
uniform sampler2D averaged;        // the 4-spp colour, box-filtered to the output size
uniform sampler2D adaptive_flags;
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    color = texelFetch(adaptive_flags, pixel, 0).r > 0.5 ? texelFetch(averaged, pixel, 0) : texelFetch(source, pixel, 0);
}
