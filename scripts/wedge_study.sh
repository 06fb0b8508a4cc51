#!/usr/bin/env bash
# The wedge nanoindentation's convergence and quasi-static checks (issue 11):
# the main job's set-up loaded to 450 nm (no unloading) as
#   3 levels (500/250/125 nm, the main job), at 10 m/s and at 5 m/s,
#   4 levels (finest 62.5 nm), and one uniform level of 125 nm cells,
# each on NP ranks (default 2), printing the load at 450 nm, its difference
# from the 3-level run, the sigma_yy under the tip and the wall time, the
# largest and RMS difference of each whole load-depth curve from the
# 3-level one, and
# writing results/wedge_study.csv. Run from the repository root after
# `make examples` (the Makefile's `make wedge-study` does both).
#
#   scripts/wedge_study.sh [NP] [OUT]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source scripts/env.sh
np=${1:-2}
out=${2:-results}
exe=${BUILD:-build}/examples-c/wedge_indentation
mkdir -p "$out/wedge_study"
csv="$out/wedge_study.csv"
echo "case,args,ranks,steps,load_450nm_n_per_m,diff_vs_3_levels,sigma_yy_tip_gpa,wall_s" > "$csv"
ref=""
run() {
  local name=$1; shift
  local dir="$out/wedge_study/$name" log
  mkdir -p "$dir"
  log="$dir/log.txt"
  mpiexec -n "$np" "$exe" --petsc --unload 0 --quiet --out "$dir" "$@" > "$log" 2>&1 ||
    { echo "$name failed:"; cat "$log"; exit 1; }
  local steps wall load sig
  steps=$(sed -n 's/^done: \([0-9]*\) steps in \([0-9.]*\) s.*/\1/p' "$log")
  wall=$(sed -n 's/^done: \([0-9]*\) steps in \([0-9.]*\) s.*/\2/p' "$log")
  load=$(sed -n 's/^  load at [0-9]* nm: \([-0-9.e+]*\) N\/m.*/\1/p' "$log")
  sig=$(sed -n 's/^  sigma_yy of the particle under the tip .*: \([-0-9.e+]*\) GPa/\1/p' "$log")
  [ -n "$ref" ] || ref=$load
  local diff
  diff=$(python3 -c "print('%+.3f %%' % (100 * ($load / $ref - 1)))")
  printf '%-22s %-28s %6s steps  load %10s N/m  (%s)  sigma_yy tip %8s GPa  %8s s\n' \
    "$name" "$*" "$steps" "$load" "$diff" "$sig" "$wall"
  echo "$name,\"$*\",$np,$steps,$load,$diff,$sig,$wall" >> "$csv"
}
echo "wedge nanoindentation to 450 nm on $np rank(s):"
run three_levels
run three_levels_5ms --speed 5
run four_levels --levels 4
run uniform_125nm --uniform 1.25e-7
# The whole load-depth curves against the main job's (3 levels, 10 m/s).
python3 - "$out/wedge_study" <<'PY'
import csv, sys
def curve(name):
    rows = csv.DictReader(open(f"{sys.argv[1]}/{name}/nanoindentation.csv"))
    return [(float(r["depth_m"]), float(r["load_n_per_m"])) for r in rows]
def at(c, d):
    for (d0, p0), (d1, p1) in zip(c, c[1:]):
        if d1 >= d:
            return p0 + (d - d0) / (d1 - d0) * (p1 - p0) if d1 > d0 else p1
    return c[-1][1]
ref = curve("three_levels")
depths = [k * 1e-8 for k in range(5, 45)] + [4.4999e-7]
for name in ["three_levels_5ms", "four_levels", "uniform_125nm"]:
    c = curve(name)
    e = [at(c, d) / at(ref, d) - 1 for d in depths]
    print(f"{name:22s} load-depth curve against three_levels over 50-450 nm: "
          f"largest {100 * max(map(abs, e)):.2f} %, RMS {100 * (sum(x * x for x in e) / len(e)) ** 0.5:.2f} %")
PY
echo "wrote $csv"
