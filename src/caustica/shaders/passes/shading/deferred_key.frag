// Deferred shading's depth key: each pixel a deferred object holds gets depth id / 256 (exact in
// float), so that drawing the object's resolve rectangle at that depth with an EQUAL test
// passes only its pixels (and a CPU rasterizer skips the rest before shading).
// Reads deferred_surface (the id is the length of xyz); writes depth only.
#version 430 core
uniform sampler2D deferred_surface;

void main() {
    float id = round(length(texelFetch(deferred_surface, ivec2(gl_FragCoord.xy), 0).xyz));
    if (id <= 0.0) discard;
    gl_FragDepth = id / 256.0;
}
