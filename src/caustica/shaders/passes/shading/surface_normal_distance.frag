// A refractor surface as the camera sees it: outward world normal (interpolated) and eye
// distance. Written by RefractorSurfaces for the front or back faces; w = 0 means empty.
#version 430 core
uniform vec3 origin;  // the eye
in vec3 world_position;
in vec3 world_normal;
out vec4 surface;

void main() {
    surface = vec4(normalize(world_normal), length(world_position - origin));
}
