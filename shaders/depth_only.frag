// The key light's shadow map: only depth is written.
void main() {}
