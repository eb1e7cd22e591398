#!/bin/sh
# Resume the parked runs (from the repository root, after `make .venv/.installed-stamp`).
# A run whose folder already exists under /work/runs (the same machine) resumes there as it is.
# phase_a03: the alpha 0.2 beam phase grid (31 of 56 points stored; the next, 40 x 10, starts afresh:
#   its work checkpoint was lost with the machine on 2026-12-08).
# t55x35_thirds: the paper's 55 x 35 along increments of 1/3 (issue 9), parked at lam 0.34.
set -e
mkdir -p /work/runs
tmp=$(mktemp -d)
sh scripts/park-runs.sh --unpark "$tmp"
if [ ! -e /work/runs/phase_a03 ]; then
    cp -r studies/results/fabric_phase_beam_alpha0.2_epl32 /work/runs/phase_a03
    cp -r "$tmp/phase_a03/." /work/runs/phase_a03/
fi
[ -e /work/runs/t55x35_thirds ] || cp -r "$tmp/t55x35_thirds" /work/runs/t55x35_thirds
rm -rf "$tmp"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1
nohup .venv/bin/python studies/fabric_phase.py --model beam --alpha 0.2 --workers 1 --resume \
    --out /work/runs/phase_a03 >> /work/runs/phase_a03.log 2>&1 &
nohup .venv/bin/knitfem curl --nw 55 --nc 35 --alpha 0.2 --paths thirds --settle 2 --no-limits \
    --no-render --resume --out /work/runs/t55x35_thirds >> /work/runs/t55x35_thirds.log 2>&1 &
