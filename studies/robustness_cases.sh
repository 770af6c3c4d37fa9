#!/usr/bin/env bash
# The cases of issue 21 (robustness at the new edges), each run through the installed
# `forcespace` command: prints one Markdown table row per case with the exit code and
# the first line of stderr (or the check that was made). Usage, from the repository root:
#
#     bash studies/robustness_cases.sh [FORCESPACE] > robustness_cases.md
#
# Runs in a temporary directory (removed at the end); about two minutes of CPU.
set -u
FS=${1:-forcespace}
PY="$(dirname "$(command -v "$FS")")/python"     # the Python forcespace is installed in
REPO=$(pwd)
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
cd "$W"
PACK="$REPO/studies/packings/paper_mu0.1.h5"

row() {   # row "case" command...: exit code and the first stderr line
    local case=$1; shift
    "$@" > out.txt 2> err.txt
    local rc=$?
    local msg
    msg=$(grep -v '^\s*$' err.txt | grep -v '%|' | head -1 | cut -c1-220)
    printf '| %s | %s | %s |\n' "$case" "$rc" "${msg//|/\\|}"
}

echo "| case | exit | message (first line of stderr) |"
echo "|---|---|---|"

# ---- data loss and wrong results ---------------------------------------------------
mkdir -p mine && echo "my own notes" > mine/REPORT.md
cp -r "$REPO/studies/results/pointforce" mine/pointforce
row "study --report-only -o DIR/NAME beside a user's DIR/REPORT.md" \
    "$FS" study pointforce --report-only -o mine/pointforce --quiet
printf '| (check) the user'"'"'s DIR/REPORT.md afterwards | - | %s |\n' "$(cat mine/REPORT.md)"

"$FS" sample "$PACK" --sampler hit-and-run -n 8 --seed 1 -o ens.h5 --quiet 2>/dev/null
"$PY" - <<'EOF'
import h5py
with h5py.File("ens.h5", "r+") as f:
    key = "samples" if "samples" in f else [k for k in f if "sample" in k][0]
    d = f[key]; x = d[()]; x[3, ::2] *= 3.0; d[...] = x
EOF
row "ensemble with sample 3 edited (fn x3)" "$FS" ensemble ens.h5
row "sample resuming onto that file" "$FS" sample "$PACK" --sampler hit-and-run -n 12 --seed 1 -o ens.h5 --quiet

cp "$PACK" neg.h5
"$PY" - <<'EOF'
import h5py
with h5py.File("neg.h5", "r+") as f:
    f["forces"][:, 0] *= -1.0
EOF
row "info on a packing with every fn negated" "$FS" info neg.h5
printf '[disks]\nn = 20\n[box]\nwidth = 20.0\n[solver]\ndt = 0.05\n[physics]\nmu = 1e-9\n[scene]\nseed = 6\n' > mu1e-9.toml
"$FS" pack mu1e-9.toml -o mu1e-9.h5 --quiet 2>/dev/null
row "analyze --full of a packing jammed at mu = 1e-9 (hard-case seed 6)" \
    "$FS" analyze mu1e-9.h5 --full --json --quiet
printf '| (check) dim S of that run | - | %s |\n' \
    "$("$PY" -c "import json; print(json.load(open('out.txt'))['dim_S'])" 2>&1)"

# ---- tracebacks --------------------------------------------------------------------
mkdir -p g/tasks && echo '{"study": "fig1", "quick": true}' > g/study.json
echo 'garbage{' > g/tasks/mu0.01_s1.json
row "study --report-only over a garbage task JSON" "$FS" study fig1 --quick --report-only -o g --quiet
echo '[]' > g/tasks/mu0.01_s1.json
row "study --report-only over a [] task JSON" "$FS" study fig1 --quick --report-only -o g --quiet
row "--scheduler tcp://127.0.0.1:1 (nothing listening)" \
    "$FS" study fig1 --quick --scheduler tcp://127.0.0.1:1 --connect-timeout 2 -o s1 --quiet
row "--scheduler tcp://127.0.0.1:99999" "$FS" study fig1 --quick --scheduler tcp://127.0.0.1:99999 -o s2 --quiet
row "--scheduler ''" "$FS" study fig1 --quick --scheduler '' -o s3 --quiet
row "--scheduler 'not an address!'" "$FS" study fig1 --quick --scheduler 'not an address!' -o s4 --quiet
row "--scheduler http://127.0.0.1:8787" "$FS" study fig1 --quick --scheduler http://127.0.0.1:8787 -o s5 --quiet
touch afile
row "study -o onto a file" "$FS" study fig1 --quick -o afile --quiet
row "study -o onto a device" "$FS" study fig1 --quick -o /dev/null --quiet
row "study -o in a read-only place" "$FS" study fig1 --quick -o /proc/fig1 --quiet
row "study --report-only on a missing directory" "$FS" study fig1 --quick --report-only -o missing --quiet
printf '| (check) missing directory created? | - | %s |\n' "$(test -e missing && echo yes || echo no)"
mkdir -p empty
row "study --report-only on an empty directory" "$FS" study fig1 --quick --report-only -o empty --quiet
row "draw --difference -o x.h5" "$FS" draw "$PACK" --difference -o x.h5
row "section -o x.h5" "$FS" section "$PACK" -o x.h5
row "draw --difference --seed -1" "$FS" draw "$PACK" --difference --seed -1 -o d.png
row "pack --n 0 --scale-box" "$FS" pack quick --n 0 --scale-box -o p.h5 --quiet
row "pack --n -5 --scale-box" "$FS" pack quick --n -5 --scale-box -o p.h5 --quiet
row "select --kn 1e308" "$FS" select "$PACK" --kn 1e308 -o sel.h5
cp "$PACK" fv.h5
"$PY" -c "import h5py; f = h5py.File('fv.h5', 'r+'); f.attrs['format_version'] = 'two'"
row "packing file with format_version = 'two'" "$FS" info fv.h5
printf 'garbage' > p2.h5.checkpoint.h5
row "pack resuming from a garbage checkpoint" "$FS" pack quick -o p2.h5 --quiet
printf '[scene]\nname = "a\\u0000b"\n' > nul.toml
row "scene name with a NUL character" "$FS" pack nul.toml -o nul.h5 --quiet
"$FS" pack paper -o big.h5 --quiet > /dev/null 2> sigint.txt &
PID=$!
sleep 8
kill -INT $PID
wait $PID
printf '| SIGINT during pack (paper scene, after 8 s) | %s | %s |\n' "$?" \
    "$(grep -v '%|' sigint.txt | grep -v '^\s*$' | head -1 | cut -c1-200)"

# ---- misleading --------------------------------------------------------------------
row "analyze --mu 1e300" "$FS" analyze "$PACK" --mu 1e300
row "select --kt-ratio 1e-300" "$FS" select "$PACK" --kt-ratio 1e-300 -o sel2.h5
row "analyze --gap-tol nan" "$FS" analyze "$PACK" --gap-tol nan
row "analyze --gap-tol -1" "$FS" analyze "$PACK" --gap-tol -1
: > empty.toml
row "pack an empty (0-byte) scene" "$FS" pack empty.toml -o e.h5 --quiet
printf '[plates]\ntop_mass = 1e-6\n' > light.toml
row "pack with plate.top_mass = 1e-6" "$FS" pack light.toml -o l.h5 --quiet
