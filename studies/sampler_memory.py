"""Memory of the billiard walk against dim S (issue 46): peak RSS of a short run with the
Gram matrix K = H H^T kept in float64 and in float32, on the slices of the committed
5000-disk packing (dim 537-1714), and the extrapolation to dim ~7000 from the measured
scaling (not from the array sizes alone).

    OMP_NUM_THREADS=1 python studies/sampler_memory.py studies/sampler_cost/memory.json
    python studies/sampler_memory.py studies/sampler_cost/memory.json --table

Each run is a child process (its own peak RSS, getrusage): read the packing, cut the
slice (RSS "base": the interpreter, imports and the problem), then
``BilliardWalk(8, seed=1, burn_in=2, gram=FORM)`` (analysis for the frame, frame,
rounding, K, 2 burn-in trajectories and 2 draws per chain: the set-up's peak, which is
the run's). Per case: rows p, dim d, columns 2m; K's bytes (8 p^2 or 4 p^2) and the
p x d and 2m x d arrays' (8 p d each: H, the rounding's slack-scaled rows and solves,
N, T). The fit: peak - base = k_K bytes(K) + k_pd 8 p d (least squares over both forms
and all slices), base = b0 + b1 p; dim 7000 is extrapolated with p / d at its measured
largest-slice value. Writes a JSON with every run (resumes: finished runs are kept).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
BIG = HERE / "big_slice" / "paper_fast_n5000_mu0.1_s1.h5"
HEIGHTS = (50.0, 80.0, 110.0, 140.0)
FORMS = ("float64", "float32")
TARGET_DIM = 7000

CHILD = r"""
import json, resource, sys, time
import forcespace as fs
path, height, form = sys.argv[1], float(sys.argv[2]), sys.argv[3]
prob = fs.slice_problem(fs.read_packing(path), height)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
c0 = time.process_time()
b = fs.BilliardWalk(8, seed=1, burn_in=2, gram=form).compute(prob)
print(json.dumps({"height": height, "gram": form, "gram_form": b.walk_info["gram_form"],
                  "dim": b.dim, "rows": b.n_rows, "columns": prob.n_columns,
                  "base_mb": base, "cpu_s": time.process_time() - c0,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def run(path: Path, height: float, form: str) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    res = subprocess.run([sys.executable, "-c", CHILD, str(path), f"{height:g}", form],
                         capture_output=True, text=True, env=env)
    if res.returncode != 0:
        raise RuntimeError(f"run at height {height} ({form}) exited {res.returncode}: "
                           f"{res.stderr[-600:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def fit(rows: list) -> dict:
    """Least squares peak - base = k_K bytes(K) + k_pd 8 p d [MB], and dim 7000 from it."""
    k_bytes = np.array([(8.0 if r["gram"] == "float64" else 4.0) * r["rows"] ** 2
                        for r in rows]) / 2 ** 20
    pd_bytes = np.array([8.0 * r["rows"] * r["dim"] for r in rows]) / 2 ** 20
    y = np.array([r["peak_mb"] - r["base_mb"] for r in rows])
    X = np.column_stack([k_bytes, pd_bytes])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ coef
    big = max(rows, key=lambda r: r["dim"])
    p_per_d = big["rows"] / big["dim"]
    p = p_per_d * TARGET_DIM
    # base (interpreter, imports, the problem): a line in p through the measured slices
    b1, b0 = np.polyfit([r["rows"] for r in rows], [r["base_mb"] for r in rows], 1)
    base = float(b0 + b1 * p)
    pred = {form: float(base + coef[0] * w * p * p / 2 ** 20
                        + coef[1] * 8.0 * p * TARGET_DIM / 2 ** 20)
            for form, w in (("float64", 8.0), ("float32", 4.0))}
    return {"k_K": float(coef[0]), "k_pd": float(coef[1]),
            "max_abs_residual_mb": float(np.abs(resid).max()), "rows_per_dim": p_per_d,
            "target_dim": TARGET_DIM, "target_rows": p,
            "target_K_gb": {"float64": 8 * p * p / 2 ** 30, "float32": 4 * p * p / 2 ** 30},
            "target_peak_gb": {k: v / 1024 for k, v in pred.items()},
            "target_base_mb": base, "base_fit": "base = b0 + b1 p (least squares)"}


def table(data: dict) -> str:
    lines = ["| dim S | rows p | 2m | K | K [MB] | base [MB] | peak RSS [MB] | peak - base "
             "[MB] | set-up CPU s |", "|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(data["runs"], key=lambda r: (r["dim"], r["gram"])):
        kb = (8 if r["gram"] == "float64" else 4) * r["rows"] ** 2 / 2 ** 20
        lines.append(f"| {r['dim']} | {r['rows']} | {r['columns']} | {r['gram_form']} | "
                     f"{kb:.0f} | {r['base_mb']:.0f} | {r['peak_mb']:.0f} | "
                     f"{r['peak_mb'] - r['base_mb']:.0f} | {r['cpu_s']:.1f} |")
    f = data["fit"]
    lines.append("")
    lines.append(f"Fit: peak - base = {f['k_K']:.2f} x bytes(K) + {f['k_pd']:.2f} x 8 p d "
                 f"(max residual {f['max_abs_residual_mb']:.0f} MB); p / d = "
                 f"{f['rows_per_dim']:.2f} at the largest slice, so dim {f['target_dim']}: "
                 f"p ~ {f['target_rows']:.0f}, K {f['target_K_gb']['float64']:.1f} GB "
                 f"(float64) / {f['target_K_gb']['float32']:.1f} GB (float32), peak RSS ~ "
                 f"{f['target_peak_gb']['float64']:.1f} / {f['target_peak_gb']['float32']:.1f}"
                 " GB.")
    return "\n".join(lines)


def save(path: Path, data: dict) -> None:
    """Write the JSON atomically (a run stopped midway keeps what was finished)."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="JSON file (resumed)")
    ap.add_argument("--table", action="store_true", help="print the table and the fit only")
    a = ap.parse_args(argv)
    data = json.loads(a.out.read_text()) if a.out.is_file() else {"runs": []}
    if not a.table:
        done = {(r["height"], r["gram"]) for r in data["runs"]}
        for h in HEIGHTS:
            for form in FORMS:
                if (h, form) in done:
                    continue
                print(f"height {h:g} R, K {form} ...", flush=True)
                data["runs"].append(run(BIG, h, form))
                r = data["runs"][-1]
                print(f"  dim {r['dim']}, {r['rows']} rows: peak {r['peak_mb']:.0f} MB "
                      f"(base {r['base_mb']:.0f}), {r['cpu_s']:.1f} CPU s", flush=True)
                save(a.out, data)
    if len(data["runs"]) >= 3:
        data["fit"] = fit(data["runs"])
        if not a.table:
            save(a.out, data)
        print(table(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
