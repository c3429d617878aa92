// A glossy receiver's local reflection probe (passes/shading/reflection_probes.py): its prefiltered atlas is
// bound in place of the environment's (common/environment.glsl prefiltered_radiance), seen from
// ``probe_centre``. With PROBE_PARALLAX the reflected ray from the shaded point is met with the proxy box
// [probe_box_min, probe_box_max] around the scene and the probe looked up towards that point (Lagarde and
// Zanuttini, "Local image-based lighting with parallax-corrected cubemaps", SIGGRAPH 2012 talk); without it,
// in the reflected direction itself, as a distant environment.
uniform vec3 probe_centre;
uniform vec3 probe_box_min;
uniform vec3 probe_box_max;

vec3 probe_direction(vec3 position, vec3 r) {
#if PROBE_PARALLAX
    vec3 safe = vec3(abs(r.x) > 1e-6 ? r.x : 1e-6, abs(r.y) > 1e-6 ? r.y : 1e-6, abs(r.z) > 1e-6 ? r.z : 1e-6);
    vec3 exits = max((probe_box_max - position) / safe, (probe_box_min - position) / safe);
    float t = min(min(exits.x, exits.y), exits.z);
    if (t > 0.0) return position + t * r - probe_centre;
#endif
    return r;
}
