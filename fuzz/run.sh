#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan, build dir build-fuzz) and runs every
# target for a bounded time, as many at once as there are cores.
#
#   fuzz/run.sh [seconds-per-target]          (default 60; tools/run-tests.sh runs 20)
#
# Environment: FUZZ_TARGETS="urdf bvh ..." (default: all), FUZZ_JOBS (default: nproc),
# FUZZ_BUILD_DIR (default: build-fuzz), FUZZ_EXTRA_ARGS (more libFuzzer flags).
# The working corpus of each target, build-fuzz/corpus/<target>/, starts from
# fuzz/seeds/<target>/ and the project's real files and keeps what the runs add.
# Exit status 1 when any target found something: the input is in
# build-fuzz/artifacts/<target>/, the report in build-fuzz/logs/<target>.log. Reproduce
# with `build-fuzz/fuzz/fuzz_<target> <input>`; once fixed, copy the input to
# fuzz/regressions/<target>/ (fuzz/README.md).
set -euo pipefail
cd "$(dirname "$0")/.."
repo="$(pwd)"
seconds="${1:-60}"
build="${FUZZ_BUILD_DIR:-build-fuzz}"
jobs="${FUZZ_JOBS:-$(nproc)}"
targets=(${FUZZ_TARGETS:-urdf reference_csv bvh retarget_mapping config lcm})

if ! command -v clang++ >/dev/null; then
  echo "fuzz/run.sh: clang++ not found (tools/install-deps.sh installs it)" >&2
  exit 2
fi
if [ ! -f "$build/build.ninja" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
    -DDYNFILTER_BUILD_FUZZERS=ON -DDYNFILTER_BUILD_TESTS=OFF -DDYNFILTER_BUILD_BENCHMARKS=OFF \
    -DDYNFILTER_WERROR=ON -DDYNFILTER_LCM_VENV="$repo/build/venv" >/dev/null
fi
cmake --build "$build" --target dynfilter_fuzzers

# Seeds: the checked-in ones, the regressions, and the real files of the repo (small ones;
# the BVH clips and the squat are checked in truncated under fuzz/seeds).
seed_files() {
  case "$1" in
    urdf) ls models/*.urdf tests/models/*.urdf ;;
    config) ls tools/config/*.yaml ;;
    retarget_mapping) ls data/mocap/cmu/mappings/*.yaml ;;
  esac
  find "fuzz/seeds/$1" "fuzz/regressions/$1" -type f ! -name '.*' 2>/dev/null || true
}
dict_of() {
  case "$1" in
    urdf) echo fuzz/dict/urdf.dict ;;
    reference_csv) echo fuzz/dict/reference_csv.dict ;;
    bvh) echo fuzz/dict/bvh.dict ;;
    retarget_mapping|config) echo fuzz/dict/yaml.dict ;;
  esac
}

mkdir -p "$build/logs"
for t in "${targets[@]}"; do
  mkdir -p "$build/corpus/$t" "$build/artifacts/$t"
  seed_files "$t" | while read -r f; do cp -n "$f" "$build/corpus/$t/seed-$(basename "$f")"; done
done

export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
run_one() {
  local t="$1" dict
  dict="$(dict_of "$t")"
  # -timeout: one input taking longer is a finding (hang); -rss_limit_mb / -malloc_limit_mb:
  # an input making the parser allocate more than that is a finding (memory blow-up).
  if "$build/fuzz/fuzz_$t" "$build/corpus/$t" -max_total_time="$seconds" \
       -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 -max_len=32768 \
       -print_final_stats=1 -artifact_prefix="$build/artifacts/$t/" \
       ${dict:+-dict=$dict} ${FUZZ_EXTRA_ARGS:-} >"$build/logs/$t.log" 2>&1; then
    echo "PASS $t"
  else
    echo "FAIL $t"
  fi
}
export -f run_one
export build seconds FUZZ_EXTRA_ARGS
export -f dict_of

echo "fuzzing ${#targets[@]} targets for ${seconds} s each, ${jobs} at a time"
results="$(printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c 'run_one {}')"

status=0
printf '%-18s %-5s %12s %10s %8s\n' target result executions exec/s corpus
for t in "${targets[@]}"; do
  log="$build/logs/$t.log"
  result="$(grep -E "^(PASS|FAIL) $t\$" <<<"$results" | cut -d' ' -f1)"
  execs="$(grep -oE 'stat::number_of_executed_units: +[0-9]+' "$log" | grep -oE '[0-9]+$' || echo '?')"
  rate="$(grep -oE 'stat::average_exec_per_sec: +[0-9]+' "$log" | grep -oE '[0-9]+$' || echo '?')"
  printf '%-18s %-5s %12s %10s %8s\n' "$t" "$result" "$execs" "$rate" \
    "$(find "$build/corpus/$t" -type f | wc -l)"
  if [ "$result" != PASS ]; then
    status=1
    echo "--- $t: $log" >&2
    pattern='ERROR:|runtime error|undocumented exception|post-condition|deadly signal|Test unit'
    grep -E -A25 "$pattern" "$log" | head -60 >&2 || tail -30 "$log" >&2
  fi
done
exit $status
