#include "sim/scene/material_presets.h"

#include <algorithm>

namespace snowsim {

namespace {

using Json = nlohmann::json;

// The paper's reference snow (Stomakhin et al. 2013, table 2), every field of it given so that a
// preset below states only where it departs from it.
Json paperMaterial() {
  return {{"E0", 1.4e5},
          {"nu", 0.2},
          {"theta_c", 2.5e-2},
          {"theta_s", 7.5e-3},
          {"xi", 10},
          {"hardening_min", 0},
          {"hardening_max", 1e300},
          {"viscosity", 0},
          {"fracture_strain", 0},
          {"fracture_length", 0}};
}

Json with(Json base, const Json& changes) {
  for (const auto& [key, value] : changes.items()) base[key] = value;
  return base;
}

// The crack model of the flagship crack scenes (docs/snow-at-scale.md, "Cracks that open in the
// solver"): hardening bounded to [0.2, 5], a damper, failure past ln J_P = 0.3 over a band 5 mm
// wide, two velocities a node across damaged snow.
Json crackMaterial(double fracture_strain) {
  return with(paperMaterial(), {{"hardening_min", 0.2},
                                {"hardening_max", 5},
                                {"viscosity", 4},
                                {"fracture_strain", fracture_strain},
                                {"fracture_length", 0.005}});
}

const Json openCracks = {{"open_cracks", true}, {"crack_friction", 0.6}};
const Json shutCracks = {{"open_cracks", false}, {"crack_friction", 0.6}};

// Densities within the ranges snow science gives for each kind of snow (Cuffey and Paterson, The
// Physics of Glaciers, 4th ed. 2010, table 2.1: new snow 50-200 kg/m^3, wind-packed snow
// 350-400, firn 400-830, very wet snow 700-800). Stiffnesses stay near the paper's, far below
// real snow's (Mellor 1975), because the step shrinks with the wave speed sqrt(E0 / rho).
std::vector<MaterialPreset> makePresets() {
  return {
      {"chunky",
       "snow that breaks into chunks: the paper's snow with bounded hardening, a damper, "
       "failure past a fracture strain and cracks that open",
       crackMaterial(0.3), openCracks, 400},
      {"paper", "the paper's reference snow (Stomakhin et al. 2013, table 2), unchanged",
       paperMaterial(), shutCracks, 400},
      {"powder",
       "loose new snow: light and soft (the paper's lower Young's modulus and lower critical "
       "stretch), failing at a third of chunky's strain",
       with(crackMaterial(0.1), {{"E0", 4.8e4}, {"theta_s", 5e-3}, {"viscosity", 1}}), openCracks,
       150},
      {"packed",
       "packed, icy snow: dense and four times as stiff, brittle in tension, breaking into few "
       "large pieces",
       with(crackMaterial(0.2), {{"E0", 5.6e5}, {"theta_s", 5e-3}}), openCracks, 500},
      {"wet",
       "wet, heavy snow that sticks: dense, ductile (the paper's lower hardening), its softening "
       "bounded at half its strength, well damped, never failing",
       with(paperMaterial(),
            {{"xi", 5}, {"hardening_min", 0.5}, {"hardening_max", 5}, {"viscosity", 10}}),
       shutCracks, 700},
  };
}

}  // namespace

const std::vector<MaterialPreset>& materialPresets() {
  static const std::vector<MaterialPreset> presets = makePresets();
  return presets;
}

const MaterialPreset& defaultMaterialPreset() {
  return materialPresets().front();
}

const MaterialPreset* findMaterialPreset(const std::string& name) {
  const auto& presets = materialPresets();
  const auto it = std::find_if(presets.begin(), presets.end(),
                               [&](const MaterialPreset& p) { return p.name == name; });
  return it == presets.end() ? nullptr : &*it;
}

std::vector<std::string> materialPresetNames() {
  std::vector<std::string> names;
  for (const MaterialPreset& p : materialPresets()) names.push_back(p.name);
  return names;
}

Json beneath(const Json& fields, const Json& preset_fields) {
  Json merged = fields;
  for (const auto& [key, value] : preset_fields.items())
    if (!merged.contains(key)) merged[key] = value;
  return merged;
}

}  // namespace snowsim
