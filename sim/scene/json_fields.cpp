#include "sim/scene/json_fields.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>

namespace snowsim {

int editDistance(const std::string& a, const std::string& b) {
  std::vector<int> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    int diagonal = row[0];
    row[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j) {
      const int above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

Json readJsonFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file (missing or unreadable)");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parseJsonText(buffer.str(), path);
}

Json parseJsonText(const std::string& text, const std::string& path) {
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    // Turn the byte offset into a line and column.
    int line = 1, column = 1;
    for (size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n')
        line++, column = 1;
      else
        column++;
    }
    std::string what = e.what();
    const auto colon = what.find("syntax error");
    throw InputError(
        path + ":" + std::to_string(line) + ":" + std::to_string(column) +
        ": malformed JSON: " + (colon == std::string::npos ? what : what.substr(colon)));
  } catch (const Json::out_of_range& e) {
    // A number beyond a double, e.g. 1e400 (found by fuzz/scene_fuzzer): no offset is given.
    const std::string what = e.what();
    const auto text_start = what.find("] ");
    throw InputError(path + ": malformed JSON: " +
                     (text_start == std::string::npos ? what : what.substr(text_start + 2)) +
                     "; allowed: numbers within +-1.8e308");
  }
}

std::string dottedPath(const std::string& path) {
  std::string dotted;
  for (char c : path) {
    if (c == '[')
      dotted += dotted.empty() ? "" : ".";
    else if (c != ']')
      dotted += c;
  }
  return dotted;
}

FieldError::FieldError(const std::string& file, const std::string& shown_path,
                       const std::string& message)
    : InputError(file + ": " + shown_path + ": " + message),
      field(dottedPath(shown_path)),
      problem(shown_path + ": " + message) {}

namespace {

std::string typeName(const Json& j) {
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  if (j.is_object()) return "an object";
  return "null";
}

// A string naming a number JSON cannot hold ("nan", "-inf", "Infinity"): what --set time.dt=nan
// gives, the value not parsing as JSON.
bool namesNonFinite(const Json& j) {
  if (!j.is_string()) return false;
  std::string text = j.get<std::string>();
  if (!text.empty() && (text[0] == '+' || text[0] == '-')) text.erase(0, 1);
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return text == "nan" || text == "inf" || text == "infinity";
}

std::string notFinite(const Json& j) {
  return j.get<std::string>() + " is not a finite number";
}

}  // namespace

std::string joinNames(const std::vector<std::string>& names) {
  std::string r;
  for (size_t i = 0; i < names.size(); ++i) r += (i ? ", \"" : "\"") + names[i] + "\"";
  return r;
}

JsonFields::JsonFields(const Json& object, std::string path, std::string file)
    : object_(object), path_(std::move(path)), file_(std::move(file)) {
  if (!object_.is_object())
    throw FieldError(file_, path_.empty() ? "the scene" : path_,
                     "expected an object, found " + typeName(object_));
}

bool JsonFields::has(const std::string& key) const {
  return object_.contains(key);
}

bool JsonFields::given(const std::string& key) {
  if (std::find(known_.begin(), known_.end(), key) == known_.end()) known_.push_back(key);
  read_.insert(key);
  return has(key);
}

std::string JsonFields::fieldPath(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void JsonFields::fail(const std::string& key, const std::string& message,
                      const std::vector<std::string>& also) const {
  FieldError error(file_, fieldPath(key), message);
  for (const std::string& other : also) error.also.push_back(dottedPath(fieldPath(other)));
  throw error;
}

const Json* JsonFields::lookup(const std::string& key, bool required) {
  given(key);
  auto it = object_.find(key);
  if (it == object_.end()) {
    if (!required) return nullptr;
    // A misspelt required field is better reported as the misspelling.
    for (auto other = object_.begin(); other != object_.end(); ++other)
      if (editDistance(other.key(), key) <= 2)
        fail(other.key(), "unknown field; did you mean \"" + key + "\"?");
    fail(key, "missing (this field is required)");
  }
  return &*it;
}

double JsonFields::number(const std::string& key, std::optional<double> fallback, double lo,
                          double hi, bool lo_open, bool hi_open) {
  const Json* j = lookup(key, !fallback);
  if (!j) return *fallback;
  const std::string range = std::string(lo_open ? "(" : "[") + numberText(lo) + ", " +
                            numberText(hi) + (hi_open ? ")" : "]");
  if (namesNonFinite(*j)) fail(key, notFinite(*j) + "; allowed: " + range);
  if (!j->is_number()) fail(key, "expected a number, found " + typeName(*j));
  const double x = j->get<double>();
  const bool below = lo_open ? !(x > lo) : !(x >= lo);
  const bool above = hi_open ? !(x < hi) : !(x <= hi);
  if (!std::isfinite(x) || below || above)
    fail(key, numberText(x) + " is out of range; allowed: " + range);
  return x;
}

int JsonFields::integer(const std::string& key, std::optional<int> fallback, int lo, int hi) {
  const Json* j = lookup(key, !fallback);
  if (!j) return *fallback;
  if (namesNonFinite(*j))
    fail(key, notFinite(*j) + "; allowed: " + std::to_string(lo) + " to " + std::to_string(hi));
  if (!j->is_number_integer()) fail(key, "expected a whole number, found " + typeName(*j));
  const auto x = j->get<long long>();
  if (x < lo || x > hi)
    fail(key, std::to_string(x) + " is out of range; allowed: " + std::to_string(lo) + " to " +
                  std::to_string(hi));
  return static_cast<int>(x);
}

bool JsonFields::boolean(const std::string& key, std::optional<bool> fallback) {
  const Json* j = lookup(key, !fallback);
  if (!j) return *fallback;
  if (!j->is_boolean()) fail(key, "expected true or false, found " + typeName(*j));
  return j->get<bool>();
}

std::string JsonFields::string(const std::string& key, std::optional<std::string> fallback) {
  const Json* j = lookup(key, !fallback);
  if (!j) return *fallback;
  if (!j->is_string()) fail(key, "expected a string, found " + typeName(*j));
  return j->get<std::string>();
}

std::string JsonFields::choice(const std::string& key, const std::vector<std::string>& allowed,
                               std::optional<std::string> fallback) {
  const std::string value = string(key, fallback);
  if (std::find(allowed.begin(), allowed.end(), value) == allowed.end())
    fail(key, "\"" + value + "\" is not allowed; allowed: " + joinNames(allowed));
  return value;
}

std::vector<double> JsonFields::numbers(const std::string& key,
                                        std::optional<std::vector<double>> fallback,
                                        std::vector<int> lengths) {
  const Json* j = lookup(key, !fallback);
  if (!j) return *fallback;
  std::string want;
  for (size_t i = 0; i < lengths.size(); ++i)
    want += (i ? " or " : "") + std::to_string(lengths[i]);
  if (!j->is_array()) fail(key, "expected an array of " + want + " numbers, found " + typeName(*j));
  const int n = static_cast<int>(j->size());
  if (std::find(lengths.begin(), lengths.end(), n) == lengths.end())
    fail(key, "expected " + want + " numbers, found " + std::to_string(n));
  std::vector<double> r;
  for (const Json& e : *j) {
    if (namesNonFinite(e)) fail(key, notFinite(e) + "; allowed: finite numbers");
    if (!e.is_number() || !std::isfinite(e.get<double>()))
      fail(key, "expected finite numbers, found " + typeName(e));
    r.push_back(e.get<double>());
  }
  return r;
}

const Json* JsonFields::object(const std::string& key, bool required) {
  const Json* j = lookup(key, required);
  if (j && !j->is_object()) fail(key, "expected an object, found " + typeName(*j));
  return j;
}

const Json* JsonFields::array(const std::string& key, bool required) {
  const Json* j = lookup(key, required);
  if (j && !j->is_array()) fail(key, "expected an array, found " + typeName(*j));
  return j;
}

void JsonFields::finish() const {
  for (auto it = object_.begin(); it != object_.end(); ++it) {
    if (read_.count(it.key())) continue;
    // The fields the key begins (checkpoint_every: checkpoint_every_frames) before the nearest
    // spelling, which for a shortened name may be another field of the same prefix.
    std::string begun, best;
    int best_distance = 1 << 30;
    for (const std::string& k : known_) {
      if (it.key().size() >= 3 && k.rfind(it.key(), 0) == 0)
        begun += (begun.empty() ? "\"" : " or \"") + k + "\"";
      const int d = editDistance(it.key(), k);
      if (d < best_distance) best_distance = d, best = k;
    }
    std::string message = "unknown field";
    if (!begun.empty())
      message += "; did you mean " + begun + "?";
    else if (!best.empty() && best_distance <= std::max<int>(2, best.size() / 2))
      message += "; did you mean \"" + best + "\"?";
    else if (!known_.empty())
      message += "; allowed: " + joinNames(known_);
    fail(it.key(), message);
  }
}

}  // namespace snowsim
