"""The beam run-time-against-error study: rolls of increments whose path .vtu is lost."""
import csv
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))
from beam_time_vs_error import EDGES, fill_from_earlier  # noqa: E402


def _write(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["lam", "relax_s", "iterations", "residual", "accepted",
                                          "curl"] + [f"roll_{e}" for e in EDGES], restval="")
        w.writeheader()
        w.writerows(rows)


def test_an_earlier_csv_fills_only_the_rows_without_rolls(tmp_path):
    earlier = tmp_path / "old.csv"
    _write(earlier, [dict(lam=0.1, curl="flat", roll_left=-4, roll_right=-3, roll_top=4, roll_bottom=5),
                     dict(lam=0.25, curl="double", roll_left=-40, roll_right=-41, roll_top=50,
                          roll_bottom=52)])
    rows = [dict(lam=0.1, accepted=True),
            dict(lam=0.25, accepted=True, curl="side", roll_left=-1.0, roll_right=-2.0, roll_top=3.0,
                 roll_bottom=4.0),
            dict(lam=0.4, accepted=True)]
    out = fill_from_earlier(rows, earlier)
    assert out[0]["curl"] == "flat" and out[0]["roll_bottom"] == 5.0
    assert out[1]["curl"] == "side" and out[1]["roll_left"] == -1.0     # measured rows win
    assert "roll_left" not in out[2]                                    # nothing to fill from


def test_an_earlier_csv_of_another_path_is_refused(tmp_path):
    earlier = tmp_path / "old.csv"
    _write(earlier, [dict(lam=0.3, curl="flat", roll_left=0, roll_right=0, roll_top=0, roll_bottom=0)])
    with pytest.raises(SystemExit, match="another path"):
        fill_from_earlier([dict(lam=0.1, accepted=True)], earlier)
