// Exact exits from inside convex glass of known shape (ours; passes/convex_exits.py): an analytic
// sphere, or a convex polyhedron as the intersection of at most MAX_CONVEX_PLANES half-spaces
// (Haines, "Fast ray-convex polyhedron intersection", Graphics Gems II).
// Host defines: MAX_CONVEX_PLANES (16, passes/convex_exits.py). Uniforms, per glass object
// (bind_convex_shape): convex_kind (int: 0 none, 1 planes, 2 sphere), convex_plane_count (int),
// convex_planes (vec4[]: world outward unit normal xyz, offset w; n . x <= w inside), convex_sphere
// (vec4: world centre xyz, radius w).
#ifndef MAX_CONVEX_PLANES
#define MAX_CONVEX_PLANES 16
#endif
uniform int convex_kind;
uniform int convex_plane_count;
uniform vec4 convex_planes[MAX_CONVEX_PLANES];
uniform vec4 convex_sphere;

// Distance along unit d from p (inside, or on the surface) to where the ray leaves the body, and the
// outward unit normal there.
float convex_exit(vec3 p, vec3 d, out vec3 normal) {
    if (convex_kind == 2) {
        // The far root of |p + t d - c| = r.
        vec3 oc = p - convex_sphere.xyz;
        float b = dot(d, oc);
        float t = max(-b + sqrt(max(b * b - dot(oc, oc) + convex_sphere.w * convex_sphere.w, 0.0)), 0.0);
        normal = normalize(oc + t * d);
        return t;
    }
    // The nearest plane the ray moves towards.
    float t = 1e30;
    normal = d;
    for (int i = 0; i < convex_plane_count; ++i) {
        vec4 plane = convex_planes[i];
        float rate = dot(d, plane.xyz);
        float ti = (plane.w - dot(p, plane.xyz)) / rate;
        if (rate > 1e-6 && ti < t) {
            t = ti;
            normal = plane.xyz;
        }
    }
    return max(t, 0.0);
}
