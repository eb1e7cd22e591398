"""Issue 12's cross-model check: the beam scene and the paper's B-spline
model relax the same swatch and must curl alike.

The issue asked for a 4 x 4.  There the frictionless B-spline swatch does not
stay a fabric (α 0.2: it shears into a tangle, the rolls of its 4-7 loop
edges are those of its bind-off and tied tails: +40 / +120 / -98 / -115 deg
at 4 x 4, -107 / -10 / -19 / +98 at 6 x 6, -68 / -67 / -60 / -132 at 7 x 7)
and the two models disagree on the top or bottom edge up to 7 x 7 (README,
"Fabric curling with the paper's own model").  From 8 x 8 on both models
rolled every edge the paper's way (until 2026-12-07: below), so the check
lives at 8 x 8, the smallest square swatch where they agreed (measured 2026-12-03: beam -211 / -141 /
+165 / +176 at be98871, -221 / -167 / +173 / +179 at 2425173 -- friction
makes the path, and so round-off, matter; B-spline -108 / -73 / +178 /
+165).  It takes ~15 min on one core, so it runs only with
``--crosscheck`` (``make test-crosscheck``), not in the fast suite.

The top and bottom edges are no longer compared (2026-12-07): the
frictionless B-spline 8 x 8 has two stable equilibria and round-off picks
one.  Summing the contact pairs in sample order instead of the k-d tree's (a
change at the level of round-off, needed for bit-for-bit resumes) moved its
converged, stable answer from -108 / -73 / +178 / +165 deg to -173 / -64 /
-57 / -180 deg (top and bottom rolled to the back, as the smaller swatches'
tangles do), where the beam's stays +165 / +179.  So the check moved to
10 x 10, the smallest square seen to agree on every edge under both
roundings: B-spline -131 / -64 / +195 / +196 (tree order), -99 / -60 / +193 /
+176 (sample order, converged 1.6e-10, stable, 286 s), beam -223 / -180 /
+192 / +236 (a90dcd3, 791 s beside three jobs).  It takes ~20 min.
"""
import pytest

from knitfem.scenes.curl import curl
from knitfem.scenes.curl_bspline import bspline_curl
from knitfem.scenes.fabric import FabricScene

EDGES = ("left", "right", "top", "bottom")


@pytest.mark.crosscheck
def test_both_models_curl_a_10x10_swatch_the_same_way():
    """Both relax to a converged, stable equilibrium; same curl type; every
    edge rolled more than 30 deg (the classification's threshold, so its sign
    means something) the same way in both models.  The sizes are not
    compared: the beam's side edges (friction, twist) roll ~120 deg further,
    its bottom ~60 deg (README)."""
    beam = curl(FabricScene(10, 10, alpha=0.2), render=False, progress=False)
    yarn = bspline_curl(10, 10, alpha=0.2, max_time=3600, progress=False)
    for summary in (beam, yarn):
        assert summary["converged"] and summary["stable"], summary.get("message")
    assert beam["curl"] == yarn["curl"] == "top_bottom"
    for edge in EDGES:
        b, y = beam["roll_deg"][edge], yarn["roll_deg"][edge]
        assert min(abs(b), abs(y)) > 30 and (b > 0) == (y > 0), (edge, b, y)
