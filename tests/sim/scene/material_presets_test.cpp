// Material presets: a scene that names none breaks into chunks, a named one lies beneath the
// scene's own fields, and names or combinations that cannot run are refused naming them.
#include <gtest/gtest.h>

#include <fstream>

#include "sim/core/errors.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/material_presets.h"
#include "sim/scene/scene.h"
#include "tests/support/temp_dir.h"

namespace snowsim {
namespace {

// A snowball in 3D with no material block, as a user writes it.
const std::string kUntuned = R"({
  "name": "untuned", "dimension": 3, "solver": "mpm",
  "grid": {"cells": [20, 20, 20], "cell_size": 0.01},
  "bodies": [{"shape": "ball", "center": [0.1, 0.1, 0.1], "radius": 0.04}]
})";

std::string writeTemp(const std::string& text) {
  static int counter = 0;
  const auto path =
      snowsim_test::processTempDir() / ("preset_" + std::to_string(counter++) + ".json");
  std::ofstream(path) << text;
  return path.string();
}

std::string errorOf(const std::vector<std::string>& overrides) {
  try {
    loadScene(writeTemp(kUntuned), overrides);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(MaterialPreset, ASceneThatNamesNoMaterialBreaksIntoChunks) {
  const Scene s = loadScene(writeTemp(kUntuned));
  EXPECT_EQ(s.material_preset, "chunky");
  EXPECT_TRUE(s.mpm.open_cracks);
  EXPECT_DOUBLE_EQ(s.material.fracture_strain, 0.3);
  EXPECT_DOUBLE_EQ(s.material.fracture_length, 0.005);
  EXPECT_DOUBLE_EQ(s.material.viscosity, 4);
  EXPECT_DOUBLE_EQ(s.material.hardening_min, 0.2);
  EXPECT_DOUBLE_EQ(s.material.hardening_max, 5);
  EXPECT_DOUBLE_EQ(s.bodies[0].density, 400);
}

TEST(MaterialPreset, PaperIsTheReferenceSnowUnchanged) {
  const Scene s = loadScene(writeTemp(kUntuned), {"material.preset=paper"});
  const SnowMaterial reference;
  EXPECT_EQ(s.material.E0, reference.E0);
  EXPECT_EQ(s.material.theta_c, reference.theta_c);
  EXPECT_EQ(s.material.theta_s, reference.theta_s);
  EXPECT_EQ(s.material.xi, reference.xi);
  EXPECT_EQ(s.material.hardening_min, reference.hardening_min);
  EXPECT_EQ(s.material.hardening_max, reference.hardening_max);
  EXPECT_EQ(s.material.viscosity, 0);
  EXPECT_EQ(s.material.fracture_strain, 0);
  EXPECT_FALSE(s.mpm.open_cracks);
  EXPECT_DOUBLE_EQ(s.bodies[0].density, 400);
  EXPECT_EQ(s.mpm.crack_friction, MpmParams{}.crack_friction);
}

TEST(MaterialPreset, TheScenesOwnFieldsWinOverThePresets) {
  const Scene s = loadScene(writeTemp(kUntuned),
                            {"material.preset=powder", "material.E0=1e5", "bodies.0.density=300"});
  EXPECT_EQ(s.material_preset, "powder");
  EXPECT_DOUBLE_EQ(s.material.E0, 1e5);
  EXPECT_DOUBLE_EQ(s.bodies[0].density, 300);
  const Scene powder = loadScene(writeTemp(kUntuned), {"material.preset=powder"});
  EXPECT_DOUBLE_EQ(powder.material.E0, 4.8e4);
  EXPECT_DOUBLE_EQ(powder.bodies[0].density, 150) << "a body that gives none has the preset's";
  EXPECT_DOUBLE_EQ(s.material.theta_s, powder.material.theta_s);
  const Scene shut = loadScene(writeTemp(kUntuned), {"mpm.open_cracks=false"});
  EXPECT_FALSE(shut.mpm.open_cracks);
  EXPECT_DOUBLE_EQ(shut.material.fracture_strain, 0.3);
}

TEST(MaterialPreset, EveryPresetLoadsAndReadsBackFromTheSceneAsRun) {
  for (const std::string& name : materialPresetNames()) {
    const Scene s = loadScene(writeTemp(kUntuned), {"material.preset=" + name});
    const Scene again = parseScene(sceneToJson(s), "as_run.json");
    EXPECT_EQ(again.material_preset, name);
    EXPECT_EQ(again.material.E0, s.material.E0) << name;
    EXPECT_EQ(again.material.viscosity, s.material.viscosity) << name;
    EXPECT_EQ(again.material.fracture_strain, s.material.fracture_strain) << name;
    EXPECT_EQ(again.mpm.open_cracks, s.mpm.open_cracks) << name;
    EXPECT_EQ(again.bodies[0].density, s.bodies[0].density) << name;
  }
}

TEST(MaterialPreset, AnUnknownNameIsRefusedWithTheList) {
  const std::string message = errorOf({"material.preset=slush"});
  EXPECT_NE(message.find("material.preset: \"slush\" is not allowed; allowed: "), std::string::npos)
      << message;
  for (const std::string& name : materialPresetNames())
    EXPECT_NE(message.find("\"" + name + "\""), std::string::npos) << message;
}

TEST(MaterialPreset, CracksWithAnIntegratorOrTransferThatCannotRunThemAreRefusedNamingBoth) {
  const std::string semi = errorOf({"mpm.precision=double", "mpm.integrator=semi_implicit"});
  EXPECT_NE(semi.find("--set mpm.integrator=semi_implicit"), std::string::npos) << semi;
  EXPECT_NE(semi.find("material.preset: \"chunky\" (the default when none is named) opens "
                      "cracks (mpm.open_cracks), which need mpm.integrator \"explicit\", not "
                      "\"semi_implicit\""),
            std::string::npos)
      << semi;
  EXPECT_NE(semi.find("(\"paper\")"), std::string::npos) << semi;

  const std::string apic = errorOf({"material.preset=packed", "mpm.transfer=apic"});
  EXPECT_NE(apic.find("material.preset: \"packed\" opens cracks"), std::string::npos) << apic;
  EXPECT_NE(apic.find("which need mpm.transfer \"mls\", not \"apic\""), std::string::npos) << apic;
  EXPECT_NE(apic.find("(\"paper\", \"wet\")"), std::string::npos) << apic;

  EXPECT_EQ(errorOf({"material.preset=wet", "mpm.transfer=apic"}), "");
  EXPECT_EQ(
      errorOf({"material.preset=paper", "mpm.precision=double", "mpm.integrator=semi_implicit"}),
      "");
  EXPECT_EQ(errorOf({"mpm.transfer=apic", "mpm.open_cracks=false"}), "")
      << "the scene's own field settles it";
  EXPECT_EQ(errorOf({"solver=density_hybrid", "mpm.transfer=apic"}), "")
      << "the report's method runs no cracks";
  const std::string typo = errorOf({"mpm.integrator=semi-implicit"});
  EXPECT_NE(typo.find("mpm.integrator: \"semi-implicit\" is not allowed"), std::string::npos)
      << typo;
}

TEST(MaterialPreset, TurningFractureOffUnderTheCrackBandSaysWhatElseToTurnOff) {
  const std::string off = errorOf({"material.fracture_strain=0"});
  EXPECT_NE(off.find("--set material.fracture_strain=0"), std::string::npos) << off;
  EXPECT_NE(off.find("material.fracture_length 0 and mpm.open_cracks false"), std::string::npos)
      << off;
  EXPECT_EQ(errorOf({"material.fracture_strain=0", "material.fracture_length=0",
                     "mpm.open_cracks=false"}),
            "");
}

}  // namespace
}  // namespace snowsim
