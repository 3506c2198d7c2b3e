#!/usr/bin/env bash
# The whole test suite, from a fresh Debian 12 machine: installs the dependencies (apt, via
# toolchains/install-deps.sh --cross --ros), then builds and tests
#   host     x86-64 RelWithDebInfo, every test including those labelled `heavy`
#   asan     x86-64 clang Debug (-O1, toolchains/cmake/CmDefaults.cmake) with AddressSanitizer +
#            UndefinedBehaviorSanitizer and libFuzzer's coverage (-DCM_SANITIZE=ON -DCM_FUZZ=ON): every test but
#            `heavy`, and the fuzz tests (label `fuzz`, tests/fuzz: every LCM decoder and the server inbox fuzzed
#            from their seed corpora for a bounded time, about 2.5 minutes of ctest). One build serves both: the
#            sanitized libraries are compiled once.
#            Neither asan nor jetson compiles the *_heavy test areas (CM_BUILD_HEAVY_TESTS=OFF): they never run there.
#   jetson   aarch64 Cortex-A57 cross build (Release, no benchmarks), tests under qemu-aarch64 -cpu cortex-a57
#            (not `heavy`)
#   fuzz     the fuzzers alone (clang RelWithDebInfo, libFuzzer + ASan + UBSan, no doctest suites); not in the
#            default set, which fuzzes in `asan`: run `tests/run.sh fuzz`
#   ipc      x86-64 -march=skylake (IPC-6000) build; its tests run when this CPU has AVX2/FMA (not `heavy`);
#            not in the default set (CI time): run `tests/run.sh ipc`
# Every configuration compiles in unity batches (CM_UNITY_BUILD=ON; CM_UNITY_BUILD=OFF in the environment compiles
# file by file) with Ninja when it is installed.
# Test code compiles at -O1 in the optimised builds (CM_TESTS_O1=ON; the libraries and apps under test keep the
# build type's level).
# Debug info is line tables only (CM_DEBUG_INFO=lines: backtraces and sanitizer reports keep file:line, the
# builds take far less time); CM_DEBUG_INFO=full in the environment builds with full debug info instead.
# Idempotent: build trees (build-<config>/) are reused; with ccache installed every compile goes through it, with
# its cache outside the tree ($CCACHE_DIR, else a cache_dir set in ccache.conf, else
# ${XDG_CACHE_HOME:-~/.cache}/commerge-ccache). A failing configuration does not stop the others. Ends with a
# summary: per configuration the time of configure, build and ctest, how many tests passed, failed and skipped,
# and each skipped test with its CM-SKIP reason. Exits non-zero when anything fails.
#
# Usage: tests/run.sh [--no-install] [CONFIG...]      (default: host asan jetson)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"

install=1
configs=()
for arg in "$@"; do
  case "$arg" in
    --no-install) install=0 ;;
    host|fuzz|asan|jetson|ipc) configs+=("$arg") ;;
    -h|--help) sed -n '2,/^# Usage:/p' "$0"; exit 0 ;;
    *) echo "tests/run.sh: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done
[ ${#configs[@]} -gt 0 ] || configs=(host asan jetson)

if [ $install -eq 1 ]; then bash toolchains/install-deps.sh --cross --ros; fi

jobs=$(nproc 2>/dev/null || echo 2)
export CTEST_OUTPUT_ON_FAILURE=1
# Sanitizer builds: impossible allocations must come back as NULL (-> std::bad_alloc), as in production.
export ASAN_OPTIONS="allocator_may_return_null=1:detect_leaks=1:abort_on_error=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# ccache: its cache lives outside the clone, so a fresh clone (CI) reuses what earlier runs compiled.
launcher=()
if command -v ccache >/dev/null 2>&1; then
  if [ -z "${CCACHE_DIR:-}" ] && ccache --show-config 2>/dev/null | grep -q '^(default) cache_dir = '; then
    export CCACHE_DIR="${XDG_CACHE_HOME:-$HOME/.cache}/commerge-ccache"
  fi
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi

debug_info=${CM_DEBUG_INFO:-lines}
# Unity builds (CM_UNITY_BUILD, CMakeLists.txt): each target compiles its sources in batches, which parses the
# headers (Eigen above all) once per batch instead of once per file. CM_UNITY_BUILD=OFF in the environment
# compiles file by file, as a developer's incremental build does.
unity=${CM_UNITY_BUILD:-ON}

summary=()
failed_configs=()
digests=()

# Appends the summary lines of a finished ctest run: counts from ctest's own report ($dir/ctest.log), and for
# each skipped test its first CM-SKIP line from $dir/Testing/Temporary/LastTest.log.
summarize_tests() {
  local dir=$1 log="$1/ctest.log" total failed skipped
  total=$(sed -n 's/.* tests failed out of \([0-9]*\)$/\1/p' "$log" | tail -n 1)
  failed=$(sed -n 's/.*tests passed, \([0-9]*\) tests failed out of .*/\1/p' "$log" | tail -n 1)
  skipped=$(grep -cE '^[[:space:]]+[0-9]+ - .* \((Skipped|Disabled)\)$' "$log" || true)
  if [ -z "$total" ]; then
    summary+=("    tests: no ctest report (see $log)")
    return
  fi
  summary+=("    tests: $total run, $((total - failed - skipped)) passed, $failed failed, $skipped skipped")
  local name reason
  while IFS= read -r name; do
    reason=$(awk -v want="$name" '
      /^[0-9]+\/[0-9]+ Test: / { sub(/^[0-9]+\/[0-9]+ Test: /, ""); current = ($0 == want); output = 0; next }
      current && /^Output:$/ { output = 1; next }
      current && /^<end of output>$/ { output = 0; next }
      current && output && /CM-SKIP:/ { sub(/.*CM-SKIP: */, ""); print; exit }' "$dir/Testing/Temporary/LastTest.log")
    summary+=("    skipped: $name -- ${reason:-no CM-SKIP line}")
  done < <(sed -nE 's/^[[:space:]]+[0-9]+ - (.*) \((Skipped|Disabled)\)$/\1/p' "$log")
  while IFS= read -r name; do
    summary+=("    failed: $name")
  done < <(sed -n '/^The following tests FAILED:/,/^$/s/^[[:space:]]\{1,\}[0-9]\{1,\} - //p' "$log")
}

# CPU time of a stage (user + system of this shell's finished children), which next to its wall time shows how
# busy the cores were: cpu_mark FILE writes the bash `times` report (in this shell: a subshell's would be its
# own), cpu_seconds_between FILE1 FILE2 prints the children's CPU seconds between the two marks.
cpu_mark() { times >"$1"; }
cpu_seconds_between() {
  awk 'FNR == 2 { t = 0; for (i = 1; i <= 2; ++i) { split($i, a, /[ms]/); t += a[1] * 60 + a[2] }
                  if (FILENAME == ARGV[1]) t0 = t; else t1 = t }
       END { printf "%d\n", t1 - t0 }' "$1" "$2"
}

# Configures, builds and tests one configuration; never exits the script (the caller records a failure).
run_config() {
  local name=$1; shift
  local dir="build-$name"
  local ctest_args=(--test-dir "$dir" -j "$jobs" --timeout 900)
  local t0=$SECONDS t_configure t_build t_ctest
  echo "=== [$name] configure + build ($dir) ==="
  mkdir -p "$dir"
  # Ninja for a new build tree (a tree configured earlier keeps its generator; CMake refuses to switch).
  local generator=()
  if [ ! -f "$dir/CMakeCache.txt" ] && command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
  if ! cmake -S . -B "$dir" "${generator[@]}" "${launcher[@]}" -DCM_DEBUG_INFO="$debug_info" -DCM_UNITY_BUILD="$unity" \
       -DCM_TESTS_O1=ON "$@" >"$dir/configure.log" 2>&1; then
    cat "$dir/configure.log"
    summary+=("$name: FAILED at configure ($((SECONDS - t0)) s; log $dir/configure.log)")
    return 1
  fi
  t_configure=$((SECONDS - t0)); t0=$SECONDS
  cpu_mark "$dir/.cpu-0"
  local build_args=()
  if [ "$name" = fuzz ]; then build_args=(--target cm_fuzz_all); fi  # only what the fuzzers link, and their seeds
  if ! cmake --build "$dir" -j "$jobs" "${build_args[@]}"; then
    summary+=("$name: FAILED at build (configure $t_configure s, build $((SECONDS - t0)) s)")
    return 1
  fi
  t_build=$((SECONDS - t0)); t0=$SECONDS
  cpu_mark "$dir/.cpu-1"
  case "$name" in
    # The host run holds the LCM missions, whose processes wait on the network and on timers: at one test per
    # core the cores idle a third of the time, at cores + 1 tests still a quarter (CPU 762 s in 516 s on 2
    # cores), so two more tests than cores run at once (profiling/RESULTS.md "CI time").
    host) ctest_args=(--test-dir "$dir" -j "$((jobs + 2))" --timeout 900) ;;
    ipc)
      if ! grep -qw avx2 /proc/cpuinfo || ! grep -qw fma /proc/cpuinfo; then
        echo "=== [ipc] built; tests skipped: this CPU lacks AVX2/FMA needed by -march=skylake ==="
        summary+=("ipc: built, tests not run: this CPU lacks AVX2/FMA (configure $t_configure s, build $t_build s)")
        return 0
      fi
      ctest_args+=(-LE heavy) ;;
    *) ctest_args+=(-LE heavy) ;;
  esac
  echo "=== [$name] ctest ==="
  local rc=0
  ctest "${ctest_args[@]}" 2>&1 | tee "$dir/ctest.log" || rc=$?
  t_ctest=$((SECONDS - t0))
  cpu_mark "$dir/.cpu-2"
  local verdict=passed
  if [ $rc -ne 0 ]; then verdict=FAILED; fi
  summary+=("$name: $verdict (configure $t_configure s, build $t_build s, ctest $t_ctest s)")
  summary+=("    CPU time: build $(cpu_seconds_between "$dir/.cpu-0" "$dir/.cpu-1") s, ctest $(cpu_seconds_between \
    "$dir/.cpu-1" "$dir/.cpu-2") s ($jobs cores)")
  summarize_tests "$dir"
  if [ $rc -ne 0 ]; then failure_digest "$name" "$dir"; return $rc; fi
}

# After a failed ctest: the failed tests and the lines of their logs that say why (a test script's own error
# lines, "name.sh: ...", included). -j interleaves the tests' own output, and a CI log is often read from its
# tail: the digest goes to $dir/failure-digest.txt too, and is printed again after the summary.
failure_digest() {
  local name=$1 dir=$2 log="$2/Testing/Temporary/LastTest.log"
  {
    echo "=== [$name] failure digest ==="
    if [ -f "$dir/Testing/Temporary/LastTestsFailed.log" ]; then
      sed 's/^/  failed: /' "$dir/Testing/Temporary/LastTestsFailed.log"
    fi
    if [ -f "$log" ]; then
      grep -a -E "^[0-9]+/[0-9]+ Testing:|Test Failed|^[A-Za-z0-9_.-]+\.sh: |MISMATCH|cm-fuzz:|libFuzzer: |==[0-9]+==ERROR|SUMMARY: |runtime error:|failed \(exit|the failing input|ERROR: CHECK|ERROR: REQUIRE|\[doctest\] test cases:.*[1-9][0-9]* failed|Segmentation|Aborted|Timeout" \
        "$log" | cut -c1-300 | tail -n 60 | sed 's/^/  /'
    fi
    echo "=== [$name] FAILED (full log: $log) ==="
  } | tee "$dir/failure-digest.txt"
  digests+=("$dir/failure-digest.txt")
}

start=$SECONDS
for c in "${configs[@]}"; do
  rc=0
  case "$c" in
    host)   run_config host -DCMAKE_BUILD_TYPE=RelWithDebInfo || rc=$? ;;
    fuzz)   run_config fuzz -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
                            -DCM_FUZZ=ON -DCM_BUILD_TESTS=OFF -DCM_BUILD_PROFILING=OFF || rc=$? ;;
    asan)   run_config asan -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Debug \
                            -DCM_SANITIZE=ON -DCM_FUZZ=ON -DCM_BUILD_PROFILING=OFF -DCM_BUILD_HEAVY_TESTS=OFF || rc=$? ;;
    jetson) run_config jetson -DCMAKE_BUILD_TYPE=Release -DCMAKE_TOOLCHAIN_FILE=toolchains/aarch64-jetson-nano.cmake \
                              -DCM_BUILD_PROFILING=OFF -DCM_BUILD_HEAVY_TESTS=OFF || rc=$? ;;
    ipc)    run_config ipc -DCMAKE_BUILD_TYPE=Release -DCMAKE_TOOLCHAIN_FILE=toolchains/x86_64-ipc6000.cmake || rc=$? ;;
  esac
  if [ $rc -ne 0 ]; then failed_configs+=("$c"); fi
done
echo "=== summary ($((SECONDS - start)) s) ==="
printf '  %s\n' "${summary[@]}"
if [ ${#failed_configs[@]} -gt 0 ]; then
  if [ ${#digests[@]} -gt 0 ]; then cat "${digests[@]}"; fi
  echo "=== FAILED: ${failed_configs[*]} ==="
  exit 1
fi
