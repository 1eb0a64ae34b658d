#!/usr/bin/env bash
# The main job: install what is missing, build, and run the closed-loop analysis
# of the paper's data (identify, then diagnose: what the model lacks, before and
# after; the corrected location errors as a compensation file), writing the results under
# reports/.
set -euo pipefail
cd "$(dirname "$0")"
./setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target dbbkit_cli
mkdir -p reports
for axis in c-turntable b-head; do
  design="designs/paper-${axis}.json"
  csv="tests/data/paper/paper_${axis//-/_}.csv"
  ./build/dbbkit identify --design "$design" --data "$csv" \
    --out "reports/paper-${axis}-identify.json" --report "reports/paper-${axis}-identify.html" \
    --summary "reports/paper-${axis}-identify.md" > "reports/paper-${axis}-identify.txt"
  ./build/dbbkit diagnose --design "$design" --data "$csv" \
    --out "reports/paper-${axis}-diagnose.json" --report "reports/paper-${axis}-diagnose.html" \
    --summary "reports/paper-${axis}-diagnose.md" > "reports/paper-${axis}-diagnose.txt"
  ./build/dbbkit evaluate --design "$design" --quiet --out "reports/paper-${axis}-evaluate.json" \
    --report "reports/paper-${axis}-evaluate.html" --summary "reports/paper-${axis}-evaluate.md"
  echo "== ${axis}"
  grep -E '^(before|after): ' "reports/paper-${axis}-diagnose.txt"
done
# The C table's corrected location errors for a controller: the ISG kernel's CSV and a table to
# enter by hand (each value with its expanded uncertainty, those too uncertain to enter said).
./build/dbbkit compensation --result reports/paper-c-turntable-diagnose.json --format isg \
  --out reports/paper-c-turntable-compensation.csv
./build/dbbkit compensation --result reports/paper-c-turntable-diagnose.json --format table \
  --out reports/paper-c-turntable-compensation.txt
# The C table in ISO 230-7 terms against an example acceptance (ISO 14253-1 decisions,
# Type A: the residual contradicts the declared noise). Exit code 1 means "does not
# conform", a result, not a failure of the run.
status=0
./build/dbbkit identify --design designs/paper-c-turntable.json --data tests/data/paper/paper_c_turntable.csv \
  --type-a --tolerances designs/tolerances/c-turntable-acceptance.json \
  --out reports/paper-c-turntable-conformance.json --report reports/paper-c-turntable-conformance.html \
  --summary reports/paper-c-turntable-conformance.md > reports/paper-c-turntable-conformance.txt || status=$?
if [ "$status" -gt 1 ]; then exit "$status"; fi
echo "== C table against designs/tolerances/c-turntable-acceptance.json: $(grep -m1 'verdict' reports/paper-c-turntable-conformance.txt | sed 's/^ *//')"
# The same acceptance on diagnose's corrected errors (the effects it found taken out).
status=0
./build/dbbkit diagnose --design designs/paper-c-turntable.json --data tests/data/paper/paper_c_turntable.csv \
  --tolerances designs/tolerances/c-turntable-acceptance.json \
  --out reports/paper-c-turntable-diagnose-conformance.json \
  --report reports/paper-c-turntable-diagnose-conformance.html \
  --summary reports/paper-c-turntable-diagnose-conformance.md > reports/paper-c-turntable-diagnose-conformance.txt || status=$?
if [ "$status" -gt 1 ]; then exit "$status"; fi
echo "== C table's corrected errors against the same acceptance: $(grep -m1 'verdict' reports/paper-c-turntable-diagnose-conformance.txt | sed 's/^ *//')"
# From the instrument's traces: simulated 1 kHz traces of the paper's C design (moves, settling,
# noise), their dwells found and matched to the sweep (reports/paper-c-turntable-readings.*).
# In the build tree under a fixed name, so that the report's inputs read the same on every run.
traces=build/traces
rm -rf "$traces" && mkdir -p "$traces"
./build/dbbkit simulate --design designs/paper-c-turntable.json --truth tests/data/truth_c_per_angle.json \
  --seed 4 --out "$traces/sim.csv" --trace-out "$traces/"
./build/dbbkit readings --design designs/paper-c-turntable.json --quiet \
  $(for id in 1r 1t 1a 2r 2t 3r 3t; do printf -- '--trace %s=%s/%s.csv ' "$id" "$traces" "$id"; done) \
  --out reports/paper-c-turntable-readings.csv --report reports/paper-c-turntable-readings.html \
  --summary reports/paper-c-turntable-readings.md
echo "== readings from simulated traces: $(($(wc -l < reports/paper-c-turntable-readings.csv) - 1)) readings (reports/paper-c-turntable-readings.html)"
# What the kit of formats.md allows, against the paper-like design.
./build/dbbkit optimize --kit designs/kits/c-turntable-kit.json --reference designs/paper-c-turntable.json \
  --out reports/c-turntable-kit-optimized.json --result reports/c-turntable-kit-optimize.json \
  --report reports/c-turntable-kit-optimize.html --summary reports/c-turntable-kit-optimize.md --pareto --quiet
echo "== C kit of formats.md: $(grep -m1 'ratio' reports/c-turntable-kit-optimize.md || true)"
# At the machine: the set-up sheet of the design found (order, hardware, a drawing of each
# installation) and its part program in both dialects.
./build/dbbkit setup-sheet --design reports/c-turntable-kit-optimized.json --kit designs/kits/c-turntable-kit.json \
  --report reports/c-turntable-kit-setup-sheet.html --summary reports/c-turntable-kit-setup-sheet.md --quiet
./build/dbbkit program --design reports/c-turntable-kit-optimized.json --dialect iso \
  --out reports/c-turntable-kit-optimized.nc --quiet
./build/dbbkit program --design reports/c-turntable-kit-optimized.json --dialect heidenhain \
  --out reports/c-turntable-kit-optimized.h --quiet
# The same kit with set-up tolerances (10 um length offset, 5 um centring) and optional
# installations: the total it minimises, what each extra installation buys (Pareto front),
# and the detection limits of the set-up effects in the design it finds.
./build/dbbkit optimize --kit designs/kits/c-turntable-kit-setup.json \
  --reference designs/c-turntable-kit-optimized-with-setup.json \
  --out reports/c-turntable-kit-setup-optimized.json --result reports/c-turntable-kit-setup-optimize.json \
  --report reports/c-turntable-kit-setup-optimize.html --summary reports/c-turntable-kit-setup-optimize.md --pareto --quiet
./build/dbbkit evaluate --design reports/c-turntable-kit-setup-optimized.json --quiet \
  --out reports/c-turntable-kit-setup-evaluate.json --report reports/c-turntable-kit-setup-evaluate.html \
  --summary reports/c-turntable-kit-setup-evaluate.md
echo "== C kit with set-up tolerances and optional installations: $(grep -m1 'total ratio' reports/c-turntable-kit-setup-optimize.md || true)"
echo "reports written under reports/"
