#!/bin/bash
# One row of the table of transfers against the hard cases in
# docs/method.md (section "Alternatives measured and left out"): runs
# build/test_hard, 1 rank, under the settings given as environment
# assignments, e.g.
#
#   scripts/hard_row.sh HARD_TRANSFER=2 HARD_XPIC_ORDER=5 HARD_FLIP=0
#   SHAPE=2 scripts/hard_row.sh HARD_SHAPE=2 HARD_TRANSFER=0
#
# and prints: the largest BAR_STRETCH of 1.05, 1.1, 1.2, ..., 1.5 at which
# every check of `test_hard bar` but the 50 % one passes (with the bar's
# shape SHAPE, default uGIMP = 1; "none" when 1.05 fails), the long run's
# energy range, the impact's largest and final energy, the vibrating
# crossings' momentum change, the free flight's momentum change and the
# rotation's largest stress. The settings apply on top of uGIMP with MUSL
# and FLIP (HARD_SHAPE=1 HARD_TRANSFER=0: the table's base, the paper's;
# the library's default is cpGIMP with APIC). Takes about 10 s per row
# (build first).
source "$(dirname "$0")/env.sh"
T=${TEST_HARD:-build/test_hard}
cfg="$*"
base="HARD_SHAPE=1 HARD_TRANSFER=0"
held=none
for st in 1.05 1.1 1.2 1.3 1.4 1.5; do
  out=$(env $base $cfg HARD_SHAPE=${SHAPE:-1} BAR_STRETCH=$st mpiexec -n 1 $T bar 2>&1)
  nf=$(echo "$out" | grep -c FAILED)
  only50=$(echo "$out" | grep -c "FAILED: bar: at least 50")
  if [ "$nf" -eq 0 ] || { [ "$nf" -eq 1 ] && [ "$only50" -eq 1 ]; }; then held=$st; else break; fi
done
lr=$(env $base $cfg mpiexec -n 1 $T long_run 2>&1 | grep 'steps, energy' | sed 's/.*range \[\([^]]*\)\].*/[\1]/')
im=$(env $base $cfg mpiexec -n 1 $T impact 2>&1 | grep '^impact at' | sed 's/.*largest energy \([^ ]*\) .*final \(.*\)/max \1 final \2/')
cr=$(env $base $cfg mpiexec -n 1 $T crossings 2>&1 | grep 'vibrating' | sed 's/.*momentum change \([^ ]*\) .*/\1/')
ff=$(env $base $cfg mpiexec -n 1 $T free_flight 2>&1 | grep 'momentum change' | sed 's/.*momentum change \([^ ]*\) .*/\1/')
ro=$(env $base $cfg mpiexec -n 1 $T rotation_flip 2>&1 | grep '^rotation_flip: w' | sed 's/.*max |stress| = \([^ ]*\) E.*/\1/')
echo "| ${cfg:-uGIMP, MUSL, FLIP} | bar held to $held | long_run $lr | impact $im | crossings $cr | free_flight $ff | rotation $ro E |"
