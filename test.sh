#!/usr/bin/env bash
# Installs what is missing, builds everything and runs the whole test suite:
#   0. the house format: every C++ file as clang-format (.clang-format) writes it;
#   1. the unit and property tests (ctest), then the design gate (`dbbkit bench`) and the cost
#      gate (the counted work of identify, evaluate and the worst case, benchmarks/cost_gate.cpp);
#   2. the same suite built by clang with AddressSanitizer and UndefinedBehaviorSanitizer
#      (less the long statistical studies of stage 1);
#   3. a short libFuzzer run of every file reader (design, measurement, truth, kit, result), of the
#      text writers (text: any bytes through every escaping function and, as a design's names,
#      through the part program and the report writers) and of the command line's options
#      (cli); 10 s each, on a copy of the committed corpus.
# DBBKIT_QUICK=1 runs stage 1 only (for quick local iterations; CI runs all three).
set -euo pipefail
cd "$(dirname "$0")"
./setup.sh
jobs="$(nproc)"

echo "== format: clang-format --dry-run --Werror (.clang-format)"
find src include tests benchmarks -name '*.cpp' -o -name '*.hpp' | sort | xargs clang-format --dry-run --Werror

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DDBBKIT_BUILD_TESTS=ON -DDBBKIT_PYTHON=ON >/dev/null
cmake --build build -j "$jobs"
ctest --test-dir build --output-on-failure -j "$jobs"
echo "== design gate: every committed design against benchmarks/designs-baseline.json"
./build/dbbkit bench designs/*.json --baseline benchmarks/designs-baseline.json
echo "== cost gate: the work of identify, evaluate and the worst case against benchmarks/cost-baseline.json"
./build/benchmarks/dbbkit_cost designs/*.json --baseline benchmarks/cost-baseline.json
[ "${DBBKIT_QUICK:-0}" = 1 ] && exit 0

# Stages 2 and 3 share one clang build: AddressSanitizer + UndefinedBehaviorSanitizer
# everywhere, and libFuzzer coverage instrumentation of the library for the fuzz targets.
echo "== AddressSanitizer + UndefinedBehaviorSanitizer (clang)"
# Line tables only (-gline-tables-only): the sanitizers' reports name file and line, at a
# fraction of full debug information's compile and link time. The library is shared here and
# binds its own calls, so that the tests' own code can be built unoptimised (tests/CMakeLists.txt):
# the tests compile in about a third of the time, and the library's work runs as built.
CC=clang CXX=clang++ cmake -S . -B build-san -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDBBKIT_SANITIZE=address,undefined \
  -DBUILD_SHARED_LIBS=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
  -DDBBKIT_BUILD_TESTS=ON -DDBBKIT_BUILD_FUZZERS=ON -DDBBKIT_BUILD_BENCHMARKS=OFF -DDBBKIT_PYTHON=OFF >/dev/null
cmake --build build-san -j "$jobs"
# The statistical studies (thousands of repeated identifications, the recovery of real axes
# of every kind) and the exhaustive
# enumerations ran in stage 1; here every code path they use is exercised by the other
# tests, at a fraction of the time (the summaries of simulated hidden effects and of two
# searches, and two more searches of kits: the README's journey and the CLI tests search and
# write summaries here; the searches of the committed kits of new axis kinds: the small kits of
# the same kinds are searched here; the A trunnion kit searched twice at two lever arms). The
# installed-package test builds an uninstrumented consumer, which cannot link a sanitized
# library; it ran in stage 1. The reports rendered in Chromium come from the writers the
# other tests run here; they were looked at in stage 1. A test under an address-space limit
# (ulimit -v) cannot run with AddressSanitizer's shadow memory; it ran in stage 1. The rates of
# diagnose's declared set-up, substitution and no-finding studies (a drift, a warm-up, an effect no
# machine or reading could hold), of predict's and verify's intervals and
# false fails, the bordered solve against the whole block and the turntable at 0.1 deg steps
# (3,601 stations of the closed form checked at 20 deg here) ran in stage 1: their code paths are
# those of the shorter diagnose, predict, verify and observability tests run here; so are the
# rates of the chain's and the tool tip's intervals and of verify's predicted readings, and the
# search of a kit for a design that detects a drift (optimize's drift requirement, 76 s here
# against 3 s in stage 1; the drift checks it calls run here in DriftCheck's other tests), and
# the probe kit searched under a tight travel and under a set-up detection requirement (their
# checks run here in the probe kit's other search and the ball bar's detection tests), and the
# search of a kit that names its machine (5 s in stage 1, 400 s here: every point's program is
# checked; the program's machine checks run here in the program tests). The probe's README
# journey (70 s here) and the run of every command with --quiet against optimize's outputs
# (50 s) ran in stage 1: their commands run here in the probe's and the CLI's other tests. The
# search of the formats' kit against the paper's design and the kit's travel extent against a
# dense sampling of 300 random arcs ran in stage 1 too; their code runs here in the README's
# journey and the other kit tests. The Python
# module is not built here (a sanitized extension needs the sanitizer runtime preloaded into Python); its
# tests ran in stage 1.
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-san --output-on-failure -j "$jobs" \
  -E 'Coverage|FindsEffect|CleanDataAddsNothing|StatedDetectionLimitHasItsPower|GrossReadingAndNoiseScaleAreSaid|NearlyCollinearCandidates|PerInstallationDriftsAreKept|UnknownEffectIsFlagged|Exhaustive|EveryNewKind|LocationErrorsOfAReal|BrowserReports|ConsumerOfInstalledPackage|UnderAMemoryLimit|OneTruthMeasuredTwice|CleanDataAtTheDeclaredNoise|HiddenEffectsAreNamedWithTheirNextStep|OptimizeBrief|TheReadmeKitsDesignsClearTheirWorkspace|TheCommittedKitsOfNewKinds|RequiredSetupDetectionIsMetByTheDesignFound|TheTrunnionDesignSeesItsTiltsAtTheTablesEdge|TenthDegreeTurntable|SubstitutionEntersTheErrorsUncertainty|WithinTheTolerancesNothingIsFound|LegendreOrderTooLowIsSuggested|ADriftIsFoundAsADriftNotAStep|AgreesWithTheWholeBlock|AWarmUpStartingFaster|AnEffectTheReadingsCouldNotHold|ADriftNoMachineHas|Predict.IntervalsCoverTheTruth|Verify.ARightResultFails|Verify.AResultWithALocationErrorLeftOut|PredictChain.IntervalsCover|PredictChain.AToolTipsIntervalsCover|Verify.PredictedReadingsCover|DriftCheck.OptimizeRequiresTheDriftDetected|Optimize.FormatsKitBeatsThePaperLikeDesign|Kit.TravelExtentIsExactOverTheArc|Probe.ATightTravelPullsTheSpheresIn|Probe.RequiredDetectionIsMetOnly|MachineKit.TheSearchOnAMachineOffersOnly|Readme.ATouchProbeOnCalibrationSpheres|Cli.QuietLeavesOnlyTheFilesAskedFor'

echo "== fuzzing (libFuzzer, 10 s per target)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
passed=0
failed=0
for target in design measurement truth kit text result trace machine chain cli; do
  mkdir -p "$work/$target"
  cp tests/fuzz/corpus/"$target"/* "$work/$target/"
  if ./build-san/tests/fuzz/fuzz_"$target" -max_total_time=10 -timeout=10 -rss_limit_mb=2048 \
      -artifact_prefix="$work/" "$work/$target" >"$work/$target.log" 2>&1; then
    passed=$((passed + 1))
    echo "fuzz_$target: $(grep -E '^Done [0-9]+ runs' "$work/$target.log")"
  else
    failed=$((failed + 1))
    echo "fuzz_$target FAILED:"; tail -40 "$work/$target.log"
  fi
done
echo "fuzz: $passed passed, $failed failed"
[ "$failed" = 0 ]
