#!/usr/bin/env bash
# One process before and after a change (docs/architecture.md#one-path): runs the scenes of the
# one-path criterion with two obs binaries side by side, alternating, and prints per scene the best
# wall time and the peak resident memory (GNU time) of each binary and their ratios (new / base).
# The criterion is a ratio of at most 1.05 for both on every scene.
#
#   scripts/one_path_speed.sh BASE_REV OUT.md [ROUNDS]   # builds BASE_REV's obs in build-base/
#   BASE_OBS=path/to/obs scripts/one_path_speed.sh - OUT.md [ROUNDS]
#
# The measured binary is build/drivers/obs (NEW_OBS to change it). ROUNDS (default 3) runs of each
# binary per scene, alternately; the times are the fastest round, the memory the largest. QUICK=1
# runs the small versions of the scenes (step-42 at refine 3, 100 dynamics steps; a smoke test of
# the script, not the criterion). Each run uses one thread (OMP_NUM_THREADS=1, OPENBLAS_NUM_THREADS=1).
set -euo pipefail
base_rev=${1:?usage: scripts/one_path_speed.sh BASE_REV|- OUT.md [ROUNDS]}
out=${2:?usage: scripts/one_path_speed.sh BASE_REV|- OUT.md [ROUNDS]}
rounds=${3:-3}
root=$(cd "$(dirname "$0")/.." && pwd)
new=${NEW_OBS:-$root/build/drivers/obs}
[[ -x "$new" ]] || { echo "one_path_speed.sh: $new is not built (make build)" >&2; exit 2; }
[[ -x /usr/bin/time ]] || { echo "one_path_speed.sh: needs GNU time (apt-get install time)" >&2; exit 2; }

if [[ "$base_rev" == "-" ]]; then
  base=${BASE_OBS:?one_path_speed.sh: with BASE_REV '-' set BASE_OBS to the baseline obs binary}
else
  # the baseline commit's obs, built once in a worktree beside this checkout
  src=$root/build-base/src
  if [[ ! -d "$src" ]]; then
    git -C "$root" worktree add --detach "$src" "$base_rev" >&2
  else
    git -C "$src" checkout --quiet --detach "$base_rev"
  fi
  cmake -S "$src" -B "$root/build-base/build" -DCMAKE_BUILD_TYPE=Release -DOBS_BUILD_BENCH=OFF >&2
  cmake --build "$root/build-base/build" -j"$(nproc)" --target obs_cli >&2
  base=$root/build-base/build/drivers/obs
fi

scenes=(
  "step42 64^3|$root/data/scenes/step42.toml|--refine 4"
  "step42 128^3|$root/data/scenes/step42.toml|--refine 5"
  "Example 3B (adaptive)|$root/data/scenes/example3b.toml|"
  "Geometry 1, 1000 steps|$root/data/scenes/dynamics_block.toml|--set dynamics.steps=1000"
  "two-body Hertz|$root/data/scenes/twobody_hertz.toml|"
  "Coulomb (friction_peer)|$root/data/scenes/friction_peer.toml|"
)
if [[ -n "${QUICK:-}" ]]; then
  scenes=(
    "step42 32^3|$root/data/scenes/step42.toml|--refine 3"
    "Geometry 1, 100 steps|$root/data/scenes/dynamics_block.toml|--set dynamics.steps=100"
  )
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
# one run: "seconds kilobytes" of GNU time (the run's own outputs go to a scratch directory)
measure() {
  local bin=$1 scene=$2 args=$3
  rm -rf "$tmp/out"
  # shellcheck disable=SC2086
  if ! /usr/bin/time -f "%e %M" -o "$tmp/time" "$bin" run "$scene" $args --output "$tmp/out" -q >"$tmp/log" 2>&1; then
    echo "one_path_speed.sh: $bin run $scene $args failed:" >&2
    cat "$tmp/log" >&2
    exit 1
  fi
  cat "$tmp/time"
}

{
  echo "\`scripts/one_path_speed.sh $base_rev OUT.md $rounds\`: $rounds alternating runs per binary, one thread;"
  echo "best wall time, largest peak memory; ratio = new / base (criterion: <= 1.05)."
  echo
  echo "| scene | base s | new s | time ratio | base MB | new MB | memory ratio |"
  echo "|---|---|---|---|---|---|---|"
} >"$out"
for entry in "${scenes[@]}"; do
  IFS='|' read -r label scene args <<<"$entry"
  bt=1e9 nt=1e9 bm=0 nm=0
  for ((k = 0; k < rounds; k++)); do
    res=$(measure "$base" "$scene" "$args")
    read -r t m <<<"$res"
    bt=$(awk -v a="$bt" -v b="$t" 'BEGIN { print (b < a ? b : a) }')
    bm=$((m > bm ? m : bm))
    res=$(measure "$new" "$scene" "$args")
    read -r t m <<<"$res"
    nt=$(awk -v a="$nt" -v b="$t" 'BEGIN { print (b < a ? b : a) }')
    nm=$((m > nm ? m : nm))
  done
  awk -v l="$label" -v bt="$bt" -v nt="$nt" -v bm="$bm" -v nm="$nm" 'BEGIN {
    printf "| %s | %.2f | %.2f | %.3f | %.0f | %.0f | %.3f |\n", l, bt, nt, (bt > 0 ? nt / bt : 0), bm / 1024, nm / 1024, nm / bm
  }' >>"$out"
  echo "one_path_speed.sh: $label done" >&2
done
cat "$out"
