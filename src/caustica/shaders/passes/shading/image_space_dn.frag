// Front faces of the refractors for image-space refraction: interpolated d_N in world units
// (x) and eye distance (y; 0 means no refractor). Written by FrontDistanceAlongNormal.
#version 430 core
uniform vec3 origin;  // the eye
in vec3 world_position;
in float world_dn;
out vec2 front_dn;

void main() {
    front_dn = vec2(world_dn, length(world_position - origin));
}
