"""The scene as records: every key lands in one field, boundary conditions are data, and
the records reach a packing and its file."""
from dataclasses import fields

import numpy as np
import pytest

from forcespace.errors import InputError
from forcespace.model.scene import SCHEMA, Scene, load_scene, validate
from forcespace.model.setup import Boundary, Plate, Setup

# read for provenance only (the packing's name and text), not by the engine
PROVENANCE_ONLY = {"scene.name", "scene.description"}


class RecordingScene(Scene):
    """A scene that records which keys are read."""

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)


def _recording(scene: Scene) -> RecordingScene:
    rec = RecordingScene(scene.values, scene.source, scene.text)
    object.__setattr__(rec, "read", set())
    return rec


def test_every_scene_key_the_engine_runs_on_is_read_into_the_records():
    rec = _recording(load_scene("paper_fast"))
    Setup.from_scene(rec)
    assert set(SCHEMA) - rec.read == PROVENANCE_ONLY - rec.read
    assert rec.read <= set(SCHEMA)


@pytest.mark.parametrize("name", ["quick", "paper", "paper_fast", "layer"])
def test_the_records_carry_the_scene_values(name):
    sc = load_scene(name)
    s = Setup.from_scene(sc)
    for record, section in ((s.grains, "disks"), (s.solver, "solver")):
        for f in fields(record):
            assert getattr(record, f.name) == sc[f"{section}.{f.name}"], f.name
    assert s.jamming.initial_packing_fraction == sc["box.initial_packing_fraction"]
    assert s.jamming.static_tolerance == sc["jamming.static_tolerance"]
    assert s.dim == 2 and s.boundary.lateral == (sc["box.width"],)
    assert s.boundary.periodic == (sc["box.periodic_x"],)
    assert s.boundary.bottom == (sc["plates.bottom"] == "fixed")
    assert (s.boundary.top is None) == (sc["plates.top"] == "none")
    assert s.physics.rotation == sc.rotation
    assert (s.seed, s.name, s.text) == (sc["scene.seed"], sc.name, sc.to_toml())


def test_the_force_unit_is_the_plate_load_else_the_weight_scale():
    plate = Setup.from_scene(load_scene("quick").with_overrides(**{"plates.top_force": 2.5}))
    assert plate.boundary.top == Plate(2.5, 10.0) and plate.force_unit == 2.5
    layer = Setup.from_scene(load_scene("layer").with_overrides(
        **{"disks.density": 3.0, "physics.gravity": 0.5}))
    assert layer.boundary.top is None and layer.force_unit == 1.5


def test_the_checkpoint_identity_ignores_the_step_budget_only():
    sc = load_scene("quick")
    same = Setup.from_scene(sc.with_overrides(**{"jamming.max_steps": 77}))
    assert same.identity == Setup.from_scene(sc).identity
    assert Setup.from_scene(sc).with_max_steps(5).jamming.max_steps == 5
    other = Setup.from_scene(sc.with_overrides(**{"physics.mu": 0.2}))
    assert other.identity != Setup.from_scene(sc).identity


def test_dimension_is_the_number_of_axes_and_the_engine_takes_two_or_three():
    from forcespace.engine.bodies import kernel_box
    from forcespace.engine.records import Box3
    sides = Boundary(lateral=(12.0,), periodic=(False,), bottom=True, top=Plate(1.0, 10.0))
    box = kernel_box(sides)
    assert (box.width, box.periodic, box.has_bottom, box.has_top, box.has_sides) == \
        (12.0, False, True, True, True)
    spheres = Boundary(lateral=(10.0, 12.0), periodic=(True, True), bottom=True, top=None)
    assert spheres.dim == 3 and spheres.has_walls
    assert kernel_box(spheres) == Box3(10.0, 12.0, True, False)
    with pytest.raises(InputError, match="periodic in x and y"):
        kernel_box(Boundary(lateral=(10.0, 10.0), periodic=(True, False), bottom=True,
                            top=None))
    with pytest.raises(InputError, match="2-D .* or 3-D"):
        kernel_box(Boundary(lateral=(10.0, 10.0, 10.0), periodic=(True,) * 3, bottom=True,
                            top=None))


def test_a_packing_carries_its_setup_into_and_out_of_its_file(tmp_path):
    from forcespace.engine.protocol import build_packing
    from forcespace.io.packing_file import read_packing, write_packing
    sc = validate({"disks.n": 8, "box.width": 10.0, "analysis.slice_height": 3.0,
                   "solver.dt": 0.05}, "s.toml")
    p = build_packing(sc, show_progress=False)
    assert p.setup == Setup.from_scene(sc) and p.scene_slice_height == 3.0
    write_packing(p, tmp_path / "p.h5")
    back = read_packing(tmp_path / "p.h5")
    assert back.setup.solver == p.setup.solver and back.setup.boundary == p.setup.boundary
    assert back.setup.jamming == p.setup.jamming and back.scene_slice_height == 3.0
    np.testing.assert_array_equal(back.fn, p.fn)
