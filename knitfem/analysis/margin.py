"""How far a curl classification is from changing: the curl type of a swatch
against the roll threshold (deg) that calls an edge pair curled.

The classification of :mod:`knitfem.analysis.curl` calls an edge pair curled
when the larger magnitude of its two rolls reaches a threshold (30 deg by
default, justified there).  The paper states no threshold: it names side,
double and top/bottom curl from pictures.  Where a swatch's type changes with
the threshold, a reader can see which reading of "curled" (a flare of a
twelfth of a turn, a quarter turn, an edge rolled over) each answer rests on.
Pure functions of the rolls; angles in degrees.
"""
import math

EDGES = ("left", "right", "top", "bottom")


TYPES = ("side", "double", "top_bottom", "flat")


def edge_rolls(roll_deg):
    """The four rolls as finite floats; ValueError naming roll_deg otherwise."""
    try:
        rolls = {e: float(roll_deg[e]) for e in EDGES}
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"roll_deg must give a number for each of {', '.join(EDGES)}, "
                         f"got {roll_deg!r}") from None
    if not all(math.isfinite(v) for v in rolls.values()):
        raise ValueError(f"roll_deg must be finite, got {rolls}")
    return rolls


def curled_pairs(roll_deg, roll_threshold):
    """(side pair curled, top/bottom pair curled): the larger magnitude of each
    pair's rolls (deg) reaches ``roll_threshold`` (deg)."""
    r = edge_rolls(roll_deg)
    return (max(abs(r["left"]), abs(r["right"])) >= roll_threshold,
            max(abs(r["top"]), abs(r["bottom"])) >= roll_threshold)


def curl_type(roll_deg, edges_touch, roll_threshold):
    """The curl type of rolls ``roll_deg`` ({left, right, top, bottom}, deg) and
    ``edges_touch`` at ``roll_threshold`` (deg): "side" | "double" |
    "top_bottom" | "flat" (the rule of :mod:`knitfem.analysis.curl`)."""
    x_curled, y_curled = curled_pairs(roll_deg, roll_threshold)
    if y_curled:
        return "double" if x_curled and not edges_touch else "top_bottom"
    return "side" if x_curled else "flat"


def curl_type_intervals(roll_deg, edges_touch, upper=360.0):
    """The curl type over thresholds in (0, upper] deg as a list of
    ``(low, high, type)``: the type holds for low < threshold <= high (the
    type changes only where the threshold passes an edge pair's larger roll).
    Raises ValueError for missing or non-finite rolls or a bad ``upper``."""
    rolls = edge_rolls(roll_deg)
    if not (math.isfinite(upper) and upper > 0):
        raise ValueError(f"upper must be a positive number of degrees, got {upper!r}")
    x = max(abs(rolls["left"]), abs(rolls["right"]))
    y = max(abs(rolls["top"]), abs(rolls["bottom"]))
    cuts = sorted({0.0, upper, *(v for v in (x, y) if 0.0 < v < upper)})
    intervals = []
    for low, high in zip(cuts, cuts[1:]):
        kind = curl_type(rolls, edges_touch, high)
        if intervals and intervals[-1][2] == kind:
            intervals[-1] = (intervals[-1][0], high, kind)
        else:
            intervals.append((low, high, kind))
    return intervals


def threshold_range(roll_deg, edges_touch, kind, upper=360.0):
    """The thresholds (deg) at which the rolls read as ``kind``: a list of
    ``(low, high)`` (empty when no threshold in (0, upper] gives it)."""
    if kind not in TYPES:
        raise ValueError(f"kind must be one of {TYPES}, got {kind!r}")
    return [(lo, hi) for lo, hi, k in curl_type_intervals(roll_deg, edges_touch, upper)
            if k == kind]
