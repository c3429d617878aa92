// Adaptive anti-aliasing's depth preset (passes/post/adaptive.py): the supersampled frame's depth is 0, the
// nearest, at every sample of a pixel left unflagged, so that an early depth test rejects the shading
// drawn there; flagged pixels keep the cleared depth. Host defines: K (samples per pixel side).
#version 430 core
uniform sampler2D adaptive_flags;  // output size

void main() {
    if (texelFetch(adaptive_flags, ivec2(gl_FragCoord.xy) / K, 0).r > 0.5) discard;
    gl_FragDepth = 0.0;
}
