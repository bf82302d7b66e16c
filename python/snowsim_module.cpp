// The snowsim Python module: scenes, simulations, images. Errors become Python's: bad input a
// ValueError (TypeError for a value of the wrong type), a diverged simulation
// snowsim.SimulationError.
#include <cmath>
#include <string>
#include <vector>

#include <pybind11/stl.h>
#include <nlohmann/json.hpp>

#include "python/bindings.h"
#include "sim/core/errors.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/resolve_scene.h"

namespace snowsim {

namespace {

// A Python value as the JSON of a --set value; TypeError or ValueError naming the field.
nlohmann::json overrideValue(const py::handle& value, const std::string& field) {
  if (value.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::int_>(value)) return value.cast<long long>();
  if (py::isinstance<py::float_>(value)) {
    const double x = value.cast<double>();
    if (!std::isfinite(x))
      throw py::value_error("overrides: " + field + ": " + py::repr(value).cast<std::string>() +
                            " is not a number a scene holds (finite numbers only)");
    return x;
  }
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    nlohmann::json list = nlohmann::json::array();
    for (const py::handle& item : value) list.push_back(overrideValue(item, field));
    return list;
  }
  if (py::isinstance<py::dict>(value)) {
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [key, item] : value.cast<py::dict>()) {
      const std::string name = py::str(key).cast<std::string>();
      object[name] = overrideValue(item, field + "." + name);
    }
    return object;
  }
  throw py::type_error("overrides: " + field + ": a " +
                       py::str(value.get_type().attr("__name__")).cast<std::string>() +
                       " is not a scene value (bool, int, float, str, list, dict or None)");
}

PyScene loadPyScene(const std::string& path, const py::object& overrides,
                    const std::string& quality, double scale) {
  SceneOverrides resolved{{}, quality, scale};
  if (!overrides.is_none()) {
    if (!py::isinstance<py::dict>(overrides))
      throw py::type_error(
          "overrides: a dict of field names and values, e.g. "
          "{\"bodies.0.radius\": 0.05}");
    for (const auto& [key, value] : overrides.cast<py::dict>()) {
      if (!py::isinstance<py::str>(key))
        throw py::type_error("overrides: the field names are str, e.g. \"bodies.0.radius\"; " +
                             py::repr(key).cast<std::string>() + " is not");
      const std::string field = key.cast<std::string>();
      // A string that is not JSON goes as the command line gives it, so that a message quoting
      // the assignment quotes what --set would.
      const bool plain =
          py::isinstance<py::str>(value) && !nlohmann::json::accept(value.cast<std::string>());
      resolved.assignments.push_back(
          field + "=" + (plain ? value.cast<std::string>() : overrideValue(value, field).dump()));
    }
  }
  if (!std::isfinite(scale) || scale <= 0)
    throw py::value_error("scale: " + std::to_string(scale) + " is not a resolution factor (> 0)");
  return {resolveScene(path, resolved)};
}

py::object sceneDict(const Scene& scene) {
  return py::module_::import("json").attr("loads")(sceneToJson(scene).dump());
}

}  // namespace

}  // namespace snowsim

PYBIND11_MODULE(snowsim, m) {
  using namespace snowsim;
  m.doc() =
      "snowsim: MPM snow and the report's hybrid method, simulated and rendered "
      "(docs/python.md)";
  static py::exception<SimulationError> simulation_error(m, "SimulationError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr e) {
    try {
      if (e) std::rethrow_exception(e);
    } catch (const InputError& error) {
      PyErr_SetString(PyExc_ValueError, error.what());
    } catch (const SimulationError& error) {
      simulation_error(error.what());
    }
  });

  py::class_<PyScene>(m, "Scene", "A scene file as loaded, every override resolved")
      .def_property_readonly("file", [](const PyScene& s) { return s.scene.file; })
      .def_property_readonly("dimension", [](const PyScene& s) { return s.scene.dimension; })
      .def_property_readonly("solver",
                             [](const PyScene& s) {
                               return s.scene.solver == SolverType::Mpm ? "mpm" : "density_hybrid";
                             })
      .def_property_readonly(
          "duration", [](const PyScene& s) { return s.scene.duration; },
          "The scene's simulated time (s)")
      .def_property_readonly(
          "fps", [](const PyScene& s) { return s.scene.fps; }, "Frames per simulated second")
      .def_property_readonly(
          "frame_count", [](const PyScene& s) { return s.scene.frameCount(); },
          "Frames after the initial one")
      .def_property_readonly(
          "dt", [](const PyScene& s) { return s.scene.dt; }, "The largest time step (s)")
      .def_property_readonly(
          "cell_size", [](const PyScene& s) { return s.scene.cell_size; },
          "The grid's cell size h (m)")
      .def(
          "to_dict", [](const PyScene& s) { return sceneDict(s.scene); },
          "The scene as run.json records it (resolved_scene), as a dict")
      .def("__repr__", [](const PyScene& s) {
        return "<snowsim.Scene " + s.scene.file + ", " + std::to_string(s.scene.dimension) + "D>";
      });

  m.def("load_scene", &loadPyScene, py::arg("path"), py::arg("overrides") = py::none(),
        py::arg("quality") = "", py::arg("scale") = 1.0,
        "Reads a scene file as `snowsim run` does. overrides: a dict of --set's fields and "
        "values, {\"solver\": \"mpm\", \"bodies.0.radius\": 0.05} (or \"bodies[0].radius\"), "
        "applied in order; quality: \"draft\", \"figure\" or \"reference\" (--quality); scale: "
        "--scale. Raises ValueError naming the file and field.");

  bindSnapshot(m);  // first: Simulation.snapshot's signature names it
  bindSimulation(m);
  bindRender(m);
}
