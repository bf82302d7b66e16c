#include "render/meshes.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/quaternion.hpp>

namespace snowsim {

namespace {

constexpr float kPi = 3.14159265f;

glm::vec3 vec(const std::array<double, 3>& a) {
  return {static_cast<float>(a[0]), static_cast<float>(a[1]), static_cast<float>(a[2])};
}

// A convex polygon as a fan of triangles sharing one normal.
void appendFan(const std::vector<glm::vec3>& polygon, glm::vec3 normal, glm::vec3 colour,
               std::vector<float>& out) {
  for (size_t i = 1; i + 1 < polygon.size(); ++i)
    for (const glm::vec3& p : {polygon[0], polygon[i], polygon[i + 1]})
      appendVertex(out, {p, normal, colour});
}

// The four corners of the rectangle centred on `centre` spanning u and v, counter-clockwise seen
// from u x v.
std::vector<glm::vec3> rectangle(glm::vec3 centre, glm::vec3 u, glm::vec3 v) {
  return {centre - u - v, centre + u - v, centre + u + v, centre - u + v};
}

void appendBox(glm::vec3 centre, glm::vec3 half, glm::vec3 colour, std::vector<float>& out) {
  for (int axis = 0; axis < 3; ++axis)
    for (float side : {-1.f, 1.f}) {
      glm::vec3 normal(0), u(0), v(0);
      normal[axis] = side;
      u[(axis + 1) % 3] = half[(axis + 1) % 3];
      v[(axis + 2) % 3] = side * half[(axis + 2) % 3];
      appendFan(rectangle(centre + normal * half[axis], u, v), normal, colour, out);
    }
}

void appendSphere(glm::vec3 centre, float radius, glm::vec3 colour, std::vector<float>& out) {
  constexpr int kSlices = 32, kStacks = 16;
  auto at = [](int slice, int stack) {
    const float theta = kPi * stack / kStacks, phi = 2 * kPi * slice / kSlices;
    return glm::vec3(std::sin(theta) * std::cos(phi), std::cos(theta),
                     -std::sin(theta) * std::sin(phi));
  };
  for (int stack = 0; stack < kStacks; ++stack)
    for (int slice = 0; slice < kSlices; ++slice) {
      const glm::vec3 a = at(slice, stack), b = at(slice, stack + 1), c = at(slice + 1, stack + 1),
                      d = at(slice + 1, stack);
      for (const glm::vec3& n : {a, b, c, a, c, d})
        appendVertex(out, {centre + radius * n, n, colour});
    }
}

// Every triangle with its own normal: flat shading shows the facets of a coarse mesh as they are.
void appendTriangles(const TriangleMesh& mesh, glm::vec3 colour, std::vector<float>& out) {
  for (const auto& [a, b, c] : mesh.triangles) {
    const glm::vec3 pa = vec(mesh.vertices[a]), pb = vec(mesh.vertices[b]),
                    pc = vec(mesh.vertices[c]);
    const glm::vec3 n = glm::normalize(glm::cross(pb - pa, pc - pa));
    for (const glm::vec3& p : {pa, pb, pc}) appendVertex(out, {p, n, colour});
  }
}

// A drum's wall seen from inside: the ring r <= |(x, y)| <= r + thickness at z = 0 in 2D, the
// cylinder |(x, y)| = r for |z| <= length / 2 in 3D (its normals towards the axis), about local
// z. Alternate segments are shaded darker so that its turning shows.
void appendDrum(float radius, float length, int dimension, glm::vec3 colour,
                std::vector<float>& out) {
  constexpr int kSegments = 48, kStripe = 4;
  const float outer = radius * 1.15f;
  for (int i = 0; i < kSegments; ++i) {
    const float a = 2 * kPi * i / kSegments, b = 2 * kPi * (i + 1) / kSegments;
    const glm::vec3 ua(std::cos(a), std::sin(a), 0), ub(std::cos(b), std::sin(b), 0);
    const glm::vec3 shade = (i / kStripe) % 2 ? 0.75f * colour : colour;
    if (dimension == 2) {
      appendFan({radius * ua, outer * ua, outer * ub, radius * ub}, {0, 0, 1}, shade, out);
      continue;
    }
    const glm::vec3 half(0, 0, 0.5f * length);
    const glm::vec3 p[4] = {radius * ua - half, radius * ub - half, radius * ub + half,
                            radius * ua + half};
    const glm::vec3 n[4] = {-ua, -ub, -ub, -ua};
    for (int k : {0, 1, 2, 0, 2, 3}) appendVertex(out, {p[k], n[k], shade});
  }
}

// Turns the vertices appended from float `first` on (built about the origin in the collider's
// local frame) by `rotation` and moves them to `centre`.
void placeVertices(std::vector<float>& out, size_t first, const glm::quat& rotation,
                   glm::vec3 centre) {
  const glm::mat3 turn = glm::mat3_cast(rotation);
  for (size_t i = first; i + 9 <= out.size(); i += 9) {
    const glm::vec3 p = turn * glm::vec3(out[i], out[i + 1], out[i + 2]) + centre;
    const glm::vec3 n = turn * glm::vec3(out[i + 3], out[i + 4], out[i + 5]);
    std::copy_n(&p.x, 3, &out[i]);
    std::copy_n(&n.x, 3, &out[i + 3]);
  }
}

// Two unit vectors spanning the plane of unit normal n.
std::pair<glm::vec3, glm::vec3> tangents(glm::vec3 n) {
  const glm::vec3 helper = std::abs(n.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 u = glm::normalize(glm::cross(helper, n));
  return {u, glm::cross(n, u)};
}

// The domain box's six walls as half spaces (point, outward normal) to clip against.
std::vector<std::pair<glm::vec3, glm::vec3>> domainWalls(glm::vec3 extent, int dimension) {
  std::vector<std::pair<glm::vec3, glm::vec3>> walls;
  for (int axis = 0; axis < dimension; ++axis) {
    glm::vec3 n(0);
    n[axis] = 1;
    walls.push_back({extent, n});
    walls.push_back({glm::vec3(0), -n});
  }
  return walls;
}

}  // namespace

void appendVertex(std::vector<float>& out, const MeshVertex& v) {
  out.insert(out.end(), {v.position.x, v.position.y, v.position.z, v.normal.x, v.normal.y,
                         v.normal.z, v.colour.r, v.colour.g, v.colour.b});
}

void appendGround(glm::vec3 extent, float margin, glm::vec3 colour, std::vector<float>& out) {
  const glm::vec3 centre(0.5f * extent.x, 0, 0.5f * extent.z);
  // Seen from above: u x v points up.
  appendFan(rectangle(centre, {0.5f * extent.x + margin, 0, 0}, {0, 0, -0.5f * extent.z - margin}),
            {0, 1, 0}, colour, out);
}

std::vector<glm::vec3> clipPolygon(const std::vector<glm::vec3>& polygon, glm::vec3 point,
                                   glm::vec3 normal) {
  std::vector<glm::vec3> kept;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const glm::vec3 a = polygon[i], b = polygon[(i + 1) % polygon.size()];
    const float da = glm::dot(a - point, normal), db = glm::dot(b - point, normal);
    if (da <= 0) kept.push_back(a);
    if ((da < 0) != (db < 0) && da != db) kept.push_back(a + (b - a) * (da / (da - db)));
  }
  return kept.size() >= 3 ? kept : std::vector<glm::vec3>{};
}

void appendCollider(const SnapshotCollider& c, int dimension, glm::vec3 extent, glm::vec3 colour,
                    std::vector<float>& out) {
  using Shape = SnapshotCollider::Shape;
  const glm::quat rotation(static_cast<float>(c.rotation[0]), static_cast<float>(c.rotation[1]),
                           static_cast<float>(c.rotation[2]), static_cast<float>(c.rotation[3]));
  glm::vec3 centre = vec(c.position);
  const glm::vec3 facing(0, 0, 1);
  if (dimension == 2) centre.z = 0;
  if (c.shape == Shape::Plane) {
    glm::vec3 n = rotation * vec(c.normal);
    if (dimension == 2) {
      n = glm::normalize(glm::vec3(n.x, n.y, 0));
      const std::vector<glm::vec3> domain =
          rectangle(0.5f * glm::vec3(extent.x, extent.y, 0), {0.5f * extent.x, 0, 0},
                    {0, 0.5f * extent.y, 0});
      return appendFan(clipPolygon(domain, centre, n), facing, colour, out);
    }
    // A square on the plane, larger than the domain, clipped to the domain's walls.
    n = glm::normalize(n);
    const glm::vec3 middle = 0.5f * extent;
    const glm::vec3 foot = middle - glm::dot(middle - centre, n) * n;
    const auto [u, v] = tangents(n);
    const float reach = glm::length(extent);
    std::vector<glm::vec3> polygon = rectangle(foot, reach * u, reach * v);
    for (const auto& [point, normal] : domainWalls(extent, 3))
      polygon = clipPolygon(polygon, point, normal);
    return appendFan(polygon, n, colour, out);
  }
  const size_t first = out.size();
  const float radius = static_cast<float>(c.radius);
  if (c.shape == Shape::Mesh) {
    appendTriangles(placed(*c.mesh, {{0, 0, 0}, {0, 0, 0}, c.scale}), colour, out);
  } else if (c.shape == Shape::Drum) {
    appendDrum(radius, static_cast<float>(c.size[2]), dimension, colour, out);
  } else if (dimension == 3 && c.shape == Shape::Box) {
    appendBox(glm::vec3(0), 0.5f * vec(c.size), colour, out);
  } else if (dimension == 3) {
    appendSphere(glm::vec3(0), radius, colour, out);
  } else if (c.shape == Shape::Box) {
    const glm::vec3 half = 0.5f * vec(c.size);
    appendFan(rectangle(glm::vec3(0), {half.x, 0, 0}, {0, half.y, 0}), facing, colour, out);
  } else {
    constexpr int kSegments = 48;
    std::vector<glm::vec3> disc;
    for (int i = 0; i < kSegments; ++i) {
      const float a = 2 * kPi * i / kSegments;
      disc.push_back({radius * std::cos(a), radius * std::sin(a), 0});
    }
    appendFan(disc, facing, colour, out);
  }
  placeVertices(out, first, rotation, centre);
}

}  // namespace snowsim
