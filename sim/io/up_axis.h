// The up axis of exported files. snowsim simulates with y up, as Houdini does; Blender's world has
// z up. Z-up turns the scene +90 degrees about x: (x, y, z) -> (x, -z, y), a rotation
// (determinant +1), so a right-handed frame stays right-handed and nothing is mirrored.
#pragma once

#include <array>

namespace snowsim {

enum class UpAxis { Y, Z };

template <class T>
std::array<T, 3> toUpAxis(const std::array<T, 3>& v, UpAxis up) {
  return up == UpAxis::Z ? std::array<T, 3>{v[0], -v[2], v[1]} : v;
}

template <class T>
std::array<T, 3> fromUpAxis(const std::array<T, 3>& v, UpAxis up) {
  return up == UpAxis::Z ? std::array<T, 3>{v[0], v[2], -v[1]} : v;
}

}  // namespace snowsim
