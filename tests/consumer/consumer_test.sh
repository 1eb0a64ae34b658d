#!/usr/bin/env bash
# Installs the build tree into a temporary prefix, then configures, builds and
# runs tests/consumer against it with find_package(dbbkit).
# Usage: consumer_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1"
build="$2"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
test -f "$work/prefix/include/dbbkit/identify.hpp"
test -f "$work/prefix/lib/cmake/dbbkit/dbbkitConfig.cmake"
# The solver's internals stay in the library: no installed header defines them.
if grep -rqE "^class (WlsSolver|Gain) \{" "$work/prefix/include"; then
  echo "an installed header defines WlsSolver or Gain" >&2
  exit 1
fi
test ! -e "$work/prefix/include/dbbkit/wls_solver.hpp"
cmake -S "$src/tests/consumer" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release >"$work/configure.log"
cmake --build "$work/build" >"$work/build.log"
"$work/build/consumer" | tee "$work/run.log"
grep -q "rank 72 of 72" "$work/run.log"
