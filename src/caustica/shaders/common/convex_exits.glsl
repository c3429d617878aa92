// Exact exits from inside convex glass of known shape (ours; passes/convex_exits.py): an analytic
// sphere, or a convex mesh as the intersection of at most MAX_CONVEX_PLANES half-spaces
// (Haines, "Fast ray-convex polyhedron intersection", Graphics Gems II), with the mesh's shading
// normal on each plane as an affine field (Mesh.face_plane_normals).
// Host defines: MAX_CONVEX_PLANES (convex_defines, passes/convex_exits.py). Uniforms, per glass object
// (bind_convex_shape): convex_kind (int: 0 none, 1 planes, 2 sphere), convex_plane_count (int),
// convex_planes (vec4[]: world outward unit normal xyz, offset w; n . x <= w inside), convex_normals
// (vec4[3 per plane]: the rows of plane k's field at 3k..3k+2, shading normal ~ row . (x, 1)),
// convex_sphere (vec4: world centre xyz, radius w).
uniform int convex_kind;
uniform int convex_plane_count;
uniform vec4 convex_planes[MAX_CONVEX_PLANES];
uniform vec4 convex_normals[3 * MAX_CONVEX_PLANES];
uniform vec4 convex_sphere;

// Distance along unit d from p (inside, or on the surface) to where the ray leaves the body, the
// outward unit shading normal there and the face's own (the same on a sphere).
float convex_exit(vec3 p, vec3 d, out vec3 normal, out vec3 face_normal) {
    if (convex_kind == 2) {
        // The far root of |p + t d - c| = r.
        vec3 oc = p - convex_sphere.xyz;
        float b = dot(d, oc);
        float t = max(-b + sqrt(max(b * b - dot(oc, oc) + convex_sphere.w * convex_sphere.w, 0.0)), 0.0);
        normal = normalize(oc + t * d);
        face_normal = normal;
        return t;
    }
    // The nearest plane the ray moves towards.
    float t = 1e30;
    int nearest = -1;
    for (int i = 0; i < convex_plane_count; ++i) {
        vec4 plane = convex_planes[i];
        float rate = dot(d, plane.xyz);
        float ti = (plane.w - dot(p, plane.xyz)) / rate;
        if (rate > 1e-6 && ti < t) {
            t = ti;
            nearest = i;
        }
    }
    t = max(t, 0.0);
    if (nearest < 0) {
        normal = face_normal = d;
        return t;
    }
    face_normal = convex_planes[nearest].xyz;
    vec4 x = vec4(p + t * d, 1.0);
    vec3 shading = vec3(dot(convex_normals[3 * nearest], x), dot(convex_normals[3 * nearest + 1], x),
                        dot(convex_normals[3 * nearest + 2], x));
    normal = dot(shading, face_normal) > 0.0 ? normalize(shading) : face_normal;
    return t;
}
