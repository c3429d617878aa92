// Exact exits from inside glass of known shape (ours; passes/shading/convex_exits.py): the intersection of at most
// MAX_CONVEX_PLANES half-spaces (Haines, "Fast ray-convex polyhedron intersection", Graphics Gems II), with
// the mesh's shading normal on each plane as an affine field (Mesh.face_plane_normals), and of the insides or
// outsides of at most MAX_CONVEX_QUADRICS balls and round cylinders (an analytic sphere; a lens's spherical
// faces, convex or concave, and its rim).
// Host defines: MAX_CONVEX_PLANES, MAX_CONVEX_QUADRICS (convex_defines, passes/shading/convex_exits.py). Uniforms, per
// glass object (bind_convex_shape): convex_kind (int: 0 none, 1 a solid), convex_plane_count (int), convex_planes
// (vec4[]: world outward unit normal xyz, offset w; n . x <= w inside), convex_normals (vec4[3 per plane]: the
// rows of plane k's field at 3k..3k+2, shading normal ~ row . (x, 1)), convex_quadric_count (int),
// convex_quadrics (vec4[2 per quadric]: world centre xyz and signed radius w, the body inside where w > 0 and
// outside where w < 0; then a cylinder's unit axis xyz and 1, or 0 for a ball).
uniform int convex_kind;
uniform int convex_plane_count;
uniform vec4 convex_planes[MAX_CONVEX_PLANES];
uniform vec4 convex_normals[3 * MAX_CONVEX_PLANES];
uniform int convex_quadric_count;
uniform vec4 convex_quadrics[2 * MAX_CONVEX_QUADRICS];

// Distance along unit d from p (inside, or on the surface) to where the ray leaves the body, the
// outward unit shading normal there and the face's own (the same on a sphere): the first boundary crossed.
float convex_exit(vec3 p, vec3 d, out vec3 normal, out vec3 face_normal) {
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
    // A quadric the body lies in is left at the far root of |P (p + t d - c)| = r (P: across a cylinder's
    // axis, the identity on a ball); one it lies outside is met at the near root, where the ray closes in on it.
    int quadric = -1;
    vec3 across = vec3(0.0);  // P (x - c) at the exit: the outward normal's direction
    for (int i = 0; i < convex_quadric_count; ++i) {
        vec4 centre = convex_quadrics[2 * i], axis = convex_quadrics[2 * i + 1];
        vec3 oc = p - centre.xyz;
        vec3 dq = d - axis.w * dot(d, axis.xyz) * axis.xyz, oq = oc - axis.w * dot(oc, axis.xyz) * axis.xyz;
        float a = dot(dq, dq), b = dot(dq, oq);
        float disc = b * b - a * (dot(oq, oq) - centre.w * centre.w);
        float ti = a < 1e-12 ? 1e30 : centre.w > 0.0 ? (-b + sqrt(max(disc, 0.0))) / a
                 : b < 0.0 && disc > 0.0 ? (-b - sqrt(disc)) / a : 1e30;
        if (ti < t) {
            t = ti;
            quadric = i;
            across = sign(centre.w) * (oq + max(ti, 0.0) * dq);
        }
    }
    t = max(t, 0.0);
    if (quadric >= 0) {
        normal = face_normal = normalize(across);
        return t;
    }
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
