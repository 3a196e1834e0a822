#!/usr/bin/env bash
# One command on a fresh Debian 12: install dependencies, build, run the whole test suite,
# then the sanitizer suite and a short fuzz run.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DDYNFILTER_WERROR=ON
cmake --build build
ctest --test-dir build --output-on-failure -j"$(nproc)"

# --- Sanitizer suite and short fuzz run (README "Fuzzing and sanitizers") --------------
# The unit tests again, built with gcc's AddressSanitizer + UndefinedBehaviorSanitizer in
# build-asan (every UB report fatal; -O1 keeps them fast), without the tests that are slow
# or measure real time (real-time processes, paper results, plots, packaging, Java/Python).
# Then every fuzz target for a few seconds (fuzz/run.sh, clang + libFuzzer, build-fuzz).
# DYNFILTER_SANITIZERS=0 skips the sanitizer suite, DYNFILTER_FUZZ_SECONDS=0 the fuzz run.
if [ "${DYNFILTER_SANITIZERS:-1}" != 0 ]; then
  # No -fsanitize=vptr: gcc 12's vptr instrumentation of lcm-cpp 1.3.1's untyped
  # subscription callback (a pointer-to-member call in a static function) crashes it — a
  # five-line program subscribing on memq:// or udpm:// SEGVs with vptr and runs clean with
  # ASan alone or with every other UBSan check (fuzz/README.md). No -fsanitize=null and
  # alignment either: in gcc they instrument every Eigen member access and make this build
  # 1.6x slower to build (BENCHMARKS.md: 624 s against 393 s on 2 cores); ASan still stops
  # on any dereference of a null pointer (SEGV), x86 reads misaligned data correctly, and
  # the clang fuzz build keeps both checks. EIGEN_MALLOC_ALREADY_ALIGNED=1: under ASan,
  # Eigen would otherwise switch to its
  # own aligned malloc/free (it does when __SANITIZE_ADDRESS__ is defined) while Debian's
  # DART, built without ASan, uses plain malloc/free for the same Eigen objects: each side
  # would free the other's blocks wrongly (ASan: heap-buffer-overflow in
  # Eigen::internal::handmade_aligned_free).
  export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1"
  # One third-party leak is suppressed (DART's Bullet mesh shapes): fuzz/sanitizers/lsan.supp.
  export LSAN_OPTIONS="suppressions=$PWD/fuzz/sanitizers/lsan.supp"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  # No -Werror here: gcc's flow warnings are noisy under the sanitizers (e.g.
  # -Wmaybe-uninitialized inside <regex>); the Release build above checks the warnings.
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize=vptr,null,alignment -fno-sanitize-recover=undefined -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1" \
    -DDYNFILTER_BUILD_BENCHMARKS=OFF -DDYNFILTER_BUILD_PYTHON=OFF -DDYNFILTER_LCM_VENV="$PWD/build/venv"
  # Every test executable and fuzz replay driver but test_processes and
  # test_realtime_closed_loop, whose tests are all excluded below (real-time rates; the
  # whole closed-loop runs). The allocation tests skip here: ASan owns malloc, so
  # tests/support/allocation_counter.cpp counts nothing in this build.
  asan_targets="$(ninja -C build-asan -t targets all |
    sed -n 's/^\(test_[a-z0-9_]*\|fuzz_replay_[a-z0-9_]*\): phony$/\1/p' |
    grep -vxE 'test_processes|test_realtime_closed_loop')"
  cmake --build build-asan --target $asan_targets
  # real_descriptions_*, model_info_* and diagnose_reseeds_kick run dynfilter-model-info
  # (and the TALOS walk and the kick's diagnosis, dynfilter-bvh2ref and dynfilter-offline;
  # bvh_conventions, dynfilter-bvh2ref), programs this build does not make
  # (test executables only); the loaders and both backends run here under the test_urdf
  # and test_backends cases of the same descriptions' edge cases.
  # ReferenceCleanup.ShippedClipsHaveStillFeetAndNoJumps cleans every shipped clip up with
  # the defaults: 30 s in Release since the balance stage is on, beyond the 600 s timeout
  # here. Balance.TheCmuWalksStance… cleans the whole walk up (17 s in Release, 225 s here:
  # ProxQP's dense factorisations at -O1, one core for a quarter of this suite's time). The
  # Release run keeps both; here the clean-up runs on the walk's first 2.5 s
  # (ReferenceCleanup.AFiveJointLeg…) and on closed-form motions (ReferenceBalance.*,
  # ReferenceCleanup.*), and the balance layer on the same walk's first steps, raw
  # (Balance.TheRawCmuWalks…: a re-seed and relaxed ticks among them).
  # (The QP-mode tests run here too: ProxQP 0.7.2 read uninitialised bools of its workspace,
  # which UBSan caught; solvers/proxqp now initialises them.)
  # RealtimeClosedLoop.* (10 whole closed-loop runs, 125 s here) run in Release only: the
  # real-time filter and the measured-state path they drive run here under Realtime.* and
  # Modes/ClosedLoopOn*. ClosedLoopOnDart.WithDartsDefaultContactsTheFeetRock (64 s here)
  # shows why the simulator changes DART's contact settings; the paths it drives run here
  # in Modes/ClosedLoopOnDart.*, and the Release run keeps it.
  ctest --test-dir build-asan --output-on-failure -j"$(nproc)" -E "$(printf '%s|' \
    '_NOT_BUILT$' '^LcmProcesses\.' '^soak' '^paper_results' '^plot_lcm_log$' '^exported_package' \
    '^lcm_python_types$' '^lcm_spy_' '^human_figure_is_regenerated' '^core_include_guard' \
    '^examples_build' '^python_' '^balance_matrix_' '^real_descriptions_' '^model_info_' '^diagnose_reseeds_kick$' '^bvh_conventions$' \
    '^ReferenceCleanup\.ShippedClipsHaveStillFeetAndNoJumps$' '^Balance\.TheCmuWalksStance' \
    '^Engines/RealtimeClosedLoop\.' \
    '^ClosedLoopOnDart\.WithDartsDefaultContactsTheFeetRock$' \
    | sed 's/|$//')"
  unset ASAN_OPTIONS UBSAN_OPTIONS LSAN_OPTIONS
fi
if [ "${DYNFILTER_FUZZ_SECONDS:-20}" != 0 ]; then
  FUZZ_JOBS="$(nproc)" fuzz/run.sh "${DYNFILTER_FUZZ_SECONDS:-20}"
fi
