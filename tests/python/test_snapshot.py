# snowsim.Snapshot: a simulation's state at one time, drawn and read after the simulation moved on.
import numpy as np
import pytest

from conftest import scene_path

WALL = {"time.duration": 0.1, "bodies[0].radius": 0.03}


def test_a_snapshot_renders_as_the_simulation_did_at_its_time(snowsim):
    scene = snowsim.load_scene(scene_path("mpm_snowball_wall"), WALL)
    simulation = snowsim.Simulation(scene)
    simulation.advance_to(2 / scene.fps)
    snapshot = simulation.snapshot()
    then = snowsim.render(simulation, 160, 120, color_by="plastic")
    positions, velocities = simulation.positions(), simulation.velocities()
    plastic_j = simulation.plastic_j()
    assert snapshot.time == simulation.time and snapshot.frame == 2
    assert snapshot.particle_count == simulation.particle_count and snapshot.dimension == 3
    assert np.array_equal(snowsim.render(snapshot, 160, 120, color_by="plastic"), then)

    simulation.advance_to(4 / scene.fps)
    later = snowsim.render(simulation, 160, 120, color_by="plastic")
    assert snowsim.diff(later, then)["differing"] > 0
    figures = snowsim.diff(snowsim.render(snapshot, 160, 120, color_by="plastic"), then)
    assert figures["compared"] == 160 * 120 and figures["differing"] == 0
    assert snapshot.time < simulation.time
    for array, state in [(snapshot.positions(), positions), (snapshot.velocities(), velocities),
                         (snapshot.plastic_j(), plastic_j)]:
        assert array.dtype == np.float32 and array.shape == state.shape
        assert np.array_equal(array, state.astype(np.float32))


def test_snapshot_arrays_are_copies(snowsim):
    scene = snowsim.load_scene(scene_path("mpm_snowball_wall"), WALL)
    simulation = snowsim.Simulation(scene)
    simulation.step()
    snapshot = simulation.snapshot()
    positions = snapshot.positions()
    positions[:] = 0
    assert snapshot.positions().any()
    simulation.close()
    assert snapshot.velocities().shape == (snapshot.particle_count, 3)
    with pytest.raises(ValueError, match="snapshot: the simulation is closed"):
        simulation.snapshot()


def test_a_report_method_snapshot_has_no_plastic_j(snowsim):
    simulation = snowsim.Simulation(snowsim.load_scene(scene_path("snowball_drop")))
    simulation.step()
    snapshot = simulation.snapshot()
    assert snapshot.positions().shape == (simulation.particle_count, 2)
    assert np.array_equal(snowsim.render(snapshot, 64, 48), snowsim.render(simulation, 64, 48))
    with pytest.raises(ValueError, match="plastic_j: MPM only"):
        snapshot.plastic_j()
