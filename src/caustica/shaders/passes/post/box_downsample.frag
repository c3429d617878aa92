// The box pixel filter of supersampling: each output pixel averages its K x K block of the source
// (the reference renderers' box filter).
// Host defines: K (samples per pixel side).
#version 430 core
uniform sampler2D source;
in vec2 ndc;
out vec4 averaged;

void main() {
    ivec2 base = ivec2(gl_FragCoord.xy) * K;
    vec4 sum = vec4(0.0);
    for (int j = 0; j < K; ++j)
        for (int i = 0; i < K; ++i) sum += texelFetch(source, base + ivec2(i, j), 0);
    averaged = sum / float(K * K);
}
