// Second resolve stage's depth key (ShadeSurfaces' ``staged``): within one object's rectangle,
// each pixel its first stage flagged (deferred_refine holds the object's key there) gets depth
// second_stage_key, between the first-stage keys, so that the second stage, drawn at that depth
// with an EQUAL test, shades those pixels alone. Reads deferred_refine; writes depth only.
#version 430 core
uniform sampler2D deferred_refine;  // the first stage's flags: the object's key, 0 elsewhere
uniform float deferred_key;         // this object's first-stage key (window depth, id / 256)
uniform float second_stage_key;     // its second-stage key (deferred.SECOND_STAGE_KEY above it)

void main() {
    if (texelFetch(deferred_refine, ivec2(gl_FragCoord.xy), 0).r != deferred_key) discard;
    gl_FragDepth = second_stage_key;
}
