// snowsim.Snapshot: a frame's state copied from a simulation, for drawing later and for its
// arrays, which do not follow the simulation's later steps.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <pybind11/numpy.h>

#include "python/bindings.h"

namespace snowsim {

Snapshot takeSnapshot(PySimulation& self, const char* what) {
  const Simulation& simulation = self.live(what);
  return simulation.snapshot(static_cast<int>(std::lround(simulation.time() * self.scene.fps)));
}

namespace {

// The first `dimension` components of each particle's vector, float32 (N, D): a copy.
py::array_t<float> vectorArray(const std::vector<std::array<float, 3>>& values, int dimension) {
  py::array_t<float> out({py::ssize_t(values.size()), py::ssize_t(dimension)});
  float* data = out.mutable_data();
  for (size_t p = 0; p < values.size(); ++p)
    for (int a = 0; a < dimension; ++a) data[p * dimension + a] = values[p][a];
  return out;
}

}  // namespace

void bindSnapshot(py::module_& m) {
  using Self = PySnapshot;
  py::class_<Self>(m, "Snapshot",
                   "A frame's state at one time, copied from a simulation (Simulation.snapshot): "
                   "what snowsim.render draws and a PLY frame holds. Its arrays are copies.")
      .def_property_readonly(
          "time", [](const Self& self) { return self.snapshot.time; }, "Simulated time (s)")
      .def_property_readonly(
          "frame", [](const Self& self) { return self.snapshot.frame; },
          "The run's frame at this time: round(time * fps)")
      .def_property_readonly("particle_count",
                             [](const Self& self) { return self.snapshot.size(); })
      .def_property_readonly("dimension",
                             [](const Self& self) { return self.snapshot.grid.dimension; })
      .def(
          "positions",
          [](const Self& self) {
            return vectorArray(self.snapshot.position, self.snapshot.grid.dimension);
          },
          "Positions (m), float32 (N, D) as the PLY frames hold them: a copy")
      .def(
          "velocities",
          [](const Self& self) {
            return vectorArray(self.snapshot.velocity, self.snapshot.grid.dimension);
          },
          "Velocities (m/s), float32 (N, D): a copy")
      .def(
          "plastic_j",
          [](const Self& self) {
            const std::vector<float>& j = self.snapshot.plastic_j;
            if (j.empty())
              throw py::value_error(
                  "plastic_j: MPM only; this snapshot is of the report's density_hybrid solver");
            py::array_t<float> out(py::ssize_t(j.size()));
            std::copy(j.begin(), j.end(), out.mutable_data());
            return out;
          },
          "MPM: J_P, the plastic volume ratio, float32 (N,): a copy")
      .def("__repr__", [](const Self& self) {
        return "<snowsim.Snapshot t=" + std::to_string(self.snapshot.time) + " s, " +
               std::to_string(self.snapshot.size()) + " particles>";
      });
}

}  // namespace snowsim
