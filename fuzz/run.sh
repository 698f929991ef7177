#!/usr/bin/env bash
# Runs each fuzz target for a while: fuzz/run.sh [SECONDS [TARGET...]] (default 30 s, all).
# FUZZ_MODE=auto (default), nightly or stable chooses the build below.
#
# With a nightly toolchain and cargo-fuzz (installed from crates.io if missing), targets run under
# cargo-fuzz with AddressSanitizer and coverage feedback. Without a nightly (a fresh machine has
# only the stable toolchain), the same targets are built on stable as a debug build (overflow
# checks and debug assertions on) with the same coverage instrumentation but no sanitizer, and
# libFuzzer replays the seeds and corpus and mutates them, guided by coverage, for the time
# given: a crash, panic, timeout or out-of-memory fails either way.
#
# The corpus grows in fuzz/corpus/TARGET (git-ignored) from the seeds in fuzz/seeds/TARGET;
# from_words's seeds are scenes built by fuzz/seed.sh. A finding is written to fuzz/artifacts/.
# Each run prints libFuzzer's closing stats (execs, corpus size) on its last lines.
# FUZZ_JOBS=N runs N targets at a time (default 1; see below).
set -euo pipefail
cd "$(dirname "$0")/.."

secs=${1:-30}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(from_words ply obj scene traversal exr instances)
fi

# -rss_limit_mb: a target that holds more than 2 GiB fails (the loaders' bound is far below).
flags=(-max_total_time="$secs" -rss_limit_mb=2048 -timeout=20 -print_final_stats=1)

if [ ! -d fuzz/corpus/from_words ]; then
  bash fuzz/seed.sh
fi

# FUZZ_MODE=stable forces the stable build (CI: predictable time); nightly requires one.
mode=${FUZZ_MODE:-auto}
nightly=false
if [ "$mode" = nightly ] || { [ "$mode" = auto ] && cargo +nightly --version >/dev/null 2>&1; }; then
  nightly=true
  if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
  fi
fi

host=$(rustc -vV | sed -n 's/^host: //p')
if [ "$nightly" != true ]; then
  # cargo-fuzz's coverage flags, which stable accepts (only the sanitizer needs nightly); with
  # an explicit --target they stay off the build scripts, and off the workspace's own builds.
  # All targets in one build: one resolution, and cargo compiles and links them in parallel.
  bins=()
  for t in "${targets[@]}"; do bins+=(--bin "$t"); done
  echo "== building ${targets[*]} (stable, coverage, no sanitizer)"
  RUSTFLAGS="--cfg fuzzing -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares" \
    cargo build -q --manifest-path fuzz/Cargo.toml --target "$host" "${bins[@]}"
fi

# One target's run; its summary goes to stdout, its exit status to $2 (the runs may be parallel).
run_one() {
  local t=$1 rc_file=$2 log status seeds=()
  [ -d "fuzz/seeds/$t" ] && seeds=("fuzz/seeds/$t")
  echo "== fuzz $t for ${secs}s ($([ "$nightly" = true ] && echo 'nightly, ASan' || echo 'stable, no sanitizer'))"
  log=$(mktemp)
  set +e
  if [ "$nightly" = true ]; then
    cargo +nightly fuzz run -O "$t" "fuzz/corpus/$t" "${seeds[@]}" -- \
      -artifact_prefix="fuzz/artifacts/$t/" "${flags[@]}" >"$log" 2>&1
  else
    "${CARGO_TARGET_DIR:-fuzz/target}/$host/debug/$t" "fuzz/corpus/$t" "${seeds[@]}" \
      -artifact_prefix="fuzz/artifacts/$t/" "${flags[@]}" >"$log" 2>&1
  fi
  status=$?
  set -e
  grep -E '^(#[0-9]+ +DONE|stat::|INFO: (Running|Loaded|seed corpus))|ERROR|panicked|SUMMARY' "$log" | tail -n 16
  rm -f "$log"
  echo "$status" >"$rc_file"
}

# FUZZ_JOBS targets at a time (default 1). Each libFuzzer run is single-threaded, so on a
# machine with spare cores (CI: 2) two at once halve the wall time at the same fuzzing time each.
jobs_max=${FUZZ_JOBS:-1}
out=$(mktemp -d)
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do
    wait -n || true
  done
  run_one "$t" "$out/$t.rc" >"$out/$t.out" 2>&1 &
done
wait
failed=0
for t in "${targets[@]}"; do
  cat "$out/$t.out"
  status=$(cat "$out/$t.rc" 2>/dev/null || echo 1)
  if [ "$status" -ne 0 ]; then
    echo "fuzz target $t failed (exit $status); see fuzz/artifacts/$t/" >&2
    failed=$status
  fi
done
rm -rf "$out"
exit "$failed"
