// The JSON side of scene files, kept out of sim/scene/scene.h: reading a JSON file, parsing a
// scene built as JSON in code, and reading one JSON object field by field with the checks and
// messages users need: the file, the field's path, what was wrong and what is allowed. Every key
// of the object must be read, or finish() names the unknown one and the closest valid name.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/core/errors.h"

namespace snowsim {

using Json = nlohmann::json;

struct Scene;

// Reads a JSON file; a syntax error names the file, line and column.
Json readJsonFile(const std::string& path);
// The same for a file's text, `file` naming it in messages.
Json parseJsonText(const std::string& text, const std::string& file);

// Parses and validates a scene given as JSON (tests and benchmarks build theirs in code); throws
// InputError naming the file and field. For scene files: loadScene (sim/scene/scene.h).
Scene parseScene(const Json& root, const std::string& file);

// The scene as a scene file: every field, defaults included; parseScene reads it back to the same
// Scene. What a run used, after --set and --quality.
Json sceneToJson(const Scene& scene);

// loadScene (sim/scene/scene.h) of a scene file's JSON, `file` naming it in messages.
Scene loadScene(Json root, const std::string& file, const std::vector<std::string>& overrides);

// A bad field: what() names the file, the field and the problem; field is the dotted path
// (bodies.0.radius), to find the --set assignment that wrote it.
struct FieldError : InputError {
  FieldError(const std::string& file, const std::string& shown_path, const std::string& problem);
  std::string field;    // dotted: bodies.0.radius
  std::string problem;  // what() without the file: "bodies[0].radius: must be positive; ..."
  std::vector<std::string> also;  // dotted: other fields the problem is of (center and radius)
};

// The dotted form of a field path: "bodies[0].radius" gives "bodies.0.radius".
std::string dottedPath(const std::string& path);

// The names as a message lists them: "a", "b", "c".
std::string joinNames(const std::vector<std::string>& names);

// Levenshtein distance, for "did you mean" suggestions.
int editDistance(const std::string& a, const std::string& b);

class JsonFields {
 public:
  JsonFields(const Json& object, std::string path, std::string file);

  bool has(const std::string& key) const;
  // Whether an optional field is given; either way it is a known field of the object.
  bool given(const std::string& key);
  const std::string& path() const { return path_; }
  std::string fieldPath(const std::string& key) const;

  // Numbers in [lo, hi]; open bounds when the flags say so.
  double number(const std::string& key, std::optional<double> fallback,
                double lo = -std::numeric_limits<double>::infinity(),
                double hi = std::numeric_limits<double>::infinity(), bool lo_open = false,
                bool hi_open = false);
  int integer(const std::string& key, std::optional<int> fallback, int lo, int hi);
  bool boolean(const std::string& key, std::optional<bool> fallback);
  std::string string(const std::string& key, std::optional<std::string> fallback);
  // One of the allowed names.
  std::string choice(const std::string& key, const std::vector<std::string>& allowed,
                     std::optional<std::string> fallback);
  // One of the allowed names, as the value it is paired with.
  template <class Value>
  Value choiceOf(const std::string& key, const std::vector<std::pair<std::string, Value>>& named,
                 std::optional<std::string> fallback) {
    std::vector<std::string> allowed;
    for (const auto& entry : named) allowed.push_back(entry.first);
    const std::string chosen = choice(key, allowed, fallback);
    for (const auto& entry : named)
      if (entry.first == chosen) return entry.second;
    return named.front().second;  // not reached: choice() accepts the allowed names only
  }
  // An array of numbers whose length is one of the allowed lengths.
  std::vector<double> numbers(const std::string& key, std::optional<std::vector<double>> fallback,
                              std::vector<int> lengths);
  // A sub-object or an array, marked as read; the caller checks inside it.
  const Json* object(const std::string& key, bool required);
  const Json* array(const std::string& key, bool required);

  // Throws if the object has a key none of the readers asked for.
  void finish() const;

  // The problem is named at `key`; an override of one of the `also` keys is blamed as well.
  [[noreturn]] void fail(const std::string& key, const std::string& message,
                         const std::vector<std::string>& also = {}) const;

 private:
  const Json* lookup(const std::string& key, bool required);

  const Json& object_;
  std::string path_;
  std::string file_;
  std::set<std::string> read_;
  std::vector<std::string> known_;
};

}  // namespace snowsim
