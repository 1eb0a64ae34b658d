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
# The internals stay in the library: no installed header defines the solvers, the residual's
# column tester or the JSON object reader, nor declares a function that takes a solver (the
# installed API reaches them through a design or an identify result).
if grep -rqE "^class (WlsSolver|Gain|SetupSolver|ColumnTester|ObjectReader) \{" "$work/prefix/include"; then
  echo "an installed header defines an internal class" >&2
  exit 1
fi
if grep -rqE "(WlsSolver|SetupSolver|ColumnTester)(&| \*|\*)|ObjectReader" "$work/prefix/include"; then
  grep -rnE "(WlsSolver|SetupSolver|ColumnTester)(&| \*|\*)|ObjectReader" "$work/prefix/include" >&2
  echo "an installed header names an internal type in a signature" >&2
  exit 1
fi
for internal in wls_solver setup_solver column_tester factorised io/object_reader io/design_reader io/result_blocks; do
  test ! -e "$work/prefix/include/dbbkit/$internal.hpp"
done
cmake -S "$src/tests/consumer" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release >"$work/configure.log"
cmake --build "$work/build" >"$work/build.log"
"$work/build/consumer" | tee "$work/run.log"
grep -q "rank 72 of 72" "$work/run.log"
