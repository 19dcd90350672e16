#version 450
// The reprojected depth (reproject_scatter.comp) as an R32F texture: a texel no sample reached
// is far (1), so it hides nothing.
layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer Target { uint target[]; };
layout(r32f, binding = 0) uniform writeonly image2D out_depth;

uniform ivec2 target_size;

void main() {
    ivec2 q = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(q, target_size))) return;
    uint bits = target[q.y * target_size.x + q.x];
    imageStore(out_depth, q, vec4(bits == 0u ? 1.0 : uintBitsToFloat(bits)));
}
