#!/bin/sh
# Resume the parked runs (from the repository root, after `make .venv/.installed-stamp`).
# A run whose folder already exists under /work/runs (the same machine) resumes there as it is.
# phase_a03: the alpha 0.2 beam phase grid (its 20 x 20 point parked on its way from lam 0.4 to 0.55).
# t55x35_thirds: the paper's 55 x 35 along increments of 1/3 (issue 9), parked at lam 0.34.
# b55x35: the paper's own model (B-spline, FIRE) on the 55 x 35 (issue 12), checkpointed every 600 s.
# bs0_10x35: the B-spline 10 x 35 with the set yarn (--straighten 0), far from rest after 27 min.
set -e
mkdir -p /work/runs
tmp=$(mktemp -d)
sh scripts/park-runs.sh --unpark "$tmp"
if [ ! -e /work/runs/phase_a03 ]; then
    cp -r studies/results/fabric_phase_beam_alpha0.2_epl32 /work/runs/phase_a03
    cp -r "$tmp/phase_a03/." /work/runs/phase_a03/
fi
[ -e /work/runs/t55x35_thirds ] || cp -r "$tmp/t55x35_thirds" /work/runs/t55x35_thirds
[ -e /work/runs/b55x35 ] || cp -r "$tmp/b55x35" /work/runs/b55x35
[ -e /work/runs/bs0_10x35 ] || cp -r "$tmp/bs0_10x35" /work/runs/bs0_10x35
rm -rf "$tmp"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1
nohup .venv/bin/python studies/fabric_phase.py --model beam --alpha 0.2 --workers 1 --resume \
    --out /work/runs/phase_a03 >> /work/runs/phase_a03.log 2>&1 &
nohup .venv/bin/knitfem curl --nw 55 --nc 35 --alpha 0.2 --paths thirds --settle 2 --no-limits \
    --no-render --resume --out /work/runs/t55x35_thirds >> /work/runs/t55x35_thirds.log 2>&1 &
nohup .venv/bin/knitfem curl --model bspline --nw 55 --nc 35 --alpha 0.2 --max-time 200000 \
    --no-limits --no-render --resume --out /work/runs/b55x35 >> /work/runs/b55x35.log 2>&1 &
nohup .venv/bin/knitfem curl --model bspline --nw 10 --nc 35 --alpha 0.2 --straighten 0 \
    --max-time 20000 --no-limits --no-render --resume --out /work/runs/bs0_10x35 \
    >> /work/runs/bs0_10x35.log 2>&1 &
