#!/usr/bin/env bash
# Distributed TNNMG on step-42 (bench/distributed), 1 and 2 ranks side by side (RANKS="1 2 4 8" for
# more; oversubscribed beyond the cores, so compare counts, not times), for the given refinements
# (default 3 4): writes the rows to OUT.tsv and prints the Markdown tables of
# docs/performance.md#distributed (ratios to 1 rank from the same script run; the communication per
# TNNMG iteration of the largest rank). scripts/cluster_model.py reads OUT.tsv.
#   scripts/distributed_bench.sh OUT.tsv [REFINE...]
set -euo pipefail
out=${1:?usage: scripts/distributed_bench.sh OUT.tsv [REFINE...]}
shift
levels=("${@:-3 4}")
[[ $# -eq 0 ]] && levels=(3 4)
bench=${BENCH:-build/bench/distributed}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
rm -f "$out"
for k in "${levels[@]}"; do
  for np in ${RANKS:-1 2}; do
    mpirun --oversubscribe -np "$np" "$bench" "$out" --refine "$k"
  done
done
/usr/bin/python3 - "$out" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1]), delimiter='\t'))
print('| refine | unknowns | ranks | solve s | iterations | load | memory per rank MB (largest) | leaves held (largest) | ghosts | messages / values per update | solve speed-up | memory ratio |')
print('|---|---|---|---|---|---|---|---|---|---|---|---|')
one = {}
for r in rows:
    if r['ranks'] == '1': one[r['refine']] = r
for r in rows:
    base = one.get(r['refine'])
    speed = float(base['solve_s']) / float(r['solve_s']) if base else float('nan')
    mem = float(r['memory_max_mb']) / float(base['memory_max_mb']) if base else float('nan')
    print(f"| {r['refine']} | {int(r['unknowns']):,} | {r['ranks']} | {float(r['solve_s']):.2f} | {r['iterations']} | "
          f"{float(r['load']):.3f} | {float(r['memory_max_mb']):.0f} | {int(float(r['leaves_max'])):,} of {int(r['leaves_global']):,} | "
          f"{int(float(r['ghosts_max'])):,} | {int(float(r['messages_max']))} / {int(float(r['values_max'])):,} | {speed:.2f} | {mem:.2f} |")
print()
print('| refine | ranks | colours | neighbour exchanges per iteration | messages sent per iteration | KB sent per iteration | reductions per iteration | values reduced per iteration |')
print('|---|---|---|---|---|---|---|---|')
for r in rows:
    it = int(r['iterations'])
    print(f"| {r['refine']} | {r['ranks']} | {r['colours']} | {int(r['exchanges']) / it:.1f} | {int(r['messages_sent_max']) / it:.1f} | "
          f"{int(r['bytes_sent_max']) / it / 1024:.0f} | {int(r['reductions']) / it:.1f} | {int(r['reduced_values_max']) / it:,.0f} |")
PY
