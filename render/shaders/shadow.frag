#version 450 core
// shadow.frag: depth only.
void main() {}
