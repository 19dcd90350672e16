#version 450
// A point splat carries its source pixel's colour and object id unchanged.
flat in vec4 v_color;
flat in uint v_object;

layout(location = 0) out vec4 f_color;
layout(location = 1) out uint f_object;

void main() {
    f_color = v_color;
    f_object = v_object;
}
