#!/usr/bin/python3
"""The Markdown tables of bench/distributed's rows (docs/performance.md#distributed):

  scripts/distributed_tables.py ranks OUT.tsv   # scripts/distributed_bench.sh: per refinement and
                                                # rank count, with the ratios to 1 rank
  scripts/distributed_tables.py weak OUT.tsv    # scripts/distributed_weak.sh: per rank count
  scripts/distributed_tables.py coarse A.tsv B.tsv  # two distributed_weak.sh series side by side: the
                                                # default partition level (A) and PARTITION_LEVEL=0 (B)

ranks and weak print a second table: the communication per TNNMG iteration of the largest rank
(Communicator::counts() over the solve).
"""
import csv
import sys


def communication(rows, lead):
    """The communication table; lead: (header, value of a row) pairs of the first columns. Rows with a
    distributed coarse level (partition level 0) add the CG iterations of its hypre solves per
    iteration: hypre communicates through MPI itself, outside Communicator::counts()."""
    hypre = 'coarse_iterations' in rows[0] and any(r['partition_level'] == '0' for r in rows)
    print('| ' + ' | '.join(h for h, _ in lead) + ' | neighbour exchanges per iteration | messages sent per iteration | '
          'KB sent per iteration | reductions per iteration | values reduced per iteration |' +
          (' coarse CG iterations per iteration (hypre) |' if hypre else ''))
    print('|' + '---|' * (len(lead) + 5 + (1 if hypre else 0)))
    for r in rows:
        it = int(r['iterations'])
        print('| ' + ' | '.join(str(f(r)) for _, f in lead) +
              f" | {int(r['exchanges']) / it:.1f} | {int(r['messages_sent_max']) / it:.1f} | "
              f"{int(r['bytes_sent_max']) / it / 1024:.0f} | {int(r['reductions']) / it:.1f} | "
              f"{int(r['reduced_values_max']) / it:,.0f} |" +
              (f" {int(r['coarse_iterations']) / it:.1f} |" if hypre else ''))


def ranks_tables(rows):
    print('| refine | unknowns | ranks | solve s | iterations | load | memory per rank MB (largest) | leaves held (largest) | '
          'ghosts | messages / values per update | solve speed-up | memory ratio |')
    print('|---|---|---|---|---|---|---|---|---|---|---|---|')
    one = {r['refine']: r for r in rows if r['ranks'] == '1'}
    for r in rows:
        base = one.get(r['refine'])
        speed = float(base['solve_s']) / float(r['solve_s']) if base else float('nan')
        mem = float(r['memory_max_mb']) / float(base['memory_max_mb']) if base else float('nan')
        print(f"| {r['refine']} | {int(r['unknowns']):,} | {r['ranks']} | {float(r['solve_s']):.2f} | {r['iterations']} | "
              f"{float(r['load']):.3f} | {float(r['memory_max_mb']):.0f} | "
              f"{int(float(r['leaves_max'])):,} of {int(r['leaves_global']):,} | {int(float(r['ghosts_max'])):,} | "
              f"{int(float(r['messages_max']))} / {int(float(r['values_max'])):,} | {speed:.2f} | {mem:.2f} |")
    print()
    communication(rows, [('refine', lambda r: r['refine']), ('ranks', lambda r: r['ranks']),
                         ('colours', lambda r: r['colours'])])


def weak_tables(rows):
    print('| ranks | coarse cells | unknowns | owned vertices per rank (min-max) | iterations | ghosts (largest) | colours | '
          'messages / values per update (largest) | leaves held (largest) / leaves per rank | '
          'memory per rank MB (largest) |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for r in rows:
        per = int(r['leaves_global']) / int(r['ranks'])
        print(f"| {r['ranks']} | {r['cells'].replace(',', ' x ')} | {int(r['unknowns']):,} | "
              f"{int(r['owned_min']):,}-{int(r['owned_max']):,} | {r['iterations']} | {int(r['ghosts_max']):,} | "
              f"{r['colours']} | {int(r['messages_max'])} / {int(r['values_max']):,} | "
              f"{int(r['leaves_max']) / per:.2f} | {float(r['memory_max_mb']):.0f} |")
    print()
    communication(rows, [('ranks', lambda r: r['ranks']), ('iterations', lambda r: r['iterations']),
                         ('V-cycles', lambda r: r['vcycles'])])


def coarse_table(replicated, distributed):
    """Two distributed_weak.sh series side by side, by rank count: the default partition level
    (replicated coarse levels) and PARTITION_LEVEL=0 (the coarse level distributed, hypre)."""
    other = {r['ranks']: r for r in distributed}
    print('| ranks | unknowns | partition level | iterations | leaves held (largest) / leaves per rank | '
          'memory per rank MB (largest) | values reduced per iteration | coarse CG iterations per iteration (hypre) | '
          'solve s (oversubscribed beyond 2) |')
    print('|---|---|---|---|---|---|---|---|---|')
    for a in replicated:
        b = other.get(a['ranks'])
        if b is None:
            continue
        def pair(f, fmt):
            return f'{fmt(f(a))} / {fmt(f(b))}'
        per = int(a['leaves_global']) / int(a['ranks'])
        print(f"| {a['ranks']} | {int(a['unknowns']):,} | {a['partition_level']} / {b['partition_level']} | "
              f"{a['iterations']} / {b['iterations']} | "
              + pair(lambda r: int(r['leaves_max']) / per, lambda v: f'{v:.2f}') + ' | '
              + pair(lambda r: float(r['memory_max_mb']), lambda v: f'{v:.0f}') + ' | '
              + pair(lambda r: int(r['reduced_values_max']) / int(r['iterations']), lambda v: f'{v:,.0f}') + ' | '
              + f"{int(b['coarse_iterations']) / int(b['iterations']):.1f} | "
              + pair(lambda r: float(r['solve_s']), lambda v: f'{v:.2f}') + ' |')


def main():
    if len(sys.argv) == 4 and sys.argv[1] == 'coarse':
        coarse_table(*(list(csv.DictReader(open(f), delimiter='\t')) for f in sys.argv[2:]))
        return
    if len(sys.argv) != 3 or sys.argv[1] not in ('ranks', 'weak'):
        sys.exit('usage: scripts/distributed_tables.py ranks|weak OUT.tsv | coarse REPLICATED.tsv DISTRIBUTED.tsv')
    rows = list(csv.DictReader(open(sys.argv[2]), delimiter='\t'))
    (ranks_tables if sys.argv[1] == 'ranks' else weak_tables)(rows)


if __name__ == '__main__':
    main()
