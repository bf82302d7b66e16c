#include "sim/io/ply.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <istream>
#include <map>
#include <sstream>
#include <vector>

#include "sim/core/errors.h"
#include "sim/io/files.h"

namespace snowsim {

namespace {

static_assert(sizeof(float) == 4 && sizeof(int) == 4);

// A vertex property of a binary PLY: its name and scalar type.
struct Property {
  std::string name;
  char kind = 'f';  // 'f' floating point, 'i' signed integer, 'u' unsigned integer
  int bytes = 4;

  double read(const char* at) const {
    switch (kind * 16 + bytes) {
      case 'f' * 16 + 4:
        return load<float>(at);
      case 'f' * 16 + 8:
        return load<double>(at);
      case 'i' * 16 + 1:
        return load<std::int8_t>(at);
      case 'i' * 16 + 2:
        return load<std::int16_t>(at);
      case 'i' * 16 + 4:
        return load<std::int32_t>(at);
      case 'u' * 16 + 1:
        return load<std::uint8_t>(at);
      case 'u' * 16 + 2:
        return load<std::uint16_t>(at);
      default:
        return load<std::uint32_t>(at);
    }
  }

  template <class T>
  static double load(const char* at) {
    T value;
    std::memcpy(&value, at, sizeof value);
    return static_cast<double>(value);
  }
};

// The PLY scalar type names (both spellings of the standard), false for anything else.
bool parseType(const std::string& type, Property& p) {
  static const std::map<std::string, std::pair<char, int>> types{
      {"char", {'i', 1}},  {"int8", {'i', 1}},    {"uchar", {'u', 1}},  {"uint8", {'u', 1}},
      {"short", {'i', 2}}, {"int16", {'i', 2}},   {"ushort", {'u', 2}}, {"uint16", {'u', 2}},
      {"int", {'i', 4}},   {"int32", {'i', 4}},   {"uint", {'u', 4}},   {"uint32", {'u', 4}},
      {"float", {'f', 4}}, {"float32", {'f', 4}}, {"double", {'f', 8}}, {"float64", {'f', 8}}};
  const auto found = types.find(type);
  if (found == types.end()) return false;
  p.kind = found->second.first;
  p.bytes = found->second.second;
  return true;
}

// The float vertex properties a snapshot has, in the order written; int id follows them.
std::vector<std::string> floatProperties(const Snapshot& s) {
  std::vector<std::string> p{"x", "y", "z", "vx", "vy", "vz", "density"};
  if (!s.plastic_j.empty()) p.push_back("plastic_j");
  if (!s.mass.empty()) p.push_back("mass");
  if (!s.radius.empty()) p.push_back("pscale");
  return p;
}

}  // namespace

void writePly(const std::string& path, const Snapshot& s, UpAxis up) {
  std::ostringstream header;
  header.precision(17);
  header << "ply\nformat binary_little_endian 1.0\n"
         << "comment snowsim frame " << s.frame << "\n"
         << "comment snowsim time " << s.time << "\n"
         << "comment snowsim dimension " << s.grid.dimension << "\n"
         << "comment snowsim cells " << s.grid.cells[0] << " " << s.grid.cells[1] << " "
         << s.grid.cells[2] << "\n"
         << "comment snowsim cell_size " << s.grid.cell_size << "\n"
         << "comment snowsim particle_spacing " << s.grid.particle_spacing << "\n"
         << "comment snowsim critical_density " << s.grid.critical_density << "\n"
         << "comment snowsim up " << (up == UpAxis::Z ? "z" : "y") << "\n"
         << "element vertex " << s.size() << "\n";
  const auto properties = floatProperties(s);
  for (const auto& name : properties) header << "property float " << name << "\n";
  header << "property int id\n";
  if (!s.grid.node_density.empty())
    header << "element node " << s.grid.node_density.size() << "\nproperty float density\n";
  header << "end_header\n";

  std::string body = header.str();
  const size_t row = properties.size() + 1;
  std::vector<float> values(static_cast<size_t>(s.size()) * row);
  for (int i = 0; i < s.size(); ++i) {
    float* r = &values[i * row];
    const auto position = toUpAxis(s.position[i], up), velocity = toUpAxis(s.velocity[i], up);
    for (int a = 0; a < 3; ++a) r[a] = position[a], r[3 + a] = velocity[a];
    size_t k = 6;
    r[k++] = s.density.empty() ? 0.f : s.density[i];
    for (const auto* column : {&s.plastic_j, &s.mass, &s.radius})
      if (!column->empty()) r[k++] = (*column)[i];
    std::memcpy(&r[k], &i, sizeof i);  // the int id shares the row's 4-byte slots
  }
  body.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  body.append(reinterpret_cast<const char*>(s.grid.node_density.data()),
              s.grid.node_density.size() * sizeof(float));
  writeFileAtomically(path, body);
}

void writeSurfacePly(const std::string& path, const SnowSurface& m, const Snapshot& s, UpAxis up) {
  std::ostringstream header;
  header.precision(17);
  header << "ply\nformat binary_little_endian 1.0\n"
         << "comment snowsim surface of frame " << s.frame << "\n"
         << "comment snowsim time " << s.time << "\n"
         << "comment snowsim up " << (up == UpAxis::Z ? "z" : "y") << "\n"
         << "comment snowsim loose_grains " << m.loose.size() << " of " << s.size()
         << " particles (isolated " << m.isolated << ", smoothed_away " << m.smoothed_away << ")\n"
         << "element vertex " << m.vertices.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\n"
         << "property float nx\nproperty float ny\nproperty float nz\n"
         << "element face " << m.triangles.size() << "\n"
         << "property list uchar uint vertex_indices\nend_header\n";
  std::string body = header.str();
  std::vector<float> vertices(m.vertices.size() * 6);
  for (size_t v = 0; v < m.vertices.size(); ++v) {
    const auto position = toUpAxis(m.vertices[v], up), normal = toUpAxis(m.normals[v], up);
    for (int a = 0; a < 3; ++a)
      vertices[6 * v + a] = position[a], vertices[6 * v + 3 + a] = normal[a];
  }
  body.append(reinterpret_cast<const char*>(vertices.data()), vertices.size() * sizeof(float));
  constexpr size_t kFace = 1 + 3 * sizeof(std::uint32_t);
  const size_t faces_at = body.size();
  body.resize(faces_at + m.triangles.size() * kFace);
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    char* face = &body[faces_at + t * kFace];
    face[0] = 3;
    std::memcpy(face + 1, m.triangles[t].data(), 3 * sizeof(std::uint32_t));
  }
  writeFileAtomically(path, body);
}

Snapshot readPly(const std::string& path, PlyContent content) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the PLY file");
  return readPly(in, path, content);
}

Snapshot readPly(std::istream& in, const std::string& path, PlyContent content) {
  const bool frame = content == PlyContent::Frame;
  auto bad = [&](const std::string& why) {
    return InputError(path + (frame ? ": not a snowsim PLY file: " : ": ") + why);
  };
  Snapshot s;
  std::string line;
  if (!std::getline(in, line) || line != "ply") throw bad("missing the 'ply' magic line");
  std::vector<Property> properties;
  std::vector<std::string> node_properties;
  long vertices = -1, nodes = 0;
  UpAxis up = UpAxis::Y;
  bool has_grid = false;
  std::string element;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string format;
      words >> format;
      if (format != "binary_little_endian")
        throw bad("format " + format + " is not supported; allowed: binary_little_endian");
    } else if (word == "comment") {
      std::string tag, key;
      words >> tag >> key;
      if (tag != "snowsim") continue;
      if (key == "frame")
        words >> s.frame;
      else if (key == "time")
        words >> s.time;
      else if (key == "dimension")
        words >> s.grid.dimension, has_grid = true;
      else if (key == "cells")
        words >> s.grid.cells[0] >> s.grid.cells[1] >> s.grid.cells[2];
      else if (key == "cell_size")
        words >> s.grid.cell_size;
      else if (key == "particle_spacing")
        words >> s.grid.particle_spacing;
      else if (key == "critical_density")
        words >> s.grid.critical_density;
      else if (key == "up") {
        std::string axis;
        words >> axis;
        if (axis != "y" && axis != "z") throw bad("up axis " + axis + " is not y or z");
        up = axis == "z" ? UpAxis::Z : UpAxis::Y;
      }
    } else if (word == "element") {
      long count = -1;
      words >> element >> count;
      if (count < 0) throw bad("element " + element + " has no count");
      if (element == "vertex")
        vertices = count;
      else if (element == "node" && frame)
        nodes = count;
      else
        throw bad("unexpected element " + element + "; allowed: vertex" + (frame ? ", node" : ""));
    } else if (word == "property") {
      std::string type, name;
      words >> type >> name;
      if (element == "vertex") {
        Property p{name};
        if (!parseType(type, p)) throw bad("property " + name + " is not a scalar");
        properties.push_back(p);
      } else {
        if (type != "float") throw bad("property " + name + " is not a float");
        node_properties.push_back(name);
      }
    }
  }
  if (line != "end_header" || vertices < 0) throw bad("incomplete header");
  // What the renderer relies on: the grid the snowsim comments describe.
  const GridInfo& g = s.grid;
  if (frame || has_grid) {
    if (g.dimension != 2 && g.dimension != 3) throw bad("dimension is not 2 or 3");
    for (int a = 0; a < 3; ++a)
      if (g.cells[a] < 1 || g.cells[a] > 4096) throw bad("cells are not whole numbers 1 to 4096");
    if (!(g.cell_size > 0 && g.cell_size <= 1e3)) throw bad("cell_size is not in (0, 1000] m");
  }
  if (nodes != 0 && (g.dimension != 2 || nodes != long(g.cells[0] + 1) * (g.cells[1] + 1) ||
                     node_properties != std::vector<std::string>{"density"}))
    throw bad("the node element does not hold a density for each node of the 2D grid");

  // Each column's byte offset in a row, -1 when the file has none.
  std::map<std::string, long> offset;
  size_t row = 0;
  for (const Property& p : properties) offset.emplace(p.name, row), row += p.bytes;
  const auto column = [&](const std::string& name) {
    const auto found = offset.find(name);
    return found == offset.end() ? -1L : found->second;
  };
  std::vector<std::string> required{"x", "y", "z", "vx", "vy", "vz"};
  if (frame) required.push_back("density");
  for (const std::string& name : required)
    if (column(name) < 0) {
      std::string list;
      for (const std::string& r : required) list += " " + r;
      throw bad("no vertex property " + name + "; required:" + list);
    }
  // The counts must fit the bytes that follow before anything is allocated for them.
  const std::streampos body = in.tellg();
  in.seekg(0, std::ios::end);
  const auto bytes = static_cast<unsigned long>(in.tellg() - body);
  in.seekg(body);
  const unsigned long node_bytes = static_cast<unsigned long>(nodes) * sizeof(float);
  if (node_bytes > bytes || static_cast<unsigned long>(vertices) > (bytes - node_bytes) / row)
    throw bad("the file is shorter than its header says");
  std::vector<char> values(vertices * row);
  std::vector<float> node_values(nodes);
  in.read(values.data(), static_cast<std::streamsize>(values.size()));
  in.read(reinterpret_cast<char*>(node_values.data()), node_values.size() * sizeof(float));
  if (!in) throw bad("the file is shorter than its header says");

  const auto property = [&](const std::string& name) {
    for (const Property& p : properties)
      if (p.name == name) return p;
    return Property{};
  };
  // Reads column `name` of every vertex into `to`, left empty when the file has no such column.
  const auto readColumn = [&](const std::string& name, std::vector<float>& to) {
    const long at = column(name);
    if (at < 0) return;
    const Property p = property(name);
    to.resize(vertices);
    for (long i = 0; i < vertices; ++i) to[i] = static_cast<float>(p.read(&values[i * row + at]));
  };
  std::array<std::vector<float>, 6> axes;
  const char* axis_names[6] = {"x", "y", "z", "vx", "vy", "vz"};
  for (int a = 0; a < 6; ++a) readColumn(axis_names[a], axes[a]);
  s.position.resize(vertices);
  s.velocity.resize(vertices);
  for (long i = 0; i < vertices; ++i) {
    s.position[i] = fromUpAxis<float>({axes[0][i], axes[1][i], axes[2][i]}, up);
    s.velocity[i] = fromUpAxis<float>({axes[3][i], axes[4][i], axes[5][i]}, up);
  }
  readColumn("density", s.density);
  readColumn("plastic_j", s.plastic_j);
  readColumn("mass", s.mass);
  readColumn("pscale", s.radius);
  s.grid.node_density = std::move(node_values);
  return s;
}

std::vector<std::string> plyFramesIn(const std::string& directory) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(directory))
    if (entry.path().extension() == ".ply" &&
        entry.path().filename().string().rfind("surface_", 0) != 0)
      files.push_back(entry.path().string());
  if (files.empty()) throw InputError(directory + ": no .ply frames in this directory");
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace snowsim
