#version 450
// Inner-conservative occluder raster, stage 1: occluder vertices to clip space. The geometry
// shader sees each primitive whole (lines_adjacency: a quad, or a triangle with its last
// vertex repeated) and does the rest (soc/depth_prepass.py).
in vec3 in_position;

uniform mat4 view_proj;

void main() {
    gl_Position = view_proj * vec4(in_position, 1.0);
}
