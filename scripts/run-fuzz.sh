#!/usr/bin/env bash
# Hostile testing of vmsim's input readers (README, "Hostile testing"). Run as root on Debian 12
# (it installs clang): builds fuzz/ with clang and ASan + UBSan (+ libFuzzer coverage) in
# build-fuzz/, runs the readers' and loaders' unit tests under the sanitizers, replays the saved
# reproducers (fuzz/regressions/<target>/), then fuzzes each reader for a bounded time from a
# seed corpus (fuzz/seeds/<target>/ and the samples, copied at run time) with the reader's
# dictionary (fuzz/dicts/<target>.dict).
#
# Prints per target the executions and coverage; exits non-zero on any failing sanitizer test,
# crash, uncaught exception, leak, timeout, out-of-memory or sanitizer report. The input that
# failed is kept under build-fuzz/crashes/<target>/.
#
# Environment:
#   VMSIM_FUZZ_SECONDS    fuzzing time per target [s] (60)
#   VMSIM_FUZZ_RUNS       instead of a time: this many inputs per target, from a fixed seed
#                         (-seed=1), so that a run repeats exactly (CI: what passed here passes
#                         there; a new finding comes from a change, not from chance)
#   VMSIM_FUZZ_PARALLEL   targets fuzzed at once (2)
#   VMSIM_FUZZ_TARGETS    targets to run, space-separated (all nine)
#   VMSIM_FUZZ_TIMEOUT    one input slower than this [s] is a hang (10)
#   VMSIM_FUZZ_MAX_LEN    largest input [bytes] (16384; longer seeds are cut)
#   VMSIM_FUZZ_ARGS       further libFuzzer flags, e.g. "-fork=1 -ignore_crashes=1" to go on
#                         after a finding (local runs)
#   VMSIM_FUZZ_BUILD_DIR  build folder (build-fuzz)
#   VMSIM_FUZZ_SKIP_TESTS 1: skip the sanitizer unit tests
#   VMSIM_JOBS            parallel compile jobs (nproc)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build_dir=${VMSIM_FUZZ_BUILD_DIR:-build-fuzz}
seconds=${VMSIM_FUZZ_SECONDS:-60}
runs=${VMSIM_FUZZ_RUNS:-}
if [[ -n "$runs" ]]; then budget=(-runs="$runs" -seed=1); else budget=(-max_total_time="$seconds"); fi
parallel=${VMSIM_FUZZ_PARALLEL:-2}
timeout=${VMSIM_FUZZ_TIMEOUT:-10}
max_len=${VMSIM_FUZZ_MAX_LEN:-16384}
jobs=${VMSIM_JOBS:-$(nproc)}
read -r -a targets <<< "${VMSIM_FUZZ_TARGETS:-gcode heidenhain siemens apt trace machine_yaml part_file stl urdf}"
read -r -a extra_args <<< "${VMSIM_FUZZ_ARGS:-}"
started=$SECONDS

# clang and its sanitizer/libFuzzer runtimes; llvm-14 for llvm-symbolizer (reports with lines).
bash scripts/setup-debian.sh clang-14 libclang-rt-14-dev llvm-14

mkdir -p "$build_dir"
cmake -S fuzz -B "$build_dir" -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  > "$build_dir/configure.log" 2>&1 || {
  cat "$build_dir/configure.log" >&2
  echo "fuzz: configuring failed (log above)" >&2
  exit 1
}
cmake --build "$build_dir" -j"$jobs"
build_s=$((SECONDS - started))

logs=$build_dir/logs
rm -rf "$logs"
mkdir -p "$logs" "$build_dir/crashes"
export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
export ASAN_OPTIONS=abort_on_error=0:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Leaks inside system libraries on their error paths, not ours: documented in the file.
export LSAN_OPTIONS=suppressions=$root/fuzz/lsan.supp:print_suppressions=0
failures=()

# 1. The unit tests of the readers and loaders under ASan + UBSan.
tests_s=0
if [[ "${VMSIM_FUZZ_SKIP_TESTS:-0}" != 1 ]]; then
  tests_started=$SECONDS
  for test in test_common_asan test_machine_loader_asan test_toolpath_readers_asan; do
    if (cd "$build_dir" && "./$test") > "$logs/$test.log" 2>&1; then
      echo "fuzz: $test: $(grep -E '^\[  PASSED  \]' "$logs/$test.log" || echo passed)"
    else
      tail -n 60 "$logs/$test.log" >&2
      echo "fuzz: $test FAILED (log above, whole in $logs/$test.log)" >&2
      failures+=("$test")
    fi
  done
  tests_s=$((SECONDS - tests_started))
fi

# 2. Seeds from the samples, copied at run time (cut to max_len: libFuzzer would cut them).
seed_samples() {
  local target=$1
  case $target in
    gcode) find tests/data samples -name '*.nc' -o -name '*.ngc' ;;
    siemens) find tests/data samples -name '*.mpf' -o -name '*.spf' ;;
    heidenhain) find tests/data samples -name '*.h' ;;
    apt) find tests/data samples -name '*.apt' -o -name '*.cl' -o -name '*.cls' ;;
    machine_yaml) find samples/machines -name '*.yaml' ;;
    urdf) find samples/machines -name '*.urdf' ;;
    part_file) find samples/parts -name 'part.yaml' ;;
    stl) find samples tests/data -name '*.stl' ;;
    trace) find samples tests/data -name '*.csv' ;;
  esac
}

# 3. Replay the reproducers, then fuzz; one result line per target in $logs/<target>.result.
fuzz_target() {
  local target=$1 program=$build_dir/fuzz_$1 log=$logs/fuzz_$1.log status=ok finding=0
  local seeds=$build_dir/seeds/$target corpus=$build_dir/corpus/$target
  local crashes=$build_dir/crashes/$target
  rm -rf "$seeds"
  mkdir -p "$seeds" "$corpus" "$crashes"
  local file
  while IFS= read -r file; do
    [[ -n "$file" ]] && head -c "$max_len" "$file" > "$seeds/$(echo "$file" | tr / _)"
  done < <(seed_samples "$target")
  local replay=()
  while IFS= read -r file; do
    [[ -n "$file" ]] && replay+=("$file")
  done < <(find "fuzz/regressions/$target" -type f ! -name README 2>/dev/null | sort)
  # One process per reproducer, so that each is reported; libFuzzer does not time a replayed
  # file, hence `timeout`.
  : > "$logs/replay_$target.log"
  : > "$logs/replay_$target.failed"
  for file in "${replay[@]}"; do
    if ! timeout "$timeout" "$program" -rss_limit_mb=2048 "$file" \
        >> "$logs/replay_$target.log" 2>&1; then
      status="regression"
      echo "$file" >> "$logs/replay_$target.failed"
    fi
  done
  local dict=()
  if [[ -f "fuzz/dicts/$target.dict" ]]; then dict=(-dict="fuzz/dicts/$target.dict"); fi
  # Hand-written seeds, where the reader has any (git keeps no empty folder).
  local own_seeds=()
  if [[ -d "fuzz/seeds/$target" ]]; then own_seeds=("fuzz/seeds/$target"); fi
  "$program" "${budget[@]}" -timeout="$timeout" -rss_limit_mb=2048 \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$crashes/" "${dict[@]}" \
    "${extra_args[@]}" "$corpus" "$seeds" "${own_seeds[@]}" > "$log" 2>&1 || finding=1
  if [[ -n "$(find "$crashes" -type f -newer "$seeds" | head -n 1)" ]]; then
    finding=1  # -fork with -ignore_crashes keeps going but saves what it found
  fi
  if ((finding)); then
    if [[ $status == ok ]]; then status="finding"; else status="$status+finding"; fi
  fi
  local final execs
  final=$(grep -E '^#[0-9]+.* cov: ' "$log" | tail -n 1 || true)
  execs=$(grep -oE 'stat::number_of_executed_units: [0-9]+' "$log" | tail -n 1 | grep -oE '[0-9]+$' || true)
  echo "$target|$status|${execs:-?}|${final:-no coverage line}" > "$logs/$target.result"
}

fuzz_started=$SECONDS
running=0
for target in "${targets[@]}"; do
  if ((running >= parallel)); then
    wait -n || true
    running=$((running - 1))
  fi
  fuzz_target "$target" &
  running=$((running + 1))
done
wait || true
fuzz_s=$((SECONDS - fuzz_started))

echo
printf '%-13s %-10s %12s  %s\n' target result executions "libFuzzer's last line (cov: edges, ft: features, corp: inputs/size)"
for target in "${targets[@]}"; do
  IFS='|' read -r name status execs final < "$logs/$target.result"
  printf '%-13s %-10s %12s  %s\n' "$name" "$status" "$execs" "$final"
  if [[ $status != ok ]]; then
    failures+=("fuzz_$name ($status)")
    if [[ $status == regression* ]]; then
      while IFS= read -r file; do
        echo "  reproducer fails: $file" >&2
      done < "$logs/replay_$name.failed"
      grep -E 'ERROR: |SUMMARY: |runtime error|terminate called|what\(\)|breaks a law' \
        "$logs/replay_$name.log" | head -n 20 >&2 || true
      echo "  replay log: $logs/replay_$name.log (a reproducer without a report: over ${timeout} s)" >&2
    fi
    if grep -qE 'ERROR: |runtime error|SUMMARY: |terminate called|breaks a law' "$logs/fuzz_$name.log"; then
      grep -E 'ERROR: |runtime error|SUMMARY: |terminate called|what\(\)|breaks a law|Test unit written' \
        "$logs/fuzz_$name.log" | head -n 20 >&2 || true
      echo "  log: $logs/fuzz_$name.log; inputs: $build_dir/crashes/$name/" >&2
    fi
  fi
done
if [[ -n "$runs" ]]; then per_target="$runs inputs per target from seed 1"; else per_target="$seconds s per target"; fi
echo "fuzz: build ${build_s} s, sanitizer tests ${tests_s} s, fuzzing ${fuzz_s} s" \
     "(${per_target}, ${parallel} at once)"
if ((${#failures[@]} > 0)); then
  echo "fuzz: FAILED: ${failures[*]}" >&2
  exit 1
fi
echo "fuzz: no finding"
