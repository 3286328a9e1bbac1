#!/usr/bin/env bash
# deal.II's step-42 tutorial beside obs's step42 scene on the same ranks, at 64^3 hexahedra
# (274,625 vertices, 823,875 unknowns), one row per program and rank count in OUT.tsv:
#   - deal.II: the tutorial as shipped (elastoplastic contact with a ball obstacle; Newton with an
#     active set, BiCGStab + Trilinos ML AMG; p4est), parameters p1_global.prm with 4 cycles
#     (8^3, 16^3, 32^3, 64^3 cells); the time of its last cycle (its own TimerOutput) and of the
#     whole program; its contact force.
#   - obs: `obs run data/scenes/step42.toml --refine 4` (linear-elastic contact with the same ball,
#     TNNMG); the time of the whole program and its solve (summary.json).
#   - both: the peak resident memory of the largest rank (GNU time's %M on every rank).
# The two programs solve different problems (deal.II's material yields): compare cost per unknown,
# not forces. Needs Debian's libdeal.ii-dev and libdeal.ii-doc (the tutorial sources); not part of
# scripts/install-deps.
#   scripts/dealii_step42.sh OUT.tsv [RANKS...]     (default: 1 2)
#
# With --elastic, the forces instead: the tutorial built with the yield stress 1e10 instead of 400
# (so the material stays linear elastic, the problem of obs's step42 scene), its contact force on
# each cycle (8^3 .. 64^3 cells) beside obs's load at refine 1 .. 4 (one process).
#   scripts/dealii_step42.sh --elastic OUT.tsv [RANKS]   (default: 2)
set -euo pipefail
elastic=0
if [[ ${1:-} == --elastic ]]; then elastic=1; shift; fi
out=${1:?usage: scripts/dealii_step42.sh [--elastic] OUT.tsv [RANKS...]}
shift
ranks=("$@")
[[ ${#ranks[@]} -eq 0 ]] && ranks=(1 2)
[[ $elastic == 1 && $# -eq 0 ]] && ranks=(2)
src=/usr/share/doc/libdeal.ii-doc/examples/step-42
[[ -f $src/step-42.cc ]] || { echo "dealii_step42.sh: $src/step-42.cc missing (apt-get install libdeal.ii-dev libdeal.ii-doc)" >&2; exit 1; }
obs=${OBS:-build/drivers/obs}
[[ -x $obs ]] || { echo "dealii_step42.sh: $obs missing (build obs first)" >&2; exit 1; }
work=${WORK:-build/peers/step-42}
[[ $elastic == 1 ]] && work=${WORK:-build/peers/step-42-elastic}
mkdir -p "$work"
work=$(cd "$work" && pwd)
if [[ ! -x $work/step-42 ]]; then
  cp "$src"/* "$work"/
  if [[ $elastic == 1 ]]; then
    grep -q ', sigma_0(400.0)' "$work/step-42.cc" || { echo "dealii_step42.sh: the yield stress line of step-42.cc changed" >&2; exit 1; }
    sed -i 's/, sigma_0(400.0)/, sigma_0(1e10)/' "$work/step-42.cc"
  fi
  (cd "$work" && cmake -DCMAKE_BUILD_TYPE=Release . > cmake.log && make > make.log)
fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
sed -e 's/^set number of cycles .*/set number of cycles              = 4/' \
    -e 's|^set output directory .*|set output directory              = output|' "$work/p1_global.prm" > "$work/run.prm"

if [[ $elastic == 1 ]]; then
  rm -rf "$work/output"; mkdir -p "$work/output"
  (cd "$work" && mpirun --oversubscribe -np "${ranks[0]}" ./step-42 run.prm > run.log 2>&1)
  printf 'cells\tunknowns\tdealii_force\tobs_load\trelative_difference\n' > "$out"
  mapfile -t forces < <(awk '/Contact force =/ {print $4}' "$work/run.log")
  mapfile -t dofs < <(awk '/Number of degrees of freedom/ {print $NF}' "$work/run.log")
  for k in 1 2 3 4; do
    "$obs" run data/scenes/step42.toml --refine "$k" --output "$work/obs-$k" -q
    load=$(/usr/bin/python3 -c 'import json, sys; print("%.9g" % json.load(open(sys.argv[1]))["contact"]["load_P"])' "$work/obs-$k/summary.json")
    f=${forces[$((k - 1))]}
    printf '%d^3\t%s\t%s\t%s\t%s\n' $((4 << k)) "${dofs[$((k - 1))]}" "$f" "$load" \
      "$(/usr/bin/python3 -c 'import sys; a, b = map(float, sys.argv[1:]); print("%.1e" % (abs(a - b) / b))' "$f" "$load")" >> "$out"
  done
  column -t -s $'\t' "$out"
  exit 0
fi

# peak RSS of the largest rank from the files rss.<rank> that GNU time wrote (kB -> MB)
peak_mb() { cat "$1"/rss.* | sort -n | tail -1 | awk '{printf "%.0f", $1 / 1024}'; }

printf 'program\tranks\tunknowns\tlast_cycle_s\twhole_run_s\tsolve_s\tpeak_mb_largest_rank\titerations\tforce\n' > "$out"
for np in "${ranks[@]}"; do
  # deal.II
  rm -rf "$work/output" "$work"/rss.*; mkdir -p "$work/output"
  t0=$(date +%s.%N)
  (cd "$work" && mpirun --oversubscribe -np "$np" sh -c '/usr/bin/time -f %M -o rss.$OMPI_COMM_WORLD_RANK ./step-42 run.prm' > "run.$np.log" 2>&1)
  t1=$(date +%s.%N)
  log=$work/run.$np.log
  last=$(awk '/Total wallclock time elapsed since start/ {gsub("s","",$9); t=$9} END {print t}' "$log")
  force=$(awk '/Contact force =/ {f=$4} END {print f}' "$log")
  newton=$(awk '/^Cycle 3:/ {c=1} c && /Newton iteration/ {n++} END {print n}' "$log")
  unknowns=$(awk '/Number of degrees of freedom/ {n=$NF} END {print n}' "$log")
  printf 'deal.II step-42\t%s\t%s\t%s\t%.2f\t\t%s\t%s Newton\t%s\n' "$np" "$unknowns" "$last" "$(echo "$t1 - $t0" | bc)" \
    "$(peak_mb "$work")" "$newton" "$force" >> "$out"
  # obs
  rm -rf "$work/obs-out" "$work"/rss.*
  t0=$(date +%s.%N)
  mpirun --oversubscribe -np "$np" sh -c "/usr/bin/time -f %M -o $work/rss.\$OMPI_COMM_WORLD_RANK $obs run data/scenes/step42.toml --refine 4 --output $work/obs-out" > "$work/obs.$np.log" 2>&1
  t1=$(date +%s.%N)
  /usr/bin/python3 - "$work/obs-out/summary.json" "$np" "$(echo "$t1 - $t0" | bc)" "$(peak_mb "$work")" >> "$out" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
print("obs step42\t%s\t%d\t\t%.2f\t%.2f\t%s\t%d TNNMG\t%.3f" % (sys.argv[2], s["dofs"], float(sys.argv[3]),
      s["times"]["solve_s"], sys.argv[4], s["solver"]["iterations"], s["contact"]["load_P"]))
EOF
done
column -t -s $'\t' "$out"
