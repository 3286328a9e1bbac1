#!/usr/bin/python3
"""A model of distributed TNNMG on step-42 for clusters of 64 to 4,096 ranks, from measurements
(docs/performance.md#distributed-model).

Input: TSV rows of bench/distributed for the unit cube (scripts/distributed_bench.sh, any RANKS):
  * the 1-rank row of the largest refinement gives the work rates per unknown (solve seconds per
    TNNMG iteration, grid and assembly seconds, memory);
  * the row with the most ranks gives the communication per TNNMG iteration of the largest rank
    (Communicator::counts() over the solve: neighbour exchanges, messages, bytes, reductions and the
    values they reduce).

Model of one TNNMG iteration on P ranks of N unknowns, refinement k of the 4^3 coarse mesh
(N = 3 (4 2^k + 1)^3), partition level L_p (the coarsest level >= 1 with 8 P cells, the default of
DistributedGrid), with the counts scaled from the measured run m:
  compute     t1 * N / P * kappa
  replicated  t1 * 3 n(L_p - 1) * 8/7            (levels below L_p are smoothed on every rank)
  halo        E * alpha + B / beta               E = E_m * D / D_m (D: distributed levels k - L_p + 1;
                                                 colours and neighbours as measured on P_m ranks),
                                                 B = B_m * D / D_m * ((N/P) / (N_m/P_m))^(2/3)
  reductions  R * 2 alpha log2(P) + 2 * 8 V / beta   V = V_m * n(L_p - 1) / n_m(L_p,m - 1)
with n(l) = (4 2^l + 1)^3 the vertices of level l.
Iterations: those of the run with the most ranks plus one per further refinement (9, 10, 11 at
k = 3, 4, 5 measured). Every figure is a
prediction for a machine with the stated latency, bandwidth per rank and memory contention.

  scripts/cluster_model.py RUNS.tsv [--latency S] [--bandwidth B/s] [--contention KAPPA]
  scripts/cluster_model.py selftest
"""
import argparse
import csv
import math
import sys


def vertices(level):
    return (4 * 2 ** level + 1) ** 3


def partition_level(ranks, cells_per_part=8):
    level = 1
    while 64 * 8 ** level < cells_per_part * ranks:
        level += 1
    return level


class Model:
    """The calibrated model: rates from the 1-rank row, counts from the row with the most ranks."""

    def __init__(self, rows, latency, bandwidth, contention):
        rows = [r for r in rows if r.get('cells', '4,4,4') == '4,4,4']
        if not rows or 'exchanges' not in rows[0]:
            raise ValueError('no unit-cube rows with communication counts')
        singles = [r for r in rows if r['ranks'] == '1']
        if not singles:
            raise ValueError('no 1-rank row')
        self.one = one = max(singles, key=lambda r: int(r['unknowns']))
        self.most = most = max(rows, key=lambda r: (int(r['ranks']), int(r['unknowns'])))
        self.latency, self.bandwidth, self.contention = latency, bandwidth, contention
        self.n1, self.it1, self.k1 = int(one['unknowns']), int(one['iterations']), int(one['refine'])
        self.t1 = float(one['solve_s']) / self.it1 / self.n1        # seconds per unknown and iteration
        self.setup1 = (float(one['build_s']) + float(one['assembly_s'])) / self.n1
        self.mem1 = float(one['memory_max_mb']) / self.n1           # MB per unknown (baseline included)
        self.pm, self.nm = int(most['ranks']), int(most['unknowns'])
        self.km, self.lpm, self.itm = int(most['refine']), int(most['partition_level']), int(most['iterations'])
        per = lambda key: int(most[key]) / self.itm
        self.E, self.S, self.B = per('exchanges'), per('messages_sent_max'), per('bytes_sent_max')
        self.R, self.V = per('reductions'), per('reduced_values_max')
        self.D = self.km - self.lpm + 1

    def predict(self, P, N):
        k = math.log2(((N / 3) ** (1 / 3) - 1) / 4)
        lp = partition_level(P)
        D = max(k - lp + 1, 1)
        iters = self.itm + max(0.0, k - self.km)
        compute = self.t1 * N / P * self.contention
        replicated = self.t1 * 3 * vertices(lp - 1) * 8 / 7
        E = self.E * D / self.D
        B = self.B * D / self.D * ((N / P) / (self.nm / self.pm)) ** (2 / 3)
        halo = E * self.latency + B / self.bandwidth
        V = self.V * vertices(lp - 1) / vertices(self.lpm - 1)
        reductions = self.R * 2 * self.latency * math.log2(P) + 2 * 8 * V / self.bandwidth
        per_iter = compute + replicated + halo + reductions
        return dict(k=k, lp=lp, iters=iters, E=E, B=B, V=V, compute=compute, replicated=replicated, halo=halo,
                    reductions=reductions, per_iter=per_iter, solve=iters * per_iter,
                    setup=self.setup1 * N / P * self.contention, memory=self.mem1 * N / P)


def selftest():
    """The model reproduces its calibration point and scales as its terms say (ctest scripts.cluster_model)."""
    row = lambda **kw: {**dict(cells='4,4,4', ranks='1', unknowns='823875', refine='4', partition_level='1',
                                iterations='10', solve_s='5.0', build_s='0.2', assembly_s='0.5', memory_max_mb='480',
                                exchanges='0', messages_sent_max='0', bytes_sent_max='0', reductions='0',
                                reduced_values_max='0'), **kw}
    rows = [row(), row(ranks='64', solve_s='6', exchanges='3000', messages_sent_max='8000',
                       bytes_sent_max='13000000', reductions='117', reduced_values_max='83000'),
            row(ranks='128', cells='8,8,8', exchanges='1')]  # another box: ignored
    m = Model(rows, latency=0.0, bandwidth=float('inf'), contention=1.0)
    assert m.pm == 64, 'the row of another box was used'
    p = m.predict(64, 823875)
    assert abs(p['k'] - 4) < 1e-12 and p['lp'] == 1 and p['iters'] == 10, p
    assert abs(p['E'] - 300) < 1e-9 and abs(p['B'] - 1.3e6) < 1e-3 and abs(p['V'] - 8300) < 1e-9, p
    assert abs(p['compute'] - 5.0 / 10 / 64) < 1e-12, p
    # free communication: strong scaling halves the compute, weak scaling keeps it
    a, b = m.predict(256, 1e9), m.predict(512, 1e9)
    assert abs(a['compute'] - 2 * b['compute']) < 1e-12 and a['halo'] == b['halo'] == 0, (a, b)
    assert abs(m.predict(256, 256e6)['compute'] - m.predict(4096, 4096e6)['compute']) < 1e-12
    # one more refinement: one more iteration, and one more distributed level's exchanges
    q = m.predict(64, 3 * (4 * 2 ** 5 + 1) ** 3)
    assert abs(q['iters'] - 11) < 1e-9 and abs(q['E'] - 300 * 5 / 4) < 1e-9, q
    # the partition level: the coarsest >= 1 with 8 cells per rank
    assert [partition_level(P) for P in (1, 64, 65, 512, 513, 4096)] == [1, 1, 2, 2, 3, 3]
    print('cluster_model.py selftest: ok')


def main():
    if sys.argv[1:] == ['selftest']:
        selftest()
        return
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('runs', help='TSV of bench/distributed rows (step-42 on the unit cube)')
    ap.add_argument('--latency', type=float, default=2e-6, help='seconds per message round or reduction stage')
    ap.add_argument('--bandwidth', type=float, default=0.4e9,
                    help='bytes per second per rank (a 100 Gb/s link shared by 32 ranks: 0.4e9)')
    ap.add_argument('--contention', type=float, default=1.0,
                    help='compute slow-down of a full node against one rank alone (memory bandwidth)')
    ap.add_argument('--unknowns', type=float, default=1e9, help='the strong-scaling problem size')
    ap.add_argument('--per-rank', type=float, default=1e6, help='unknowns per rank of the weak-scaling table')
    a = ap.parse_args()
    try:
        m = Model(list(csv.DictReader(open(a.runs), delimiter='\t')), a.latency, a.bandwidth, a.contention)
    except (OSError, ValueError) as e:
        sys.exit(f'cluster_model.py: {a.runs}: {e}')

    print(f'Measured (this machine): 1 rank at {m.n1:,} unknowns (refine {m.k1}): {m.t1 * 1e9:.0f} ns per unknown '
          f'and TNNMG iteration, {m.it1} iterations, setup {m.setup1 * 1e9:.0f} ns per unknown, '
          f'{m.mem1 * 1e3:.2f} KB per unknown; {m.pm} ranks at {m.nm:,} unknowns (refine {m.km}, partition level '
          f'{m.lpm}), per iteration of the largest rank: {m.E:.1f} neighbour exchanges, {m.S:.0f} messages, '
          f'{m.B / 1024:.0f} KB, {m.R:.1f} reductions of {m.V:,.0f} values.')
    print(f'Machine assumed: latency {a.latency * 1e6:g} us, bandwidth {a.bandwidth / 1e9:g} GB/s per rank, '
          f'compute contention {a.contention:g}.')
    print()

    def table(title, cases):
        print(title)
        print()
        print('| ranks | unknowns | per rank | k | L_p | iterations | compute s/it | replicated s/it | halo s/it | '
              'reductions s/it | solve s | setup s | communication share | memory per rank MB (own part) |')
        print('|---|---|---|---|---|---|---|---|---|---|---|---|---|---|')
        for P, N in cases:
            p = m.predict(P, N)
            comm = (p['halo'] + p['reductions'] + p['replicated']) / p['per_iter']
            print(f"| {P:,} | {N:.3g} | {N / P:,.0f} | {p['k']:.1f} | {p['lp']} | {p['iters']:.1f} | "
                  f"{p['compute']:.3f} | {p['replicated']:.4f} | {p['halo']:.4f} | {p['reductions']:.4f} | "
                  f"{p['solve']:.1f} | {p['setup']:.1f} | {comm * 100:.0f} % | {p['memory']:,.0f} |")
        print()

    ranks = [64 * 2 ** i for i in range(7)]
    table(f'Strong scaling, {a.unknowns:.3g} unknowns:', [(P, a.unknowns) for P in ranks])
    table(f'Weak scaling, {a.per_rank:.3g} unknowns per rank:', [(P, a.per_rank * P) for P in ranks])


if __name__ == '__main__':
    main()
