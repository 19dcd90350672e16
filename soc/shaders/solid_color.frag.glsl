#version 450
// Box outlines and flat overlays in one colour.
uniform vec4 color;
out vec4 f_color;

void main() {
    f_color = color;
}
