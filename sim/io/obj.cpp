#include "sim/io/obj.h"

#include <charconv>
#include <cstdio>

#include "sim/io/files.h"

namespace snowsim {

namespace {

// The shortest text that reads back as the same float.
void appendNumber(std::string& out, float value) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, value).ptr;
  out.append(text, end);
}

void appendTriple(std::string& out, const char* tag, const std::array<float, 3>& v) {
  out += tag;
  for (const float x : v) {
    out += ' ';
    appendNumber(out, x);
  }
  out += '\n';
}

}  // namespace

void writeSurfaceObj(const std::string& path, const SnowSurface& m, const Snapshot& s, UpAxis up) {
  char header[160];
  std::snprintf(header, sizeof header,
                "# snowsim surface of frame %d\n# snowsim time %.17g\n# snowsim up %s\n", s.frame,
                s.time, up == UpAxis::Z ? "z" : "y");
  std::string body = header;
  body.reserve(body.size() + m.vertices.size() * 80 + m.triangles.size() * 40);
  for (const auto& v : m.vertices) appendTriple(body, "v", toUpAxis(v, up));
  for (const auto& n : m.normals) appendTriple(body, "vn", toUpAxis(n, up));
  for (const auto& t : m.triangles) {
    body += 'f';
    for (const std::uint32_t index : t) {
      const std::string one = std::to_string(index + 1);  // OBJ counts from 1
      body += ' ';
      body += one;
      body += "//";
      body += one;
    }
    body += '\n';
  }
  writeFileAtomically(path, body);
}

}  // namespace snowsim
