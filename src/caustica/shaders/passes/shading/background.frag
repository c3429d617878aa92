// The environment seen directly: the world direction through each pixel.
#version 430 core
#include "common/environment.glsl"
uniform sampler2D environment;
uniform mat4 world_from_clip;
uniform float intensity_scale;
in vec2 ndc;
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 exit_direction;  // nothing refracts here

void main() {
    vec4 near_point = world_from_clip * vec4(ndc, -1.0, 1.0);
    vec4 far_point = world_from_clip * vec4(ndc, 1.0, 1.0);
    vec3 d = far_point.xyz / far_point.w - near_point.xyz / near_point.w;
    color = vec4(intensity_scale * environment_radiance(environment, d), 1.0);
    exit_direction = vec4(0.0);
}
