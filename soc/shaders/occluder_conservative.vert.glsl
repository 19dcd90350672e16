#version 450
// Inner-conservative occluder raster: the eroded polygons soc/culling/depth_prepass.py set up, already
// in NDC with their depth bound as z; drawn depth-only (depth_only.frag).
in vec3 in_position;

void main() {
    gl_Position = vec4(in_position, 1.0);
}
