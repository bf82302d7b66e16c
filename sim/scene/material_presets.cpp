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
// real snow's (Mellor 1975), because the step shrinks with the wave speed sqrt(E0 / rho); the
// other values are this project's, chosen by the smash of docs/materials.md.
std::vector<MaterialPreset> makePresets() {
  return {
      // Snow that breaks into chunks: the paper's snow with bounded hardening, a damper, failure
      // past a fracture strain and cracks that open.
      {"chunky", crackMaterial(0.3), openCracks, 400},
      // The paper's reference snow (Stomakhin et al. 2013, table 2), unchanged.
      {"paper", paperMaterial(), shutCracks, 400},
      // Light, soft new snow: a third of chunky's density and of its stiffness (the paper's lower
      // Young's modulus), so that the same throw breaks it alike (rho v^2 / E0 is chunky's);
      // weaker once cracked.
      {"powder",
       with(crackMaterial(0.15), {{"E0", 4.8e4}, {"hardening_min", 0.05}, {"viscosity", 1.4}}),
       {{"open_cracks", true}, {"crack_friction", 0.2}},
       150},
      // Hard, icy packed snow: dense, four times as stiff, compacting and so hardening at the
      // first touch: a throw that breaks chunky bounces it off whole.
      {"packed", with(crackMaterial(0.1), {{"E0", 5.6e5}, {"theta_c", 1e-2}, {"theta_s", 5e-3}}),
       openCracks, 500},
      // Wet, heavy snow that splats and sticks: dense and soft, yielding early with little
      // hardening (the paper's lower hardening), its softening bounded at half its strength,
      // never failing.
      {"wet",
       with(paperMaterial(), {{"E0", 4.8e4},
                              {"theta_c", 5e-3},
                              {"theta_s", 2.5e-3},
                              {"xi", 5},
                              {"hardening_min", 0.5},
                              {"hardening_max", 2},
                              {"viscosity", 4}}),
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
