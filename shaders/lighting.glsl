// Snow shading shared by the sphere impostors and the point sprites: diffuse + specular from one
// light, and a soft sky term brighter on top so a packed pile reads as a solid mass.
vec3 shadeSnow(vec3 base_color, vec3 normal, vec3 light_direction) {
  vec3 l = normalize(light_direction);
  float diffuse = max(dot(normal, l), 0.0);
  vec3 halfway = normalize(l + vec3(0.0, 0.0, 1.0));
  float specular = pow(max(dot(normal, halfway), 0.0), 32.0);
  float ambient = 0.35 + 0.15 * normal.y;
  return base_color * (ambient + 0.6 * diffuse) + vec3(0.25 * specular);
}
