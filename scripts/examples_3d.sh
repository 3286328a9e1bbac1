#!/usr/bin/env bash
# Thesis Sec. 4.2.3, Examples 4-9 (3D): runs every scene data/scenes/example4.toml ... example9.toml
# with the adaptive loop (contact-residual estimator, mean marking, theta 1.1) and with uniform
# refinement, on the starting grids of the thesis, and writes the tables of docs/examples.md
# ("Examples 4-9") to docs/figures/ex4-9/tables.md plus the raw step tables
# docs/figures/ex4-9/<example>_<grid>_<adaptive|uniform>.csv (steps.csv of each run).
#   scripts/examples_3d.sh [path/to/obs]        # default: build/drivers/obs; about 20 s on 2 idle cores
# Environment: OUT (scratch directory, default out/examples_3d), STEPS_SCALE=small (CI smoke run:
# two adaptive and two uniform steps each).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
obs="${1:-$here/build/drivers/obs}"
out="${OUT:-out/examples_3d}"
fig="$here/docs/figures/ex4-9"
mkdir -p "$out" "$fig"
[ -x "$obs" ] || { echo "examples_3d.sh: no obs executable at $obs (pass its path)" >&2; exit 1; }

# example  grid  adaptive-steps  uniform-steps
runs=(
  "4 hexahedron  5 4"
  "4 tetrahedron 5 4"
  "4 prism       5 4"
  "5 hexahedron  6 4"
  "5 pyramid     6 3"
  "6 hexahedron  5 4"
  "7 pyramid     4 3"
  "7 tetrahedron 5 4"
  "8 hexahedron  5 3"
  "9 pyramid     5 3"
  "9 hexahedron  5 3"
)
cap=40000   # [adaptivity] max_vertices for every run (stops after the first solve above it)
for r in "${runs[@]}"; do
  read -r ex grid na nu <<<"$r"
  if [ "${STEPS_SCALE:-}" = small ]; then na=2; nu=2; fi
  for mode in adaptive uniform; do
    steps=$na; [ $mode = uniform ] && steps=$nu
    dir="$out/example${ex}_${grid}_${mode}"
    start=$(date +%s.%N)
    "$obs" run "$here/data/scenes/example$ex.toml" --quiet --output "$dir" \
      --set "mesh.type=\"$grid\"" --set "adaptivity.refinement=\"$mode\"" \
      --set "adaptivity.steps=$steps" --set "adaptivity.max_vertices=$cap" --set 'adaptivity.vtk="last"'
    end=$(date +%s.%N)
    cp "$dir/steps.csv" "$fig/example${ex}_${grid}_${mode}.csv"
    printf 'example %s %-11s %-8s %2s steps  %6.1f s\n' "$ex" "$grid" "$mode" "$steps" "$(echo "$end - $start" | bc)"
  done
done
# Example 8: contact vertices per crest after 1, 2, 3, 4 solves (adaptive, hexahedra)
for st in 1 2 3 4; do
  "$obs" run "$here/data/scenes/example8.toml" --quiet --output "$out/example8_crests_$st" \
    --set "adaptivity.steps=$st" --set 'adaptivity.vtk="none"'
done
python3 - "$out" > "$fig/extra.md" <<'PY'
# contact vertices (s_p > 1e-6 max s_p in pressure.csv) per crest of Example 8 and per feature of the
# smiley of Example 9 (nearest curve of the final adaptive step)
import csv, math, os, sys
out = sys.argv[1]
def contacts(f):
    rows = list(csv.DictReader(open(f)))
    top = max(float(r['s_p']) for r in rows)
    return [(float(r['x']), float(r['y'])) for r in rows if float(r['s_p']) > 1e-6 * top]
print('Example 8 (hexahedra): contact vertices near each crest (|x - crest| < 0.125) after k + 1 solves\n')
print('| k | N | x = 0.1 | x = 0.35 | x = 0.6 | x = 0.85 |')
print('|---|---|---|---|---|---|')
for st in (1, 2, 3, 4):
    d = os.path.join(out, 'example8_crests_%d' % st)
    n = list(csv.DictReader(open(os.path.join(d, 'steps.csv'))))[-1]['vertices']
    c = contacts(os.path.join(d, 'pressure.csv'))
    print('| %d | %s | ' % (st - 1, n) + ' | '.join(str(sum(1 for x, y in c if abs(x - cr) < 0.125))
                                                  for cr in (0.1, 0.35, 0.6, 0.85)) + ' |')
def features(x, y):
    s1, s2 = x - 0.5, y - 0.5; R = 0.4; r = math.hypot(s1, s2)
    d = {'outline': abs(r - R),
         'left eye': max(0, math.hypot(s1 + 0.35 * R, s2 - 0.3 * R) - 0.1 * R),
         'right eye': max(0, math.hypot(s1 - 0.35 * R, s2 - 0.3 * R) - 0.1 * R)}
    a = math.atan2(s2, s1) % (2 * math.pi); rm = 0.6 * R
    if r > 0 and math.radians(210) <= a <= math.radians(330): d['mouth'] = abs(r - rm)
    else: d['mouth'] = min(math.hypot(s1 - rm * math.cos(math.radians(t)), s2 - rm * math.sin(math.radians(t)))
                           for t in (210, 330))
    return d
print('\nExample 9: contact vertices of the final adaptive step by nearest feature of the smiley, and the\n'
      'largest distance d of a contact vertex from the smiley\n')
print('| grid | outline | left eye | right eye | mouth | max d |')
print('|---|---|---|---|---|---|')
for grid in ('pyramid', 'hexahedron'):
    f = os.path.join(out, 'example9_%s_adaptive' % grid, 'pressure.csv')
    if not os.path.exists(f): continue
    count = {'outline': 0, 'left eye': 0, 'right eye': 0, 'mouth': 0}; dmax = 0
    for x, y in contacts(f):
        d = features(x, y); k = min(d, key=d.get); count[k] += 1; dmax = max(dmax, d[k])
    print('| %s | %d | %d | %d | %d | %.3f |' % (grid, count['outline'], count['left eye'], count['right eye'],
                                                count['mouth'], dmax))
PY
# the source line of every section of the tables (scripts/provenance.py; docs.provenance checks it)
source_line=$(python3 "$here/scripts/provenance.py" stamp "scripts/examples_3d.sh${STEPS_SCALE:+ (STEPS_SCALE=$STEPS_SCALE)}")
python3 - "$fig" "$fig/extra.md" "$source_line" > "$fig/tables.md" <<'PY'
# Tables of docs/examples.md from the step tables: per run the steps (vertices, ratios of actual /
# semi / full contact vertices to the potential ones, eta and eta_1..eta_8, eoc, solver and
# estimator seconds) and a summary (eoc adaptive vs uniform: least-squares slope of -ln eta over
# ln N on steps >= 1, and the last step's eoc).
import csv, glob, math, os, sys
fig = sys.argv[1]
def rows(f): return list(csv.DictReader(open(f)))
def num(x): return float(x) if x not in ('', None) else math.nan
def slope(rs):
    pts = [(math.log(num(r['vertices'])), math.log(num(r['eta']))) for r in rs[1:] if num(r['eta']) > 0]
    if len(pts) < 2: return math.nan
    mx = sum(p[0] for p in pts) / len(pts); my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    return -sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx if sxx > 0 else math.nan
def g(x, fmt='%.3g'): return '' if math.isnan(x) else fmt % x
runs = sorted({os.path.basename(f).rsplit('_', 1)[0] for f in glob.glob(os.path.join(fig, 'example*_*.csv'))})
def seconds(rs): return sum(num(r[k]) for r in rs for k in ('solver_s', 'estimator_s', 'refinement_s', 'transfer_s')
                            if not math.isnan(num(r[k])))
def dominant(r):
    eta = {k: num(r['eta_%d' % k]) for k in range(1, 9)}
    return ' > '.join('eta_%d' % k for k in sorted(eta, key=eta.get, reverse=True)[:3])
source = sys.argv[3]
print(source)
print()
print('| example | grid | adaptive: steps, final N | eoc adaptive (fit / last) | uniform: steps, final N | eoc uniform (fit / last) | time adaptive / uniform [s] | dominant, first step | dominant, last adaptive step |')
print('|---|---|---|---|---|---|---|---|---|')
for run in runs:
    ex, grid = run.split('_', 1)
    a = rows(os.path.join(fig, run + '_adaptive.csv')); u = rows(os.path.join(fig, run + '_uniform.csv'))
    print('| %s | %s | %d, %s | %s / %s | %d, %s | %s / %s | %.1f / %.1f | %s | %s |' % (ex[7:], grid, len(a),
          a[-1]['vertices'], g(slope(a), '%.2f'), g(num(a[-1]['eoc']), '%.2f'), len(u), u[-1]['vertices'],
          g(slope(u), '%.2f'), g(num(u[-1]['eoc']), '%.2f'), seconds(a), seconds(u), dominant(a[0]), dominant(a[-1])))
print()
print(open(sys.argv[2]).read())
for run in runs:
    ex, grid = run.split('_', 1)
    for mode in ('adaptive', 'uniform'):
        rs = rows(os.path.join(fig, '%s_%s.csv' % (run, mode)))
        print('\n#### Example %s, %s, %s refinement\n' % (ex[7:], grid, mode))
        print(source + '\n')
        print('| k | N | aC/C | sC/C | fC/C | eta | eta_1 | eta_2 | eta_3 | eta_4 | eta_5 | eta_6 | eta_7 | eta_8 | eoc | solve s | estimate s |')
        print('|---' * 17 + '|')
        for r in rs:
            pc = num(r['potential_contact'])
            ratio = lambda k: g(num(r[k]) / pc, '%.3f') if pc > 0 else ''
            print('| ' + ' | '.join([r['step'], r['vertices'], ratio('actual_contact'), ratio('semi_contact'),
                  ratio('full_contact'), g(num(r['eta']))] + [g(num(r['eta_%d' % k])) for k in range(1, 9)] +
                  [g(num(r['eoc']), '%.2f'), g(num(r['solver_s']), '%.2f'), g(num(r['estimator_s']), '%.2f')]) + ' |')
PY
# the generated part of docs/examples.md "Examples 4-9" lies between these markers
rm -f "$fig/extra.md"
python3 - "$here/docs/examples.md" "$fig/tables.md" <<'PY'
import sys
doc, tables = sys.argv[1], open(sys.argv[2]).read()
begin, end = '<!-- examples-4-9:begin -->', '<!-- examples-4-9:end -->'
text = open(doc).read()
if begin in text and end in text:
    head, rest = text.split(begin, 1)
    text = head + begin + '\n' + tables + '\n' + end + rest.split(end, 1)[1]
    open(doc, 'w').write(text)
    print('updated: ' + doc)
else:
    print('note: ' + doc + ' has no examples-4-9 markers; tables left in ' + sys.argv[2])
PY
echo "written: $fig/tables.md and the step tables in $fig"
