#!/usr/bin/env bash
# The cost gate fails where the work grew, and says where: a baseline with one count lowered
# (as if the current code had added a factorisation to identify) must fail naming the call, the
# design and the counter; the committed baseline must pass.
set -euo pipefail
gate="$1"
cd "$(dirname "$0")/.."
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$gate" designs/*.json --write "$work/now.json" >/dev/null
/usr/bin/python3 - "$work/now.json" "$work/lowered.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
j["cases"]["identify designs/paper-c-turntable.json"]["factorisations"] -= 1
json.dump(j, open(sys.argv[2], "w"))
PY
if "$gate" designs/*.json --baseline "$work/lowered.json" >"$work/out.txt"; then
  echo "the gate passed a count above its baseline"; cat "$work/out.txt"; exit 1
fi
grep -q '^MORE    identify designs/paper-c-turntable.json: factorisations 1 (baseline 0)$' "$work/out.txt" ||
  { echo "the gate did not say where:"; cat "$work/out.txt"; exit 1; }
"$gate" designs/*.json --baseline "$work/now.json" | grep -q '0 counts above the baseline, 0 below, 0 new'
echo "cost gate: fails and names identify designs/paper-c-turntable.json factorisations"
