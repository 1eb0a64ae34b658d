#!/usr/bin/env bash
# cmake --install into a fresh prefix, then `import dbbkit` from there (and not from the build).
#   install_test.sh BUILD_DIR PYTHON MODULE_DIR (relative to the prefix)
set -euo pipefail
build="$1" python="$2" module_dir="$3"
prefix="$(mktemp -d)"
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix" >/dev/null
cd "$prefix"
PYTHONPATH="$prefix/$module_dir" "$python" -c "
import os, sys, dbbkit
where = os.path.realpath(dbbkit.__file__)
assert where.startswith(os.path.realpath(sys.argv[1])), where
print('dbbkit', dbbkit.__version__, 'from', where)
" "$prefix"
