#include "sim/geometry/triangle_mesh.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string_view>

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include "sim/core/errors.h"

namespace snowsim {

namespace {

using Point = std::array<double, 3>;

Point sub(const Point& a, const Point& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}

Point cross(const Point& a, const Point& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double norm(const Point& a) {
  return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw InputError(path + ": " + problem);
}

// A binary STL cut short (a copy or a download that stopped), which assimp reports only as a
// storage format it cannot tell: an 80-byte header, a triangle count N (u32) and 50 bytes a
// triangle. A file that starts as text with "solid" is left to assimp as ASCII.
void refuseCutShortBinaryStl(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (extension != ".stl") return;
  std::ifstream in(path, std::ios::binary);
  if (!in) return;  // assimp names what keeps it from reading the file
  const auto size = static_cast<std::uintmax_t>(std::filesystem::file_size(path));
  std::string head(std::min<std::uintmax_t>(size, 512), '\0');
  in.read(head.data(), std::streamsize(head.size()));
  // Text, after a UTF-8 byte-order mark if there is one, that starts with "solid".
  const std::string_view opening =
      std::string_view(head).substr(head.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0);
  const bool text = std::all_of(opening.begin(), opening.end(), [](char c) {
    return std::isprint(static_cast<unsigned char>(c)) ||
           std::isspace(static_cast<unsigned char>(c));
  });
  const size_t start = opening.find_first_not_of(" \t\r\n");
  if (text && start != std::string_view::npos && opening.substr(start, 5) == "solid") return;
  if (size < 84)
    fail(path,
         "a binary STL starts with an 84-byte header (80 bytes and the triangle count); the "
         "file has " +
             std::to_string(size) + " bytes");
  std::uint32_t triangles = 0;
  for (int b = 0; b < 4; ++b)
    triangles |= std::uint32_t(static_cast<unsigned char>(head[80 + b])) << (8 * b);
  const std::uintmax_t needed = 84 + 50 * std::uintmax_t(triangles);
  if (size >= needed) return;
  // A count far beyond the file is no STL's header.
  if (needed > 10 * size)
    fail(path,
         "neither an ASCII STL (text starting with \"solid\") nor a binary STL: its bytes "
         "80-83 give " +
             std::to_string(triangles) + " triangles, " + std::to_string(needed) +
             " bytes, and the file has " + std::to_string(size));
  fail(path, "a binary STL of " + std::to_string(triangles) +
                 " triangles (its header's count) takes 84 + 50 x " + std::to_string(triangles) +
                 " = " + std::to_string(needed) + " bytes and the file has " +
                 std::to_string(size) +
                 ": it ends early (was it cut short in a copy or a download?)");
}

// Every triangle of every mesh of the file, vertices merged by exact position.
TriangleMesh readTriangles(const std::string& path) {
  Assimp::Importer importer;
  // Triangulate: OBJ and PLY faces may be polygons. No vertex joining here: assimp keeps vertices
  // with different normals apart (an STL's every corner), so they are merged by position below.
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_SortByPType);
  if (!scene || !scene->mRootNode)
    fail(path,
         std::string("cannot read it as a mesh (OBJ, STL or PLY): ") + importer.GetErrorString());
  TriangleMesh mesh;
  std::map<Point, int> index_of;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* part = scene->mMeshes[m];
    std::vector<int> merged(part->mNumVertices);
    for (unsigned v = 0; v < part->mNumVertices; ++v) {
      const aiVector3D& p = part->mVertices[v];
      const Point point{p.x, p.y, p.z};
      // Beyond 1e9 (m, before any scale) no grid reaches: a corrupt number, not a shape.
      if (!(std::abs(point[0]) <= 1e9 && std::abs(point[1]) <= 1e9 && std::abs(point[2]) <= 1e9)) {
        std::ostringstream s;
        s << "a vertex is at (" << point[0] << ", " << point[1] << ", " << point[2]
          << "): each coordinate must be a finite number between -1e9 and 1e9";
        fail(path, s.str());
      }
      const auto [it, added] = index_of.emplace(point, static_cast<int>(mesh.vertices.size()));
      if (added) mesh.vertices.push_back(point);
      merged[v] = it->second;
    }
    for (unsigned f = 0; f < part->mNumFaces; ++f) {
      const aiFace& face = part->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines bound no volume
      mesh.triangles.push_back(
          {merged[face.mIndices[0]], merged[face.mIndices[1]], merged[face.mIndices[2]]});
    }
  }
  return mesh;
}

void checkTriangles(const TriangleMesh& mesh, const std::string& path) {
  if (mesh.triangles.empty())
    fail(path, "the mesh has no triangles (an empty mesh, or not an OBJ, STL or PLY file)");
  const auto [lo, hi] = mesh.bounds();
  const double diagonal = norm(sub(hi, lo));
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& [a, b, c] = mesh.triangles[t];
    const Point& pa = mesh.vertices[a];
    const double area = 0.5 * norm(cross(sub(mesh.vertices[b], pa), sub(mesh.vertices[c], pa)));
    // Relative to the mesh's size: a sliver far below float precision has no normal.
    if (!(area > 1e-12 * diagonal * diagonal)) {
      std::ostringstream s;
      s << "triangle " << t << " is degenerate (its corners are on one line or coincide; area "
        << area << "); the mesh needs triangles that span an area";
      fail(path, s.str());
    }
  }
}

// A closed surface uses every edge in exactly two triangles.
void checkWatertight(const TriangleMesh& mesh, const std::string& path) {
  std::map<std::pair<int, int>, int> uses;
  for (const auto& tri : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const int a = tri[e], b = tri[(e + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  long open = 0, over = 0;
  std::pair<int, int> example{-1, -1};
  for (const auto& [edge, count] : uses) {
    if (count == 2) continue;
    (count == 1 ? open : over) += 1;
    if (example.first < 0) example = edge;
  }
  if (open == 0 && over == 0) return;
  std::ostringstream s;
  s << "the mesh is not watertight: " << open << " edge(s) belong to one triangle only (a hole)";
  if (over) s << " and " << over << " to three or more (non-manifold)";
  const Point& p = mesh.vertices[example.first];
  s << ", e.g. the edge at (" << p[0] << ", " << p[1] << ", " << p[2]
    << "); a body or collider needs a closed surface";
  fail(path, s.str());
}

}  // namespace

std::array<std::array<double, 3>, 2> TriangleMesh::bounds() const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::array<Point, 2> box{Point{inf, inf, inf}, Point{-inf, -inf, -inf}};
  for (const Point& p : vertices)
    for (int a = 0; a < 3; ++a) {
      box[0][a] = std::min(box[0][a], p[a]);
      box[1][a] = std::max(box[1][a], p[a]);
    }
  return box;
}

double TriangleMesh::signedVolume() const {
  double six_volume = 0;
  for (const auto& [a, b, c] : triangles)
    six_volume +=
        vertices[a][0] * (vertices[b][1] * vertices[c][2] - vertices[b][2] * vertices[c][1]) +
        vertices[a][1] * (vertices[b][2] * vertices[c][0] - vertices[b][0] * vertices[c][2]) +
        vertices[a][2] * (vertices[b][0] * vertices[c][1] - vertices[b][1] * vertices[c][0]);
  return six_volume / 6;
}

TriangleMesh loadTriangleMesh(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    fail(path, "is a directory; give a mesh file (a closed triangle mesh: OBJ, STL or PLY)");
  if (!std::filesystem::is_regular_file(path, error))
    fail(path, "no such mesh file (a closed triangle mesh: OBJ, STL or PLY)");
  if (std::filesystem::file_size(path, error) == 0) fail(path, "the file is empty");
  refuseCutShortBinaryStl(path);
  TriangleMesh mesh = readTriangles(path);
  checkTriangles(mesh, path);
  checkWatertight(mesh, path);
  return mesh;
}

TriangleMesh placed(const TriangleMesh& mesh, const MeshPlacement& placement) {
  constexpr double kRadians = 3.14159265358979323846 / 180;
  const double cx = std::cos(placement.rotation_degrees[0] * kRadians),
               sx = std::sin(placement.rotation_degrees[0] * kRadians),
               cy = std::cos(placement.rotation_degrees[1] * kRadians),
               sy = std::sin(placement.rotation_degrees[1] * kRadians),
               cz = std::cos(placement.rotation_degrees[2] * kRadians),
               sz = std::sin(placement.rotation_degrees[2] * kRadians);
  // R = Rz Ry Rx, row by row.
  const double r[3][3] = {{cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx},
                          {sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx},
                          {-sy, cy * sx, cy * cx}};
  TriangleMesh out = mesh;
  for (Point& p : out.vertices) {
    const Point s{p[0] * placement.scale, p[1] * placement.scale, p[2] * placement.scale};
    for (int i = 0; i < 3; ++i)
      p[i] = placement.position[i] + r[i][0] * s[0] + r[i][1] * s[1] + r[i][2] * s[2];
  }
  return out;
}

}  // namespace snowsim
