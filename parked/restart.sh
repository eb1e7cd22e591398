#!/bin/sh
# Resume parked runs (from the repository root, after `make .venv/.installed-stamp`):
#   sh parked/restart.sh RUN ...      (no RUN: list them)
# A run whose folder already exists under /work/runs (the same machine) resumes there as it is.
# Two cores: start two (priority 2026-12-08: s0_55x35, then bs0_25x35; the grid and
# t55x35_thirds wait).
#   phase_a03      the alpha 0.2 beam phase grid (31 of 56 points stored; the next, 40 x 10,
#                  starts afresh: its work checkpoint was lost with the machine on 2026-12-08).
#   t55x35_thirds  the paper's 55 x 35 along increments of 1/3 (issue 9), parked at lam 0.34.
#   s0_55x35       the 55 x 35 with the set yarn (--straighten 0, issue 9), at its lam 0.34 equilibrium
#                  (top/bottom; the final solve to 1e-8 still to run).
#   bs0_25x35      the B-spline 25 x 35 with the set yarn (issue 12), on its way (FIRE).
set -e
if [ $# -eq 0 ]; then
    sed -n 's/^#   \([a-z][a-z0-9_]*\)  .*/\1/p' "$0"
    exit 0
fi
mkdir -p /work/runs
tmp=$(mktemp -d)
sh scripts/park-runs.sh --unpark "$tmp" > /dev/null
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1
for run in "$@"; do
    if [ ! -e "/work/runs/$run" ]; then
        [ -d "$tmp/$run" ] || { echo "restart.sh: $run is not parked" >&2; exit 2; }
        if [ "$run" = phase_a03 ]; then
            cp -r studies/results/fabric_phase_beam_alpha0.2_epl32 /work/runs/phase_a03
            cp -r "$tmp/phase_a03/." /work/runs/phase_a03/
        else
            cp -r "$tmp/$run" "/work/runs/$run"
        fi
    fi
    log="/work/runs/$run.log"
    case "$run" in
    phase_a03)
        nohup .venv/bin/python studies/fabric_phase.py --model beam --alpha 0.2 --workers 1 \
            --resume --out /work/runs/phase_a03 >> "$log" 2>&1 & ;;
    t55x35_thirds)
        nohup .venv/bin/knitfem curl --nw 55 --nc 35 --alpha 0.2 --paths thirds --settle 2 \
            --no-limits --no-render --resume --out /work/runs/t55x35_thirds >> "$log" 2>&1 & ;;
    s0_55x35)
        nohup .venv/bin/knitfem curl --nw 55 --nc 35 --alpha 0.2 --straighten 0 --paths thirds \
            --settle 2 --no-limits --no-render --resume --out /work/runs/s0_55x35 >> "$log" 2>&1 & ;;
    bs0_25x35)
        nohup .venv/bin/knitfem curl --model bspline --nw 25 --nc 35 --alpha 0.2 --straighten 0 \
            --max-time 20000 --no-limits --no-render --resume --out /work/runs/bs0_25x35 \
            >> "$log" 2>&1 & ;;
    *)
        echo "restart.sh: no command for $run" >&2; exit 2 ;;
    esac
    echo "restarted $run (log $log)"
done
rm -rf "$tmp"
