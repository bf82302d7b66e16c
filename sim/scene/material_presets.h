// Named snow materials (`"material": {"preset": NAME}`): each a set of the material's fields, the
// solver's physical ones (mpm.open_cracks, mpm.crack_friction) and the bodies' rest density, laid
// beneath whatever the scene sets itself. docs/materials.md shows each.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace snowsim {

struct MaterialPreset {
  std::string name;
  nlohmann::json material;  // fields of the scene's "material" object
  nlohmann::json mpm;       // fields of the scene's "mpm" object
  double density;           // kg/m^3, for bodies that give none
};

// Every preset, the default first.
const std::vector<MaterialPreset>& materialPresets();

// The preset a scene gets when its material names none: snow that breaks into chunks.
const MaterialPreset& defaultMaterialPreset();

// The preset of that name, or null.
const MaterialPreset* findMaterialPreset(const std::string& name);

// The names, in order.
std::vector<std::string> materialPresetNames();

// `fields` with each of the preset's fields it does not give itself.
nlohmann::json beneath(const nlohmann::json& fields, const nlohmann::json& preset_fields);

}  // namespace snowsim
