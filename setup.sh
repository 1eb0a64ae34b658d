#!/usr/bin/env bash
# Installs the Debian packages dbbkit needs that are missing on this machine.
# Runs as root, or through sudo when available. Does nothing when all are present.
#   ./setup.sh            the build, the tests (junitparser reads the gate's JUnit XML), the reports (gnuplot),
#                         the Python module (pybind11, NumPy, the Python headers)
#   ./setup.sh --browser  also Chromium, for the browser test of the HTML reports
#   ./setup.sh --peers    also OpenBLAS, for the benchmarks' peer programs (benchmarks/*.py; NumPy is in the default set)
set -euo pipefail

packages=(
  cmake g++ make
  libeigen3-dev libnlopt-cxx-dev libboost-math-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev libcli11-dev gnuplot-nox
  clang libclang-rt-14-dev clang-format
  python3-junitparser
  pybind11-dev python3-numpy python3-dev
)
for option in "$@"; do
  case "$option" in
    --browser) packages+=(chromium) ;;
    --peers) packages+=(libopenblas0-pthread) ;;
    *) echo "setup: unknown option $option (--browser, --peers)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "setup: installing missing packages: ${missing[*]}" >&2
if [ "$(id -u)" -eq 0 ]; then
  sudo_cmd=()
elif command -v sudo >/dev/null 2>&1; then
  sudo_cmd=(sudo)
else
  echo "setup: missing packages (${missing[*]}) and neither root nor sudo; install them and re-run" >&2
  exit 2
fi

export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
