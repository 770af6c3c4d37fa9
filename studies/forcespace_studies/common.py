"""What several studies share: packings jammed once per study directory."""
from __future__ import annotations

import time
from pathlib import Path

from forcespace import jam, read_packing, write_packing
from forcespace.io.outputs import file_lock


def shared_packing(out, scene: str, mu: float, seed: int, n_disks: int, reuse_from=(),
                   overrides=None):
    """The packing jammed from the bundled scene SCENE at (mu, seed, n_disks), made once per
    study directory and shared by every task that needs it.

    Kept as ``OUT/packings/SCENE_nN_muMU_sSEED.h5``; a worker that needs a packing
    another worker is jamming waits for it (a blocking file lock) instead of jamming it
    a second time. ``reuse_from``: names of sibling study directories (e.g. "fig1")
    whose packings are read instead when they have it. ``overrides``: further scene
    keys (``jam`` style, e.g. ``{"physics__plate_mu": mu}``) that must be a function
    of (scene, mu, seed, n_disks), since the file name does not record them.
    An interrupted compression resumes from ``OUT/packings/NAME.checkpoint.npz``
    (saved every 30 s; bit-identical to an uninterrupted run), so a study stopped
    in the middle of a long jam loses at most half a minute of it.
    Returns (Packing, jam wall time [s] of this call, 0 when it was reused).
    """
    name = f"{scene}_n{n_disks}_mu{mu:.6g}_s{seed}.h5"
    for other in reuse_from:
        theirs = Path(out).parent / other / "packings" / name
        if theirs.is_file():
            return read_packing(theirs), 0.0
    path = Path(out) / "packings" / name
    path.parent.mkdir(parents=True, exist_ok=True)
    with file_lock(path.parent / f".{path.name}.jamlock"):
        if path.is_file():
            return read_packing(path), 0.0
        t0 = time.perf_counter()
        p = jam(scene, physics__mu=mu, scene__seed=seed,
                disks__n=n_disks, checkpoint=path.with_name(path.name + ".checkpoint.npz"),
                **(overrides or {}))
        write_packing(p, path)
        return read_packing(path), time.perf_counter() - t0
