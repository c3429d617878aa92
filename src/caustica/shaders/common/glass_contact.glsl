// Glass standing on a receiver (ours, passes/shading/glass_contact.py): whether the exit point p through the face of
// outward normal n lies on the receiver plane (unit normal plane.xyz, plane.xyz . x = plane.w on it; a zero plane:
// none) within `tolerance`, the face turned into it. Then `landing` is p put on that plane: there all the light that
// reaches the face passes into the receiver (no air between them: no refraction, Fresnel or total reflection).
bool on_contact_plane(vec4 plane, float tolerance, vec3 p, vec3 n, out vec3 landing) {
    float off_plane = dot(plane.xyz, p) - plane.w;
    landing = p - off_plane * plane.xyz;
    return dot(plane.xyz, plane.xyz) > 0.0 && abs(off_plane) < tolerance && dot(n, plane.xyz) < -0.5;
}
