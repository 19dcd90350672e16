#version 450
// Depth prepass and occlusion queries: only the depth test matters, nothing is written.
void main() {}
