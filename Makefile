# forcespace: `make demo` installs everything and runs the main job on a small scene;
# `make test` runs the test suite; `make bench` writes benchmark figures to studies/out/
# (studies/bench.py, then studies/accuracy_vs_time.py, which needs LIGGGHTS, then the engine's
# CPU benchmarks against the old engine and pymunk, forcespace_studies.bench_engine, and the
# exact analysis against the old code, forcespace_studies.bench_analysis, and a measured
# 1000-particle frame read and checked, forcespace_studies.bench_measured, and the sphere
# jam at 500 spheres (--long: 2000) with the per-contact update, forcespace_studies.bench_spheres,
# and the billiard walk to ESS 100 at dim 228 and 1714, forcespace_studies.bench_sampler;
# the samplers' cost table is `python studies/sampler_cost.py studies/sampler_cost`, hours, see its note);
# `make studies` runs every study at full size (days on a few cores; resumable: rerun
# after any interruption; not run by CI) into studies/results/NAME and rebuilds
# studies/REPORT.md from them. STUDY_ARGS passes options, e.g. --scheduler tcp://host:8786.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SUDO   := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# numba caches forcespace's kernels beside its sources (or where NUMBA_CACHE_DIR says, if
# the user's environment sets it): the same cache for make and for a plain shell, so they
# compile once per machine and version

.PHONY: install liggghts demo test bench studies clean

install: $(STAMP)

$(STAMP): pyproject.toml
	@echo "== creating $(VENV) and installing forcespace with its dependencies (numpy, scipy," \
	  "numba, HiGHS, matplotlib, ...; 1-3 minutes on a fresh machine)"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --progress-bar on -e '.[test]'
	touch $(STAMP)

# LIGGGHTS comes from Debian; installed only when the binary is missing.
liggghts:
	@command -v liggghts >/dev/null 2>&1 || { \
	  echo "installing LIGGGHTS (apt-get install liggghts)"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq liggghts >/dev/null; }

# the main job on a small frictional packing (about a minute; the first run also compiles
# the numba kernels): jam, the exact analysis of S, uniform samples of S until converged,
# the ensemble's figure (P(f) and the spread of every contact force) and a 2-D section of S
demo: install
	@echo "== jam 40 frictional disks (bundled scene quick at mu = 0.3) -> out/demo.h5"
	$(BIN)/forcespace pack quick --mu 0.3 -o out/demo.h5
	@echo "== the exact analysis of S, the forces in equilibrium with the loads (LPs)"
	$(BIN)/forcespace analyze out/demo.h5 --full
	@echo "== uniform samples of S (billiard walk) until ESS 200 -> out/demo_ensemble.h5"
	$(BIN)/forcespace sample out/demo.h5 --full --sampler billiard -n 20000 --target-ess 200 \
	  -o out/demo_ensemble.h5
	@echo "== eta with its interval, P(f), stress and fabric -> out/demo_ensemble.png/.pdf"
	$(BIN)/forcespace ensemble out/demo_ensemble.h5 --packing out/demo.h5 -o out/demo_ensemble.png
	@echo "== a 2-D section of S through the jammed network -> out/demo_section.png/.pdf"
	$(BIN)/forcespace section out/demo.h5 --full -o out/demo_section.png

test: install liggghts
	$(BIN)/python -m pytest -q -n logical

bench: install liggghts
	$(BIN)/python studies/bench.py
	$(BIN)/python studies/accuracy_vs_time.py
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_engine
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_analysis
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_certificate
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_certificate --section compaction
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_measured
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_spheres
	OMP_NUM_THREADS=1 $(BIN)/python -m forcespace_studies.bench_sampler

STUDIES     := fig1 fig3 fig2 size pointforce selection measured
# studies whose verdicts.json their own script writes (not run by `forcespace study`),
# reported beside: studies/spheres_fig1.py (issue 44), studies/spheres3d.py (issue 43;
# --report-only rewrites a directory's verdicts from its rows)
REPORTED    := spheres_fig1 spheres3d_certified_n500 spheres_liggghts_in_s spheres_slice_cost
STUDY_ARGS  ?=

studies: install liggghts
	@for s in $(STUDIES); do \
	  echo "== study $$s"; \
	  $(BIN)/forcespace study $$s -o studies/results/$$s $(STUDY_ARGS) || exit $$?; \
	done
	$(BIN)/forcespace study report $(addprefix studies/results/,$(STUDIES) $(REPORTED)) -o studies/REPORT.md

clean:
	rm -rf out .pytest_cache
