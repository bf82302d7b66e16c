// What the module's files share: the Python objects over a scene, a simulation and a snapshot, and
// the functions that add each part of the module.
#pragma once

#include <memory>
#include <string>

#include <pybind11/pybind11.h>

#include "sim/core/snapshot.h"
#include "sim/scene/scene.h"
#include "sim/simulation.h"

namespace snowsim {

namespace py = pybind11;

// A scene as loaded, with every override resolved.
struct PyScene {
  Scene scene;
};

// A simulation and what a render of it needs: the scene it runs and its first frame, which a run
// frames its camera on.
struct PySimulation {
  Scene scene;
  std::unique_ptr<Simulation> simulation;
  Snapshot first;
  bool busy = false;  // stepping with the GIL released: another Python thread must wait

  // The simulation, or a ValueError once it is closed or while another thread steps it.
  Simulation& live(const char* what);
};

// A frame's state, copied from a simulation at one time, with what a render of it needs: the
// scene and the simulation's first frame, which the camera frames as a run's does.
struct PySnapshot {
  Scene scene;
  Snapshot first;
  Snapshot snapshot;
};

// The simulation's state now, as a run's frame at this time holds it; ValueError as live's.
Snapshot takeSnapshot(PySimulation& self, const char* what);

void bindSimulation(py::module_& module);
void bindSnapshot(py::module_& module);
void bindRender(py::module_& module);

}  // namespace snowsim
