// libFuzzer target: a scene file's text and --set overrides, parsed and validated as `snowsim run`
// does. The input is the file's text, then each override after a NUL byte. Any input must end in a
// Scene or an InputError; a Scene must also write back (run.json's resolved scene) to a file that
// parses again.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "sim/core/errors.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> parts;
  for (std::size_t start = 0;;) {
    const std::size_t end = input.find('\0', start);
    parts.push_back(input.substr(start, end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  const std::vector<std::string> overrides(parts.begin() + 1, parts.end());
  snowsim::Scene scene;
  try {
    scene =
        snowsim::loadScene(snowsim::parseJsonText(parts[0], "fuzz.json"), "fuzz.json", overrides);
  } catch (const snowsim::InputError&) {
    return 0;
  }
  try {
    snowsim::parseScene(snowsim::sceneToJson(scene), "resolved.json");
  } catch (const snowsim::InputError&) {
    std::abort();  // a scene that was accepted must write back to one that is accepted
  }
  return 0;
}
