// What a collider is and how it acts on snow, named alike by the core's colliders and the scene
// file that describes them.
#pragma once

namespace snowsim {

enum class ColliderType { Sticky, Slip, Separating };
enum class ColliderShape { HalfSpace, Sphere, Box, Drum, Mesh };

}  // namespace snowsim
