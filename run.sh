#!/usr/bin/env bash
# The main job: install what is missing, build, and run the closed-loop analysis
# of the paper's data (identify, then diagnose: what the model lacks, before and
# after), writing the results under reports/.
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
    --out "reports/paper-${axis}-identify.json" > "reports/paper-${axis}-identify.txt"
  ./build/dbbkit diagnose --design "$design" --data "$csv" \
    --out "reports/paper-${axis}-diagnose.json" --report "reports/paper-${axis}-diagnose.html" \
    > "reports/paper-${axis}-diagnose.txt"
  echo "== ${axis}"
  sed -n '3,4p' "reports/paper-${axis}-diagnose.txt"
done
echo "reports written under reports/"
