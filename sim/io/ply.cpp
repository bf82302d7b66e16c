#include "sim/io/ply.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <istream>
#include <sstream>
#include <vector>

#include "sim/core/errors.h"
#include "sim/io/files.h"

namespace snowsim {

namespace {

static_assert(sizeof(float) == 4);

std::vector<std::string> vertexProperties(const Snapshot& s) {
  std::vector<std::string> p{"x", "y", "z", "vx", "vy", "vz", "density"};
  if (!s.plastic_j.empty()) p.push_back("plastic_j");
  return p;
}

}  // namespace

void writePly(const std::string& path, const Snapshot& s) {
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
         << "element vertex " << s.size() << "\n";
  const auto properties = vertexProperties(s);
  for (const auto& name : properties) header << "property float " << name << "\n";
  if (!s.grid.node_density.empty())
    header << "element node " << s.grid.node_density.size() << "\nproperty float density\n";
  header << "end_header\n";

  std::string body = header.str();
  const size_t row = properties.size();
  std::vector<float> values(static_cast<size_t>(s.size()) * row);
  for (int i = 0; i < s.size(); ++i) {
    float* r = &values[i * row];
    for (int a = 0; a < 3; ++a) r[a] = s.position[i][a], r[3 + a] = s.velocity[i][a];
    r[6] = s.density.empty() ? 0.f : s.density[i];
    if (row > 7) r[7] = s.plastic_j[i];
  }
  body.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  body.append(reinterpret_cast<const char*>(s.grid.node_density.data()),
              s.grid.node_density.size() * sizeof(float));
  writeFileAtomically(path, body);
}

Snapshot readPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the PLY file");
  return readPly(in, path);
}

Snapshot readPly(std::istream& in, const std::string& path) {
  auto bad = [&](const std::string& why) {
    return InputError(path + ": not a snowsim PLY file: " + why);
  };
  Snapshot s;
  std::string line;
  if (!std::getline(in, line) || line != "ply") throw bad("missing the 'ply' magic line");
  std::vector<std::string> properties, node_properties;
  long vertices = -1, nodes = 0;
  std::string element;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string format;
      words >> format;
      if (format != "binary_little_endian") throw bad("format " + format + " is not supported");
    } else if (word == "comment") {
      std::string tag, key;
      words >> tag >> key;
      if (tag != "snowsim") continue;
      if (key == "frame")
        words >> s.frame;
      else if (key == "time")
        words >> s.time;
      else if (key == "dimension")
        words >> s.grid.dimension;
      else if (key == "cells")
        words >> s.grid.cells[0] >> s.grid.cells[1] >> s.grid.cells[2];
      else if (key == "cell_size")
        words >> s.grid.cell_size;
      else if (key == "particle_spacing")
        words >> s.grid.particle_spacing;
      else if (key == "critical_density")
        words >> s.grid.critical_density;
    } else if (word == "element") {
      long count = -1;
      words >> element >> count;
      if (count < 0) throw bad("element " + element + " has no count");
      if (element == "vertex")
        vertices = count;
      else if (element == "node")
        nodes = count;
      else
        throw bad("unexpected element " + element);
    } else if (word == "property") {
      std::string type, name;
      words >> type >> name;
      if (type != "float") throw bad("property " + name + " is not a float");
      (element == "vertex" ? properties : node_properties).push_back(name);
    }
  }
  if (line != "end_header" || vertices < 0) throw bad("incomplete header");
  // What the renderer relies on: the grid the snowsim comments describe.
  const GridInfo& g = s.grid;
  if (g.dimension != 2 && g.dimension != 3) throw bad("dimension is not 2 or 3");
  for (int a = 0; a < 3; ++a)
    if (g.cells[a] < 1 || g.cells[a] > 4096) throw bad("cells are not whole numbers 1 to 4096");
  if (!(g.cell_size > 0 && g.cell_size <= 1e3)) throw bad("cell_size is not in (0, 1000] m");
  if (nodes != 0 && (g.dimension != 2 || nodes != long(g.cells[0] + 1) * (g.cells[1] + 1) ||
                     node_properties != std::vector<std::string>{"density"}))
    throw bad("the node element does not hold a density for each node of the 2D grid");
  const std::vector<std::string> required{"x", "y", "z", "vx", "vy", "vz", "density"};
  if (properties.size() < 7 || !std::equal(required.begin(), required.end(), properties.begin()))
    throw bad("vertex properties are not x y z vx vy vz density");
  const bool has_j = properties.size() > 7 && properties[7] == "plastic_j";
  const size_t row = properties.size();
  // The counts must fit the bytes that follow before anything is allocated for them.
  const std::streampos body = in.tellg();
  in.seekg(0, std::ios::end);
  const auto bytes = static_cast<unsigned long>(in.tellg() - body);
  in.seekg(body);
  const unsigned long floats = bytes / sizeof(float);
  if (static_cast<unsigned long>(nodes) > floats ||
      static_cast<unsigned long>(vertices) > (floats - nodes) / row)
    throw bad("the file is shorter than its header says");
  std::vector<float> values(vertices * row);
  std::vector<float> node_values(nodes);
  in.read(reinterpret_cast<char*>(values.data()), values.size() * sizeof(float));
  in.read(reinterpret_cast<char*>(node_values.data()), node_values.size() * sizeof(float));
  if (!in) throw bad("the file is shorter than its header says");
  s.position.resize(vertices);
  s.velocity.resize(vertices);
  s.density.resize(vertices);
  if (has_j) s.plastic_j.resize(vertices);
  for (long i = 0; i < vertices; ++i) {
    const float* r = &values[i * row];
    for (int a = 0; a < 3; ++a) s.position[i][a] = r[a], s.velocity[i][a] = r[3 + a];
    s.density[i] = r[6];
    if (has_j) s.plastic_j[i] = r[7];
  }
  s.grid.node_density = std::move(node_values);
  return s;
}

std::vector<std::string> plyFramesIn(const std::string& directory) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(directory))
    if (entry.path().extension() == ".ply") files.push_back(entry.path().string());
  if (files.empty()) throw InputError(directory + ": no .ply frames in this directory");
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace snowsim
