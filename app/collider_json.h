// The scene's colliders in run.json, so `snowsim render DIR` draws them where they were at each
// frame: written at time 0 with their velocities by `snowsim run`, read back by `snowsim render`.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/core/snapshot.h"

namespace snowsim {

nlohmann::json collidersToJson(const std::vector<SnapshotCollider>& colliders);

// Throws InputError naming `file` and the entry when run.json's "colliders" is malformed.
std::vector<SnapshotCollider> collidersFromJson(const nlohmann::json& colliders,
                                                const std::string& file);

}  // namespace snowsim
