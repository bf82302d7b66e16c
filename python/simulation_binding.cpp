// snowsim.Simulation: stepping with the GIL released, Ctrl-C between steps, the state as numpy
// arrays (copies), checkpoints.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <nlohmann/json.hpp>

#include "app/run_checkpoint.h"
#include "python/bindings.h"

namespace snowsim {

Simulation& PySimulation::live(const char* what) {
  if (!simulation)
    throw py::value_error(std::string(what) + ": the simulation is closed (close() was called)");
  if (busy)
    throw py::value_error(std::string(what) + ": another thread is stepping the simulation");
  return *simulation;
}

namespace {

int checkedThreads(int threads) {
  if (threads < 1 || threads > 1024)
    throw py::value_error("threads: " + std::to_string(threads) + " is not allowed: 1 to 1024");
  return threads;
}

PySimulation* makePySimulation(const Scene& scene, int threads) {
  const int checked = checkedThreads(threads);
  std::unique_ptr<Simulation> simulation;
  Snapshot first;
  {
    // Sampling a large scene's bodies and building its solver take a while: other Python threads
    // run meanwhile.
    py::gil_scoped_release released;
    simulation = makeSimulation(scene, checked);
    first = simulation->snapshot(0);
  }
  return new PySimulation{scene, std::move(simulation), std::move(first)};
}

// Steps with the GIL released, taking it back between steps to look for Ctrl-C: a signal stops
// the simulation at the end of the current step and raises KeyboardInterrupt.
template <class Steps>
void stepReleased(PySimulation& self, const char* what, Steps&& steps) {
  Simulation& simulation = self.live(what);
  self.busy = true;
  bool interrupted = false;
  try {
    py::gil_scoped_release released;
    steps(simulation, [&] {
      py::gil_scoped_acquire held;
      interrupted = PyErr_CheckSignals() != 0;
      return interrupted;
    });
  } catch (...) {
    self.busy = false;
    throw;
  }
  self.busy = false;
  if (interrupted) throw py::error_already_set();
}

// A copy of values (shape, C order) as a float64 array.
py::array_t<double> arrayOf(const std::vector<double>& values, std::vector<py::ssize_t> shape) {
  py::array_t<double> out(shape);
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

// The MPM solver's own state and grid, which the report's method does not hand out.
void requireMpm(const PySimulation& self, const char* what) {
  if (self.scene.solver != SolverType::Mpm)
    throw py::value_error(std::string(what) +
                          ": MPM only; this simulation runs the report's density_hybrid solver "
                          "(load the scene with overrides={\"solver\": \"mpm\"})");
}

// The grid's nodes as shape (nx, ny[, nz]) + tail, indexed by node along x, y, z: a copy.
py::array_t<double> nodeArray(const StateArrays& state, const std::vector<double>& values,
                              int components) {
  std::vector<py::ssize_t> shape, strides;
  py::ssize_t stride = sizeof(double) * components;
  for (int a = 0; a < state.dimension; ++a) {
    shape.push_back(state.nodes[a]);
    strides.push_back(stride);
    stride *= state.nodes[a];
  }
  if (components > 1) {
    shape.push_back(components);
    strides.push_back(sizeof(double));
  }
  return py::array_t<double>(shape, strides, values.data());
}

}  // namespace

void bindSimulation(py::module_& m) {
  using Self = PySimulation;
  py::class_<Self>(m, "Simulation",
                   "A scene's simulation, stepped by the library `snowsim run` runs. The arrays "
                   "its methods return are copies: changing one changes nothing in the solver.")
      .def(py::init([](const PyScene& scene, int threads) {
             return makePySimulation(scene.scene, threads);
           }),
           py::arg("scene"), py::arg("threads") = 1,
           "Samples the scene's bodies and builds its solver. threads: the MPM solver's, 1 to "
           "1024; results are the same for any count.")
      .def(
          "advance_to",
          [](Self& self, double t) {
            Simulation& simulation = self.live("advance_to");
            if (!std::isfinite(t))
              throw py::value_error("advance_to: t is " + std::to_string(t) +
                                    "; a finite time in seconds");
            if (t < simulation.time())
              throw py::value_error("advance_to: t = " + std::to_string(t) +
                                    " s is before the simulation's time, " +
                                    std::to_string(simulation.time()) + " s");
            stepReleased(self, "advance_to",
                         [&](Simulation& s, const auto& stop) { s.advanceTo(t, stop); });
          },
          py::arg("t"),
          "Steps until the time is t seconds, the last step shortened to land on it, as a run "
          "steps to each frame's time. Ctrl-C stops at the end of the current step "
          "(KeyboardInterrupt); a diverged state raises snowsim.SimulationError.")
      .def(
          "step",
          [](Self& self) {
            stepReleased(self, "step", [](Simulation& s, const auto&) { s.step(); });
          },
          "One step of the scene's dt, or shorter where stability asks.")
      .def_property_readonly(
          "time", [](Self& self) { return self.live("time").time(); }, "Simulated time (s)")
      .def_property_readonly(
          "step_count", [](Self& self) { return self.live("step_count").steps(); },
          "Steps taken since the start (a loaded checkpoint's included)")
      .def_property_readonly("particle_count",
                             [](Self& self) { return self.live("particle_count").particleCount(); })
      .def_property_readonly("dimension", [](const Self& self) { return self.scene.dimension; })
      .def_property_readonly(
          "scene", [](const Self& self) { return PyScene{self.scene}; },
          "The scene it runs (a copy)")
      .def(
          "positions",
          [](Self& self) {
            const StateArrays s = self.live("positions").stateArrays();
            return arrayOf(s.position, {py::ssize_t(s.mass.size()), s.dimension});
          },
          "Positions (m), float64 (N, D), in the particles' creation order: a copy")
      .def(
          "velocities",
          [](Self& self) {
            const StateArrays s = self.live("velocities").stateArrays();
            return arrayOf(s.velocity, {py::ssize_t(s.mass.size()), s.dimension});
          },
          "Velocities (m/s), float64 (N, D): a copy")
      .def(
          "masses",
          [](Self& self) {
            const StateArrays s = self.live("masses").stateArrays();
            return arrayOf(s.mass, {py::ssize_t(s.mass.size())});
          },
          "Masses (kg; 2D: kg per metre of depth), float64 (N,): a copy")
      .def(
          "plastic_j",
          [](Self& self) {
            requireMpm(self, "plastic_j");
            const StateArrays s = self.live("plastic_j").stateArrays();
            return arrayOf(s.plastic_j, {py::ssize_t(s.plastic_j.size())});
          },
          "MPM: J_P = det F_P, the plastic volume ratio, float64 (N,): a copy")
      .def(
          "deformation_gradients",
          [](Self& self) {
            requireMpm(self, "deformation_gradients");
            const StateArrays s = self.live("deformation_gradients").stateArrays();
            return arrayOf(s.elastic_gradient,
                           {py::ssize_t(s.plastic_j.size()), s.dimension, s.dimension});
          },
          "MPM: the elastic deformation gradients F_E, float64 (N, D, D): a copy")
      .def(
          "grid_masses",
          [](Self& self) {
            requireMpm(self, "grid_masses");
            const StateArrays s = self.live("grid_masses").stateArrays();
            return nodeArray(s, s.node_mass, 1);
          },
          "MPM: each node's mass at the end of the last step, float64 (nx, ny[, nz]) indexed by "
          "node, two ghost layers beyond each wall included (node i at (i - 2) h): a copy")
      .def(
          "grid_velocities",
          [](Self& self) {
            requireMpm(self, "grid_velocities");
            const StateArrays s = self.live("grid_velocities").stateArrays();
            return nodeArray(s, s.node_velocity, s.dimension);
          },
          "MPM: each node's velocity at the end of the last step, float64 (nx, ny[, nz], D): a "
          "copy")
      .def(
          "snapshot",
          [](Self& self) {
            return PySnapshot{self.scene, self.first, takeSnapshot(self, "snapshot")};
          },
          "The state now as a snowsim.Snapshot: a copy, which later steps leave as it is")
      .def(
          "save",
          [](Self& self, const std::string& path) {
            const Simulation& simulation = self.live("save");
            writeCheckpointFile(path, self.scene, simulation, nlohmann::json::object(), false);
          },
          py::arg("path"),
          "Writes a checkpoint: the whole state, from which Simulation.load continues to the very "
          "particles this simulation reaches (the file format of `snowsim run`'s checkpoints).")
      .def_static(
          "load",
          [](const std::string& path, int threads) {
            const SavedRun saved = std::filesystem::is_directory(path) ? loadCheckpoint(path)
                                                                       : readCheckpointFile(path);
            PySimulation* made = makePySimulation(saved.scene, threads);
            made->simulation->loadState(saved.solver_state, saved.file);
            return made;
          },
          py::arg("path"), py::arg("threads") = 1,
          "A simulation from a checkpoint: a file save wrote, or a run's directory (its "
          "checkpoint.snowsim, as `snowsim resume` reads it). ValueError naming the file when it "
          "is missing, damaged, or of another snowsim version.")
      .def(
          "close",
          [](Self& self) {
            if (!self.simulation) return;
            self.live("close");
            self.simulation.reset();
          },
          "Frees the simulation's memory; any use after raises ValueError. Closing twice is "
          "allowed.")
      .def_property_readonly("closed", [](const Self& self) { return !self.simulation; })
      .def("__enter__", [](Self& self) -> Self& { return self; })
      .def("__exit__", [](Self& self, const py::args& raised) {
        // As close(): a simulation another thread is stepping raises rather than stay open
        // unsaid, unless the block is leaving on an exception, which must not be replaced.
        if (!self.simulation) return;
        if (self.busy && !raised.empty() && !raised[0].is_none()) return;
        self.live("leaving the with block");
        self.simulation.reset();
      });
}

}  // namespace snowsim
