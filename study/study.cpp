#include "study/study.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <set>

#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/simulation.h"
#include "study/metrics.h"

namespace snowsim {

namespace {

// One point of the sweep. refine halves the cell size and doubles the cells (same domain).
struct Config {
  std::string scene;                      // file stem in the scenes directory
  std::string solver = "density_hybrid";  // a label of applySolver()
  double dt = 0.001;
  int refine = 1;
  int particles_per_cell = 9;
  double duration = 0.5;
  double E0 = 0;  // MPM Young's modulus (Pa); 0: the scene's
};

// The solvers and integrators the study compares. MPM runs at the fixed dt of the sweep (no
// adaptive step), so the study sees where each integrator breaks.
void applySolver(const std::string& label, Scene& scene) {
  if (label == "density_hybrid") {
    scene.solver = SolverType::DensityHybrid;
    return;
  }
  scene.solver = SolverType::Mpm;
  // Single precision only on its own axis, whatever the scene's default (float for explicit 3D).
  scene.mpm.precision = label == "mpm_mls_float" ? MpmPrecision::Float : MpmPrecision::Double;
  // The reference: APIC with the adaptive CFL step, capped by the given dt.
  if (label == "reference_mpm_apic") {
    scene.mpm.transfer = MpmTransfer::Apic;
    return;
  }
  scene.mpm.adaptive_dt = false;
  const bool semi = label == "mpm_apic_semi" || label == "mpm_mls_semi";
  if (semi) scene.mpm.integrator = MpmIntegrator::SemiImplicit;
  // The axes beside the solvers: explicit MLS at the default adaptive step (capped by the
  // sweep's dt), with auto-sleep at its defaults, and with cracks that open in snow that fails at
  // eps_f 0.3 at any cell (a scene's own fracture strain if it has one).
  if (label == "mpm_mls_adaptive") scene.mpm.adaptive_dt = true;
  if (label == "mpm_mls_sleep") scene.mpm.auto_sleep.enabled = true;
  if (label == "mpm_mls_cracks") {
    scene.mpm.open_cracks = true;
    if (!(scene.material.fracture_strain > 0)) scene.material.fracture_strain = 0.3;
  }
  if (label == "mpm_pic_flip")
    scene.mpm.transfer = MpmTransfer::PicFlip;
  else if (label == "mpm_apic" || label == "mpm_apic_semi")
    scene.mpm.transfer = MpmTransfer::Apic;
  else if (label == "mpm_mls" || label == "mpm_mls_semi" || label == "mpm_mls_float" ||
           label == "mpm_mls_adaptive" || label == "mpm_mls_sleep" || label == "mpm_mls_cracks")
    scene.mpm.transfer = MpmTransfer::Mls;
  else
    throw InputError("study: unknown solver label '" + label + "'");
}

const std::vector<std::string> kAllSolvers = {"density_hybrid", "mpm_pic_flip",  "mpm_apic",
                                              "mpm_mls",        "mpm_apic_semi", "mpm_mls_semi"};

// quick: 21 runs in seconds, for CI (tests/study). full: the study of
// docs/study.md (the 2D scenes over cell size too; the 3D smash at one cell size, as its
// reference at half the cell size is already 14k particles). stability: the stability map (time
// step against Young's modulus, and against the hardening of a small sticky-wall smash). Each
// includes steps beyond the explicit limit and dt = 0.01, the report's Fig. 8 failure. The report's
// Fig. 6 claim (pile heights x2 > x4 > x8 at 0.5 s), scored on each x8 row.
Sweep pileClaimSweep(std::vector<double> dts, std::vector<int> particles_per_cell) {
  return {{"critical_density_x2", "critical_density_x4", "critical_density_x8"},
          {"density_hybrid"},
          std::move(dts),
          {1},
          std::move(particles_per_cell),
          0.5,
          {0},
          false};
}

}  // namespace

std::vector<Sweep> presetNamed(const std::string& name) {
  if (name == "quick")
    return {{{"snowball_drop", "column_thrown_ball"},
             {"density_hybrid", "mpm_mls", "mpm_apic_semi"},
             {0.01, 0.002, 2e-4},
             {1},
             {9},
             0.3},
            pileClaimSweep({0.001}, {9})};
  if (name == "full")
    return {{{"snowball_drop", "column_thrown_ball"},
             kAllSolvers,
             {0.05, 0.01, 0.005, 0.002, 0.001, 5e-4, 2e-4, 1e-4},
             {1, 2},
             {4, 9, 16},
             0.5},
            {{"study_smash_3d"}, kAllSolvers, {0.01, 0.005, 0.002, 0.001, 5e-4}, {1}, {4, 9}, 0.3},
            pileClaimSweep({0.01, 0.005, 0.002, 0.001, 5e-4, 2e-4}, {4, 9, 16})};
  if (name == "stability")
    return {{{"column_thrown_ball"},
             {"density_hybrid", "mpm_mls", "mpm_apic_semi"},
             {0.02, 0.01, 0.005, 0.002, 0.001, 5e-4, 2e-4, 1e-4, 5e-5},
             {1},
             {9},
             0.3,
             {1.4e4, 1.4e5, 1.4e6},
             false},
            // The hardened states of the flagship smash, in small: the paper's unbounded hardening
            // and the flagship scenes' bounds, the default adaptive step beside the fixed ones.
            {{"study_smash_sticky_3d", "study_smash_sticky_bounded_3d"},
             {"mpm_mls", "mpm_mls_adaptive", "mpm_apic_semi"},
             {2e-3, 1e-3, 5e-4, 4e-4, 3e-4, 2e-4, 1e-4, 5e-5},
             {1},
             {4},  // 2 x 2 in 2D: 2 x 2 x 2, the scenes' own 8 per cell
             0.15,
             {0},
             false}};
  if (name == "axes") {  // precision, step policy, auto-sleep and cracks against the reference
    const std::vector<std::string> axes = {"mpm_mls", "mpm_mls_float", "mpm_mls_adaptive",
                                           "mpm_mls_sleep", "mpm_mls_cracks"};
    return {{{"snowball_drop", "column_thrown_ball"}, axes, {0.002, 5e-4, 2e-4}, {1}, {9}, 0.5},
            {{"study_smash_3d"}, axes, {0.002, 5e-4}, {1}, {4}, 0.3}};
  }
  throw InputError("--preset: unknown preset '" + name +
                   "'; allowed: quick, full, stability, axes");
}

namespace {

// The reference: the most accurate solver (APIC MPM, its step at the CFL limit and at most a
// quarter of the sweep's finest dt) at half the finest cell size and the most particles per cell.
Config referenceFor(const std::string& scene, const Sweep& p) {
  Config c;
  c.scene = scene;
  c.solver = "reference_mpm_apic";
  c.dt = *std::min_element(p.dts.begin(), p.dts.end()) / 4;
  c.refine = 2 * *std::max_element(p.refines.begin(), p.refines.end());
  c.particles_per_cell =
      *std::max_element(p.particles_per_cell.begin(), p.particles_per_cell.end());
  c.duration = p.duration;
  return c;
}

// The build is identified by a hash of the executable itself: a rebuilt binary remeasures.
std::string buildId() {
  std::ifstream in("/proc/self/exe", std::ios::binary);
  uint64_t hash = 1469598103934665603ull;  // FNV-1a 64
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      hash ^= static_cast<unsigned char>(buffer[i]);
      hash *= 1099511628211ull;
    }
    if (!in) break;
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

std::string format(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

std::string keyOf(const std::string& build, const Config& c) {
  return build + "," + c.scene + "," + c.solver + "," + format(c.dt) + "," +
         std::to_string(c.refine) + "," + std::to_string(c.particles_per_cell) + "," +
         format(c.duration) + "," + format(c.E0);
}

// Particles per cell in the scene's dimension: a 3D scene takes the cube nearest the 2D count.
int particlesPerCell(int count_2d, int dimension) {
  if (dimension == 2) return count_2d;
  const int per_axis = std::max(1, static_cast<int>(std::lround(std::sqrt(count_2d))));
  return per_axis * per_axis * per_axis;
}

struct Outcome {
  std::string status = "finished";  // finished | diverged | nan | escaped | tunnelled
  std::string message;
  double wall = 0;
  long steps = 0;
  int particles = 0;
  double cell_size = 0;
  Frames frames;
};

// The study runs each scene with every solver, APIC, PIC/FLIP and the semi-implicit one
// included: a scene's cracks or damper would stop those runs, so it is refused when read.
void refuseWhatEverySolverCannotRun(const Scene& scene, const std::string& file) {
  if (scene.mpm.open_cracks || scene.material.viscosity > 0)
    throw InputError(file + ": " +
                     (scene.mpm.open_cracks ? "mpm.open_cracks (cracks that open)"
                                            : "material.viscosity (a damper)") +
                     ", of material.preset \"" + scene.material_preset +
                     "\" or the scene, is more than every solver of the study runs (its "
                     "mpm_mls_cracks axis opens cracks itself); name material.preset \"paper\" "
                     "and leave both out");
}

// The scene files of a study, each read and parsed once.
class Scenes {
 public:
  explicit Scenes(std::string dir) : dir_(std::move(dir)) {}
  const Scene& operator[](const std::string& name) {
    auto it = scenes_.find(name);
    if (it == scenes_.end()) {
      const std::string file = dir_ + "/" + name + ".json";
      it = scenes_.emplace(name, loadScene(file)).first;
      refuseWhatEverySolverCannotRun(it->second, file);
    }
    return it->second;
  }

 private:
  std::string dir_;
  std::map<std::string, Scene> scenes_;
};

// The scene file with the configuration's settings.
Scene configured(const Scene& base, const Config& c) {
  Scene scene = base;
  applySolver(c.solver, scene);
  scene.dt = c.dt;
  scene.duration = c.duration;
  // Frames no closer than dt: the driver never steps past a frame, so a step larger than the
  // frame interval would silently shrink to it.
  scene.fps = std::min(base.fps, 1 / c.dt);
  setParticlesPerCell(scene, particlesPerCell(c.particles_per_cell, base.authored_dimension));
  refineGrid(scene, c.refine);
  if (c.E0 > 0) scene.material.E0 = c.E0;
  return scene;
}

Outcome simulate(const StudySettings& settings, const Scene& base, const Config& c) {
  const Scene scene = configured(base, c);

  Outcome out;
  out.cell_size = scene.cell_size;
  const auto start = std::chrono::steady_clock::now();
  auto simulation = makeSimulation(scene, settings.threads);
  out.particles = simulation->particleCount();
  try {
    for (int frame = 0; frame <= scene.frameCount(); ++frame) {
      simulation->advanceTo(std::min(scene.duration, frame / scene.fps));
      out.frames.push_back(simulation->snapshot(frame));
      if (anyNonFinite(out.frames.back())) {
        out.status = "nan";
        out.message = "non-finite particle at t = " + format(simulation->time());
        break;
      }
    }
  } catch (const SimulationError& e) {
    out.status = "diverged";
    out.message = e.what();
  }
  out.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.steps = simulation->steps();
  if (out.status != "finished") return out;
  const Vec3 e = scene.extent();
  if (anyOutside(out.frames.back(), {e[0], e[1], e[2]}, scene.cell_size)) out.status = "escaped";
  return out;
}

// The frames of both runs at the times they share (a run with a step longer than the scene's
// frame interval records fewer frames; see simulate()).
std::pair<Frames, Frames> atCommonTimes(const Frames& run, const Frames& reference) {
  std::pair<Frames, Frames> common;
  size_t r = 0;
  for (const Snapshot& s : run) {
    while (r < reference.size() && reference[r].time < s.time - 1e-9) ++r;
    if (r < reference.size() && std::abs(reference[r].time - s.time) <= 1e-9) {
      common.first.push_back(s);
      common.second.push_back(reference[r]);
    }
  }
  return common;
}

// The tower's left edge in a thrown-ball scene (a body named "column" and one named "ball");
// -1 for any other scene.
double towerLeftEdge(const Scene& scene) {
  double edge = -1;
  bool ball = false;
  for (const Body& b : scene.bodies) {
    if (b.name == "column") edge = b.center[0] - b.size[0] / 2;
    ball = ball || b.name == "ball";
  }
  return ball ? edge : -1;
}

const char* kHeader =
    "build,scene,solver,dt,refine,particles_per_cell,duration,E0,cell_size,status,wall_s,steps,"
    "particles,err_density,err_height_m,err_com_m,free_fall_err_m,ball_past_tower_m,"
    "pile_height_m,claim,message";

std::set<std::string> measuredKeys(const std::string& csv) {
  std::set<std::string> keys;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    // The key is the first eight fields.
    size_t pos = 0;
    for (int field = 0; field < 8 && pos != std::string::npos; ++field)
      pos = line.find(',', pos + (field ? 1 : 0));
    if (pos != std::string::npos) keys.insert(line.substr(0, pos));
  }
  return keys;
}

// The report's Fig. 6 claim takes three runs: the final piles of critical density x2 and x4 are
// kept, per configuration, until the x8 run of the same configuration scores x2 > x4 > x8.
class PileClaim {
 public:
  // "pass" or "fail" for the x8 run of a configuration whose x2 and x4 runs were seen; else "".
  std::string score(const Config& c, const Snapshot& last) {
    const std::string family = "critical_density_x";
    if (c.scene.rfind(family, 0) != 0) return "";
    const std::string multiplier = c.scene.substr(family.size());
    const std::string key = c.solver + "," + format(c.dt) + "," + std::to_string(c.refine) + "," +
                            std::to_string(c.particles_per_cell) + "," + format(c.duration) + "," +
                            format(c.E0);
    Piles& piles = piles_[key];
    if (multiplier == "2") piles.x2 = last;
    if (multiplier == "4") piles.x4 = last;
    if (multiplier != "8" || !piles.x2 || !piles.x4) return "";
    return pileHeightsOrdered(*piles.x2, *piles.x4, last) ? "pass" : "fail";
  }

 private:
  struct Piles {
    std::optional<Snapshot> x2, x4;
  };
  std::map<std::string, Piles> piles_;
};

std::string csvField(std::string text) {
  for (char& ch : text)
    if (ch == ',' || ch == '\n' || ch == '"') ch = ';';
  return text;
}

// The runs of one sweep in the order a study runs them and writes their rows.
std::vector<Config> configsOf(const Sweep& sweep) {
  std::vector<Config> configs;
  for (const std::string& scene : sweep.scenes)
    for (const std::string& solver : sweep.solvers)
      for (double E0 : sweep.E0s)
        for (double dt : sweep.dts)
          for (int refine : sweep.refines)
            for (int ppc : sweep.particles_per_cell)
              configs.push_back({scene, solver, dt, refine, ppc, sweep.duration, E0});
  return configs;
}

}  // namespace

Shard parseShard(const std::string& text) {
  const std::string allowed = "; allowed: i/n with whole numbers 1 <= i <= n, e.g. 2/8";
  const size_t slash = text.find('/');
  int index = 0, count = 0;
  size_t index_end = 0, count_end = 0;
  try {
    if (slash == std::string::npos) throw std::invalid_argument("no slash");
    index = std::stoi(text.substr(0, slash), &index_end);
    count = std::stoi(text.substr(slash + 1), &count_end);
  } catch (const std::exception&) {
    throw InputError("--shard: '" + text + "' is not i/n" + allowed);
  }
  if (index_end != slash || count_end != text.size() - slash - 1)
    throw InputError("--shard: '" + text + "' is not i/n" + allowed);
  if (count < 1 || index < 1 || index > count)
    throw InputError("--shard: " + text + " is out of range" + allowed);
  return {index, count};
}

namespace {

// A run's rough cost, to balance the shards: its steps times its particles (the particles per
// cell times the refined grid's cells in the scene's dimension), ten times that for the
// semi-implicit solve (docs/study.md measures 5-37x the explicit run).
double estimatedCost(const Config& c, const Scene& base) {
  const double semi_implicit = c.solver.ends_with("_semi") ? 10 : 1;
  return c.duration / c.dt * particlesPerCell(c.particles_per_cell, base.authored_dimension) *
         std::pow(c.refine, base.dimension) * semi_implicit;
}

// The keys (without the build) of the runs a shard owns. Each run, the costliest first, goes to
// the shard with the least estimated cost so far: dealing them round-robin in the study's order
// would give one shard every run of the smallest dt whenever n divides the inner lists' lengths.
// The Fig. 6 claim is scored on the x8 run from the x2 and x4 runs of the same settings, so those
// three go to one shard together. Ties go to the earlier run and the lower shard: every shard
// computes the same split.
std::set<std::string> keysOfShard(const std::vector<Sweep>& preset, const Shard& shard,
                                  Scenes& scenes) {
  const std::string pile_family = "critical_density_x";
  struct Unit {
    double cost = 0;
    std::vector<std::string> keys;
  };
  std::map<std::string, int> unit_of_settings;
  std::vector<Unit> units;
  for (const Sweep& sweep : preset)
    for (const Config& c : configsOf(sweep)) {
      Config settings = c;
      if (settings.scene.starts_with(pile_family)) settings.scene = pile_family;
      const auto [it, added] =
          unit_of_settings.emplace(keyOf("", settings), static_cast<int>(units.size()));
      if (added) units.emplace_back();
      units[it->second].cost += estimatedCost(c, scenes[c.scene]);
      units[it->second].keys.push_back(keyOf("", c));
    }
  std::vector<int> costliest_first(units.size());
  std::iota(costliest_first.begin(), costliest_first.end(), 0);
  std::stable_sort(costliest_first.begin(), costliest_first.end(),
                   [&](int a, int b) { return units[a].cost > units[b].cost; });
  std::vector<double> load(shard.count, 0);
  std::set<std::string> keys;
  for (const int u : costliest_first) {
    const auto least = std::min_element(load.begin(), load.end()) - load.begin();
    load[least] += units[u].cost;
    if (least == shard.index - 1) keys.insert(units[u].keys.begin(), units[u].keys.end());
  }
  return keys;
}

// Runs the configurations of one sweep that this build has not measured yet and that belong to
// this shard (all, when `owned` is null), appending a CSV row per run; returns how many it ran
// and adds to `skipped` those already measured.
int runSweep(const StudySettings& settings, const Sweep& sweep, const std::string& build,
             const std::set<std::string>& done, const std::set<std::string>* owned, Scenes& scenes,
             std::ofstream& csv, int& skipped) {
  int measured = 0;
  PileClaim pile_claim;
  const std::vector<Config> configs = configsOf(sweep);
  for (const std::string& scene : sweep.scenes) {
    std::vector<Config> todo;
    for (const Config& c : configs) {
      if (c.scene != scene || (owned && !owned->count(keyOf("", c)))) continue;
      if (done.count(keyOf(build, c))) {
        ++skipped;
        continue;
      }
      todo.push_back(c);
    }
    if (todo.empty()) continue;

    const Scene& base = scenes[scene];
    Outcome reference;
    if (sweep.errors) {
      const Config ref_config = referenceFor(scene, sweep);
      std::fprintf(stderr, "study: %s reference (%s, dt <= %s, cell/%d, %d per cell)\n",
                   scene.c_str(), ref_config.solver.c_str(), format(ref_config.dt).c_str(),
                   ref_config.refine, ref_config.particles_per_cell);
      reference = simulate(settings, base, ref_config);
      if (reference.status != "finished")
        throw SimulationError("study: the reference run of " + scene + " " + reference.status +
                              ": " + reference.message);
    }
    const Vec3 extent = base.extent();
    const FieldGrid field{base.dimension, {extent[0], extent[1], extent[2]}, 64};
    const double tower = towerLeftEdge(base);

    for (const Config& c : todo) {
      const Outcome run = simulate(settings, base, c);
      std::string errors = ",,,,";
      std::string past_tower, pile_height, claim;
      std::string status = run.status;
      const bool usable = run.status == "finished" || run.status == "escaped";
      if (tower > 0 && usable) {
        const double past = ballPastTower(run.frames, tower);
        past_tower = format(past);
        claim = past < 0 ? "pass" : "fail";  // the ball stays outside the tower (Fig. 2)
        if (past > 0 && status == "finished") status = "tunnelled";  // through the tower
      }
      if (usable) {
        pile_height = format(pileHeight(run.frames.back()));
        if (claim.empty()) claim = pile_claim.score(c, run.frames.back());
      }
      if (usable && sweep.errors) {
        const bool falls_freely = tower < 0 && base.dimension == 2;
        const auto [frames, ref] = atCommonTimes(run.frames, reference.frames);
        errors = format(densityFieldError(frames, ref, field)) + "," +
                 format(heightProfileError(frames, ref, field)) + "," +
                 format(centreOfMassPathError(frames, ref)) + "," +
                 (falls_freely ? format(freeFallError(run.frames, {0, -9.81, 0}, 0.08)) : "") + ",";
      }
      csv << keyOf(build, c) << "," << format(run.cell_size) << "," << status << ","
          << format(run.wall) << "," << run.steps << "," << run.particles << "," << errors
          << past_tower << "," << pile_height << "," << claim << "," << csvField(run.message)
          << "\n";
      csv.flush();
      ++measured;
      std::fprintf(stderr, "study: %s %s dt %s E0 %s cell/%d ppc %d: %s, %.2f s\n", scene.c_str(),
                   c.solver.c_str(), format(c.dt).c_str(), format(c.E0).c_str(), c.refine,
                   c.particles_per_cell, status.c_str(), run.wall);
    }
  }
  return measured;
}

}  // namespace

StudyTally runStudy(const std::vector<Sweep>& preset, const StudySettings& settings) {
  Scenes scenes(settings.scenes);
  std::optional<std::set<std::string>> owned;
  if (settings.shard) owned = keysOfShard(preset, *settings.shard, scenes);
  // Every scene of the preset is read before anything is written: a missing or broken one
  // stops the study with no CSV begun.
  for (const Sweep& sweep : preset)
    for (const std::string& name : sweep.scenes) scenes[name];
  StudyTally tally;
  tally.build = buildId();
  const bool existed = std::filesystem::exists(settings.out);
  const std::set<std::string> done = measuredKeys(settings.out);
  std::error_code error;
  if (!std::filesystem::path(settings.out).parent_path().empty())
    std::filesystem::create_directories(std::filesystem::path(settings.out).parent_path(), error);
  std::ofstream csv;
  if (!error) csv.open(settings.out, std::ios::app);
  if (error || !csv) throw InputError("--out: cannot write " + settings.out);
  if (!existed) csv << kHeader << "\n";

  for (const Sweep& sweep : preset)
    tally.measured += runSweep(settings, sweep, tally.build, done, owned ? &*owned : nullptr,
                               scenes, csv, tally.skipped);
  return tally;
}

namespace {

// A shard's CSV: its rows by key (the first eight fields), each as written.
struct ShardRows {
  std::map<std::string, std::string> row_of_key;
  int other_builds = 0;  // rows measured by another build, left out
};

ShardRows readShard(const std::string& path, const std::string& build) {
  std::ifstream in(path);
  if (!in) throw InputError("--merge: cannot read " + path);
  std::string line;
  if (!std::getline(in, line) || line != kHeader)
    throw InputError("--merge: " + path + " is not a study CSV (its first line is not the header)");
  ShardRows rows;
  for (int number = 2; std::getline(in, line); ++number) {
    size_t end = 0;
    for (int field = 0; field < 8 && end != std::string::npos; ++field)
      end = line.find(',', end + (field ? 1 : 0));
    if (end == std::string::npos)
      throw InputError("--merge: " + path + " line " + std::to_string(number) +
                       " has fewer than the header's fields");
    const std::string key = line.substr(0, end);
    if (key.substr(0, key.find(',')) != build) {
      ++rows.other_builds;
      continue;
    }
    if (!rows.row_of_key.emplace(key, line).second)
      throw InputError("--merge: " + path + " holds the run " + key + " twice");
  }
  return rows;
}

}  // namespace

size_t mergeShards(const std::string& preset, const std::vector<std::string>& shard_csvs,
                   const std::string& out) {
  if (std::filesystem::exists(out))
    throw InputError("--merge: " + out +
                     " exists; the merge writes a new file (remove it or give another -o)");
  const std::string build = buildId();
  std::map<std::string, std::pair<std::string, std::string>> row_and_file_of_key;
  int other_builds = 0;
  for (const std::string& path : shard_csvs) {
    const ShardRows rows = readShard(path, build);
    other_builds += rows.other_builds;
    for (const auto& [key, row] : rows.row_of_key) {
      const auto [it, added] = row_and_file_of_key.emplace(key, std::pair{row, path});
      if (!added)
        throw InputError("--merge: the run " + key + " is in both " + it->second.second + " and " +
                         path + "; each run belongs to one shard");
    }
  }
  std::set<std::string> preset_keys;
  std::string text = std::string(kHeader) + "\n";
  std::vector<std::string> missing;
  for (const Sweep& sweep : presetNamed(preset))
    for (const Config& c : configsOf(sweep)) {
      const std::string key = keyOf(build, c);
      preset_keys.insert(key);
      const auto it = row_and_file_of_key.find(key);
      if (it == row_and_file_of_key.end())
        missing.push_back(key);
      else
        text += it->second.first + "\n";
    }
  for (const auto& [key, row_and_file] : row_and_file_of_key)
    if (!preset_keys.count(key))
      throw InputError("--merge: " + row_and_file.second + " holds the run " + key +
                       ", which preset " + preset + " does not have");
  if (!missing.empty())
    throw InputError("--merge: " + std::to_string(missing.size()) + " runs of preset " + preset +
                     " are in no shard (first: " + missing.front() + ")" +
                     (other_builds ? "; " + std::to_string(other_builds) +
                                         " rows of other builds than " + build + " were left out"
                                   : std::string()));
  writeFileAtomically(out, text);
  return preset_keys.size();
}

}  // namespace snowsim
