// The scene's colliders in run.json (at time 0) and in colliders.json (where they are at every
// frame: docs/scene-format.md, "Moving colliders"), so that `snowsim render DIR` and other tools
// draw them beside the snow.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/core/snapshot.h"
#include "sim/scene/scene.h"

namespace snowsim {

nlohmann::json collidersToJson(const std::vector<SnapshotCollider>& colliders);

// colliders.json: the scene's colliders at each of the first `frames` frames, computed from the
// scene (a frame's poses do not depend on the run, so a resumed run writes the same file).
nlohmann::json colliderFramesJson(const Scene& scene, int frames);

// Throws InputError naming `file` and the entry when run.json's "colliders" is malformed.
std::vector<SnapshotCollider> collidersFromJson(const nlohmann::json& colliders,
                                                const std::string& file);

}  // namespace snowsim
