#!/bin/sh
# Resume the parked runs on a new machine (from the repository root, after `make .venv/.installed-stamp`).
# phase_a03: the alpha 0.2 beam phase grid (its 15 x 25 point parked inside its first increments).
set -e
[ ! -e /work/runs/phase_a03 ] || { echo "restart.sh: /work/runs/phase_a03 exists; resume it there instead" >&2; exit 2; }
mkdir -p /work/runs
cp -r studies/results/fabric_phase_beam_alpha0.2_epl32 /work/runs/phase_a03
sh scripts/park-runs.sh --unpark /work/runs
nohup .venv/bin/python studies/fabric_phase.py --model beam --alpha 0.2 --workers 1 --resume \
    --out /work/runs/phase_a03 >> /work/runs/phase_a03.log 2>&1 &
