# The Python module against the command line: the same particles and images, the documented
# arrays, errors naming the field, checkpoints, Ctrl-C.
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

from conftest import BINARY, read_ply, scene_path


def run_frames(snowsim, simulation):
    """Steps to each frame's time as `snowsim run` does (app/run_command.cpp)."""
    scene = simulation.scene
    for frame in range(1, scene.frame_count + 1):
        simulation.advance_to(min(scene.duration, frame / scene.fps))


@pytest.mark.parametrize(
    "name, sets, threads",
    [
        ("mpm_snowball_wall", {"time.duration": 0.1, "bodies[0].radius": 0.03}, 1),
        ("snowball_drop", {"time.duration": 0.1}, 1),
        ("snowball_drop", {"solver": "mpm", "time.duration": 0.06}, 2),
    ],
)
def test_same_particles_and_image_as_the_command_line(snowsim, tmp_path, name, sets, threads):
    out = tmp_path / "run"
    args = [BINARY, "run", scene_path(name), "-o", str(out), "--no-mp4", "--threads", "2",
            "--width", "160", "--height", "120", "--color-by", "speed"]
    for field, value in sets.items():
        args += ["--set", f"{field}={value}"]
    subprocess.run(args, check=True, capture_output=True)

    scene = snowsim.load_scene(scene_path(name), sets)
    simulation = snowsim.Simulation(scene, threads=threads)
    run_frames(snowsim, simulation)
    last = f"frame_{scene.frame_count:05d}"
    frame = read_ply(out / f"{last}.ply")
    assert np.array_equal(frame["id"], np.arange(simulation.particle_count))
    d = scene.dimension
    positions, velocities = simulation.positions(), simulation.velocities()
    for a in range(d):
        assert np.array_equal(frame["xyz"[a]], positions[:, a].astype(np.float32))
        assert np.array_equal(frame["v" + "xyz"[a]], velocities[:, a].astype(np.float32))
    assert np.array_equal(frame["mass"], simulation.masses().astype(np.float32))
    if scene.solver == "mpm":
        assert np.array_equal(frame["plastic_j"], simulation.plastic_j().astype(np.float32))

    image = snowsim.render(simulation, 160, 120, color_by="speed")
    figures = snowsim.diff(str(out / f"{last}.png"), image)
    assert figures["compared"] == 160 * 120
    assert figures["differing"] == 0 and figures["largest"] == 0


def test_arrays_have_the_documented_shapes_and_are_copies(snowsim):
    scene = snowsim.load_scene(scene_path("mpm_snowball_wall"), {"bodies.0.radius": 0.03})
    simulation = snowsim.Simulation(scene)
    simulation.step()
    n = simulation.particle_count
    assert simulation.step_count == 1 and 0 < simulation.time <= scene.dt
    for array, shape in [(simulation.positions(), (n, 3)), (simulation.velocities(), (n, 3)),
                         (simulation.masses(), (n,)), (simulation.plastic_j(), (n,)),
                         (simulation.deformation_gradients(), (n, 3, 3))]:
        assert array.dtype == np.float64 and array.shape == shape
    nodes = tuple(c + 1 + 4 for c in scene.to_dict()["grid"]["cells"])
    grid_mass = simulation.grid_masses()
    assert grid_mass.shape == nodes and simulation.grid_velocities().shape == nodes + (3,)
    # The particles' mass, spread by weights that sum to one, is all on the grid.
    assert grid_mass.sum() == pytest.approx(simulation.masses().sum(), rel=1e-7)
    # The ghost layers beyond the walls hold none.
    assert grid_mass[:2].sum() == 0 and grid_mass[-2:].sum() == 0

    positions = simulation.positions()
    positions[:] = 0
    gradients = simulation.deformation_gradients()
    gradients[:] = np.nan
    assert simulation.positions().any() and np.isfinite(simulation.deformation_gradients()).all()
    before = simulation.positions()
    simulation.step()
    assert not np.array_equal(before, simulation.positions())


def test_the_report_method_has_no_mpm_state(snowsim):
    simulation = snowsim.Simulation(snowsim.load_scene(scene_path("snowball_drop")))
    assert simulation.positions().shape == (simulation.particle_count, 2)
    for method in ("plastic_j", "deformation_gradients", "grid_masses", "grid_velocities"):
        with pytest.raises(ValueError, match=f"{method}: .*MPM only"):
            getattr(simulation, method)()


def test_bad_input_raises_naming_the_field(snowsim, tmp_path):
    path = scene_path("snowball_drop")
    with pytest.raises(ValueError, match="no_such_field"):
        snowsim.load_scene(path, {"time.no_such_field": 1})
    with pytest.raises(ValueError, match="radius"):
        snowsim.load_scene(path, {"bodies.0.radius": -0.01})
    with pytest.raises(ValueError, match=r"bodies.0.radius: nan"):
        snowsim.load_scene(path, {"bodies.0.radius": float("nan")})
    with pytest.raises(TypeError, match="time.dt: a object"):
        snowsim.load_scene(path, {"time.dt": object()})
    with pytest.raises(TypeError, match="overrides"):
        snowsim.load_scene(path, ["time.dt=0.01"])
    with pytest.raises(ValueError, match="solver"):
        snowsim.load_scene(path, {"solver": "lattice_boltzmann"})
    with pytest.raises(ValueError, match="missing.json"):
        snowsim.load_scene(str(tmp_path / "missing.json"))

    # The message is the command line's for the same --set.
    with pytest.raises(ValueError) as raised:
        snowsim.load_scene(path, {"time.dt": "fast"})
    cli = subprocess.run([BINARY, "run", path, "-o", str(tmp_path / "o"), "--set", "time.dt=fast"],
                         capture_output=True, text=True)
    assert cli.returncode == 2 and str(raised.value) in cli.stderr

    simulation = snowsim.Simulation(snowsim.load_scene(path))
    with pytest.raises(ValueError, match="advance_to: t is nan"):
        simulation.advance_to(float("nan"))
    simulation.advance_to(0.01)
    with pytest.raises(ValueError, match="before the simulation's time"):
        simulation.advance_to(0.005)
    with pytest.raises(TypeError):
        simulation.advance_to("soon")
    with pytest.raises(ValueError, match="threads: 0"):
        snowsim.Simulation(snowsim.load_scene(path), threads=0)
    # A grid too large for its int index is refused before anything of it is allocated.
    huge = snowsim.load_scene(scene_path("mpm_snowball_wall"), {"grid.cells": [4096, 4096, 4096]})
    with pytest.raises(ValueError, match="grid.cells make .* grid nodes"):
        snowsim.Simulation(huge)
    with pytest.raises(ValueError, match="--look"):
        snowsim.render(simulation, 64, 48, look="painterly")
    with pytest.raises(ValueError, match="camera-wobble"):
        snowsim.render(simulation, 64, 48, camera_wobble=1)
    with pytest.raises(ValueError, match="--width"):
        snowsim.render(simulation, 4, 48)
    with pytest.raises(ValueError, match="sphere_radius: .*nan.* is not a finite number"):
        snowsim.render(simulation, 64, 48, sphere_radius=np.float32("nan"))
    with pytest.raises(ValueError, match="camera_eye: .*inf.* is not a finite number"):
        snowsim.render(simulation, 64, 48, camera_eye=np.array([0.1, np.inf, 0.2], np.float32))
    with pytest.raises(TypeError, match="sphere_radius: True is not a value"):
        snowsim.render(simulation, 64, 48, sphere_radius=True)
    with pytest.raises(TypeError, match="camera_eye: True is not a number"):
        snowsim.render(simulation, 64, 48, camera_eye=(True, 0.2, 0.3))
    assert snowsim.render(simulation, 64, 48, sphere_radius=np.float32(0.01)).shape == (48, 64, 3)
    with pytest.raises(ValueError, match=r"shape is \(height, width, 3 or 4\)"):
        snowsim.write_png(str(tmp_path / "x.png"), np.zeros((4, 4), np.uint8))

    simulation.close()
    assert simulation.closed
    for use in (lambda: simulation.step(), lambda: simulation.time, lambda: simulation.positions(),
                lambda: simulation.save(str(tmp_path / "c")), lambda: snowsim.render(simulation)):
        with pytest.raises(ValueError, match="closed"):
            use()


def test_a_saved_simulation_continues_to_the_same_particles(snowsim, tmp_path):
    scene = snowsim.load_scene(scene_path("mpm_snowball_wall"), {"bodies.0.radius": 0.03})
    uninterrupted = snowsim.Simulation(scene)
    uninterrupted.advance_to(0.02)
    checkpoint = str(tmp_path / "state.snowsim")
    uninterrupted.save(checkpoint)
    saved_steps = uninterrupted.step_count
    uninterrupted.advance_to(0.05)

    resumed = snowsim.Simulation.load(checkpoint, threads=2)
    assert resumed.time == pytest.approx(0.02) and resumed.step_count == saved_steps
    resumed.advance_to(0.05)
    assert resumed.step_count == uninterrupted.step_count
    for method in ("positions", "velocities", "plastic_j", "deformation_gradients"):
        assert np.array_equal(getattr(resumed, method)(), getattr(uninterrupted, method)()), method

    with open(checkpoint, "r+b") as f:
        f.truncate(os.path.getsize(checkpoint) // 2)
    with pytest.raises(ValueError, match="state.snowsim"):
        snowsim.Simulation.load(checkpoint)


CHILD = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    import snowsim
    scene = snowsim.load_scene(sys.argv[1])
    simulation = snowsim.Simulation(scene)
    simulation.step()
    print("stepping", flush=True)
    try:
        simulation.advance_to(1e6)
        print("not interrupted")
    except KeyboardInterrupt:
        steps = simulation.step_count
        again = snowsim.Simulation(scene)
        for _ in range(steps):
            again.step()
        same = (again.time == simulation.time and
                np.array_equal(again.positions(), simulation.positions()))
        print("interrupted", steps, "same" if same else "different", flush=True)
    """
)


def test_ctrl_c_stops_at_the_end_of_a_step(tmp_path):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    child = subprocess.Popen([sys.executable, str(script), scene_path("mpm_snowball_wall")],
                             stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "stepping"
    time.sleep(0.5)
    child.send_signal(signal.SIGINT)
    sent = time.monotonic()
    out, _ = child.communicate(timeout=60)
    words = out.split()
    assert words[0] == "interrupted" and int(words[1]) > 1 and words[2] == "same", out
    # The stop came at the end of the step under way, not at the target.
    assert time.monotonic() - sent < 30


def test_a_run_directory_checkpoint_loads_and_steps_as_resume_does(snowsim, tmp_path):
    out = tmp_path / "run"
    run = subprocess.Popen([BINARY, "run", scene_path("mpm_snowball_wall"), "-o", str(out),
                            "--no-png", "--no-mp4", "--threads", "1", "--checkpoint-every", "1",
                            "--set", "time.duration=1"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # The first checkpoint follows frame 0, before any step: stop once frame 1 is written, so that
    # the checkpoint of the stop holds steps.
    checkpoint, first = out / "checkpoint.snowsim", out / "frame_00001.ply"
    while not (checkpoint.exists() and first.exists()) and run.poll() is None:
        time.sleep(0.01)
    run.send_signal(signal.SIGTERM)
    assert run.wait(timeout=60) == 143, "the run ended before it was stopped"

    simulation = snowsim.Simulation.load(str(out))
    scene = simulation.scene
    assert 0 < simulation.time < scene.duration
    subprocess.run([BINARY, "resume", str(out)], check=True, capture_output=True)
    for frame in range(1, scene.frame_count + 1):
        if frame / scene.fps > simulation.time + 1e-12:
            simulation.advance_to(min(scene.duration, frame / scene.fps))
    last = read_ply(out / f"frame_{scene.frame_count:05d}.ply")
    positions = simulation.positions().astype(np.float32)
    for a in range(3):
        assert np.array_equal(last["xyz"[a]], positions[:, a])


def test_leaving_a_with_block_while_another_thread_steps_raises(snowsim):
    simulation = snowsim.Simulation(snowsim.load_scene(scene_path("mpm_snowball_wall")))
    stepping = threading.Thread(target=simulation.advance_to, args=(0.5,))
    with pytest.raises(ValueError, match="another thread is stepping"):
        with simulation:
            stepping.start()
            while stepping.is_alive():  # until the other thread holds it
                try:
                    simulation.time
                except ValueError:
                    break
    stepping.join()
    assert not simulation.closed, "closed under the stepping thread"
    simulation.close()
