#!/usr/bin/env bash
# The main job: install what is missing, build, and analyse the paper's data,
# writing the results under reports/.
set -euo pipefail
cd "$(dirname "$0")"
./setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target dbbkit_cli
mkdir -p reports
for axis in c-turntable b-head; do
  csv="tests/data/paper/paper_${axis//-/_}.csv"
  ./build/dbbkit identify --design "designs/paper-${axis}.json" --data "$csv" \
    --out "reports/paper-${axis}-identify.json" > "reports/paper-${axis}-identify.txt"
  echo "wrote reports/paper-${axis}-identify.json and .txt"
done
