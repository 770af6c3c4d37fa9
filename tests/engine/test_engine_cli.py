"""Bad input gives one clear line naming file, field and what is allowed."""
import json

import pytest

from forcespace.cli import main

GOOD = """
[disks]
n = 12
radius_min = 1.0
radius_max = 2.0
[box]
width = 20.0
"""


@pytest.mark.parametrize("edit, field, allowed", [
    ("[disks]\nn = 12\nradius_min = -1.0\n", "disks.radius_min", "must be in (0, 1e6]"),
    ("[physics]\nmu = -0.1\n", "physics.mu", "must be in [0, 1e6]"),
    ("[box]\nwidth = 5.0\n", "box.width", "minimum-image"),
    ("[disks]\nn = \"many\"\n", "disks.n", "must be an integer"),
    ("[physics]\nfriction = 0.3\n", "physics.friction", "unknown key; allowed keys here:"),
    ("[plates]\ntop = \"servo\"\n", "plates.top", 'must be "load" or "none"'),
    ("[physics\nmu = 0.1\n", "(syntax)", "not valid TOML"),
])
def test_bad_scene_is_one_line_naming_file_field_and_allowed(tmp_path, capsys, edit, field,
                                                              allowed):
    scene = tmp_path / "bad.toml"
    scene.write_text(edit)
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert str(scene) in err and field in err and allowed in err
    assert "Traceback" not in err
    assert not (tmp_path / "p.h5").exists()


def test_override_out_of_range_is_reported(tmp_path, capsys):
    scene = tmp_path / "ok.toml"
    scene.write_text(GOOD)
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5"), "--mu", "-1"]) == 2
    assert "physics.mu" in capsys.readouterr().err


def test_info_on_missing_or_foreign_file(tmp_path, capsys):
    assert main(["info", str(tmp_path / "none.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    assert main(["info", str(junk)]) == 2
    assert "not a readable HDF5 file" in capsys.readouterr().err


def test_pack_info_json_round_trip(tmp_path, capsys):
    scene = tmp_path / "ok.toml"
    scene.write_text(GOOD)
    out = tmp_path / "p.h5"
    assert main(["pack", str(scene), "-o", str(out), "--quiet", "--seed", "3"]) == 0
    capsys.readouterr()
    assert main(["info", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    for key in ("n_disks", "n_contacts", "z", "n_rattlers", "mu", "equilibrium_residual",
                "max_overlap"):
        assert key in info
    assert info["n_disks"] == 12 and info["seed"] == 3
    assert info["equilibrium_residual"] <= 1e-10
    assert main(["draw", str(out), "-o", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 0 and (tmp_path / "f.pdf").exists()
