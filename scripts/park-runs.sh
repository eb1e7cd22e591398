#!/bin/sh
# Carry relaxations that outlive a session across a machine that may be
# replaced: only the repository survives, so their checkpoints are committed.
#
#   sh scripts/park-runs.sh RUN_DIR ...   copy each run's checkpoints (and its
#                                         run.json / sweep.json) into parked/<name>/
#   sh scripts/park-runs.sh --unpark DEST copy parked/<name>/ back to DEST/<name>/
#
# A checkpoint is all `--resume` needs (beam: checkpoint.npz per path folder,
# B-spline: *_checkpoint.npz, a sweep: work/<key>/checkpoint.npz); the
# relaxation path's .vtu files are outputs and stay behind.  The commands that
# resume the runs go in parked/restart.sh (written by hand: the runs' options).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
parked="$here/parked"
if [ "${1:-}" = "--unpark" ]; then
    dest=${2:?"--unpark needs the folder to copy the runs into"}
    mkdir -p "$dest"
    for run in "$parked"/*/; do
        [ -d "$run" ] || continue
        name=$(basename "$run")
        mkdir -p "$dest/$name"
        (cd "$run" && find . -type f -exec cp --parents {} "$dest/$name/" \;)
        echo "unparked $name -> $dest/$name"
    done
    exit 0
fi
[ $# -gt 0 ] || { echo "usage: park-runs.sh RUN_DIR ... | --unpark DEST" >&2; exit 2; }
for run in "$@"; do
    [ -d "$run" ] || { echo "park-runs.sh: $run is not a folder" >&2; exit 2; }
    name=$(basename "$run")
    rm -rf "$parked/$name"
    mkdir -p "$parked/$name"
    (cd "$run" && find . \( -name 'checkpoint.npz' -o -name '*_checkpoint.npz' \
        -o -name run.json -o -name sweep.json \) -exec cp --parents {} "$parked/$name/" \;)
    echo "parked $name: $(du -sh "$parked/$name" | cut -f1)"
done
