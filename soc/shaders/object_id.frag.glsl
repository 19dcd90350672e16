#version 450
// Exact visibility oracle: every covered pixel records the id of the nearest object.
flat in uint v_object;
out uint f_object;

void main() {
    f_object = v_object;
}
