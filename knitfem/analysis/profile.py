"""Roll profiles across a curled swatch: where along a row or column it turns.

The edge rolls of :mod:`knitfem.analysis.curl` are the whole turning from the
centre to an edge.  A swatch can reach the same roll by bending evenly (a
cylinder) or by a flat middle and a rolled-over edge (the paper's edge curl),
and a long swatch bent gently along its length adds that bend to its end
rolls.  The profile separates the two: the tangent angle of the central band
of rows (columns) against the arclength from the centre, a straight line
fitted to its interior (the points within n/4 of the centre, the middle half,
but at least the centre and its neighbours),
and the **local roll** of each edge, its roll minus that line's turning to the
same edge: 0 on a cylinder, the whole roll on a flat sheet with rolled edges.

Same frame, bands, signs and chord-to-arc correction as the curl analysis
(positive toward the front); lengths in the swatch's unit (mm), angles in
degrees, curvatures in rad per length.
"""
from dataclasses import dataclass

import numpy as np

from .curl import _band, _body_frame, _turning, centre_grid, chord_arcs, loop_centres


@dataclass(frozen=True)
class RollProfile:
    """Turning profiles of a swatch (definitions in the module docstring).

    s_x, theta : (n_wale,) arclength from the centre along the rows and the
        rows' tangent angle relative to the centre (deg), medians over the
        central band; s_y, phi : (n_course,) the same up the columns;
    theta_fit, phi_fit : the interior lines at s_x, s_y (deg).
    interior_curvature_x, interior_curvature_y : slope of the line fitted to
        the interior of theta(s_x), phi(s_y) (1/length, + toward the front).
    local_roll_deg : {"left", "right", "top", "bottom"}: each edge's roll
        minus the interior line's turning to that edge (deg)."""
    s_x: np.ndarray
    theta: np.ndarray
    s_y: np.ndarray
    phi: np.ndarray
    theta_fit: np.ndarray
    phi_fit: np.ndarray
    interior_curvature_x: float
    interior_curvature_y: float
    local_roll_deg: dict


def _profile(lines, along, normal):
    """(s, angle, line in deg, interior slope in rad/length, start and end excess)."""
    at, centre, _ = _turning(lines, along, normal)
    angle = np.median(at - centre[:, None], axis=0)
    chord = np.median(np.linalg.norm(np.diff(lines, axis=1), axis=2), axis=0)
    s = np.concatenate([[0.0], np.cumsum(chord_arcs(chord, np.diff(angle)))])
    n = len(s)
    s -= s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])
    inner = np.abs(np.arange(n) - 0.5 * (n - 1)) <= max(n / 4.0, 1.0)
    slope, offset = np.polyfit(s[inner], angle[inner], 1)
    line = slope * s + offset
    return (s, np.degrees(angle), np.degrees(line), float(slope),
            float(np.degrees(line[0] - angle[0])), float(np.degrees(angle[-1] - line[-1])))


def roll_profile(centres):
    """:class:`RollProfile` of a swatch from its loop centres.

    centres : (n_course >= 4, n_wale >= 3, 3) loop centres
        (:func:`knitfem.analysis.loop_centres`), length unit (mm)."""
    C = centre_grid(centres)
    n_course, n_wale = C.shape[:2]
    e_x, e_y, e_z = _body_frame(C)
    s_x, theta, theta_fit, k_x, left, right = _profile(C[_band(n_course)], e_x, e_z)
    s_y, phi, phi_fit, k_y, bottom, top = _profile(C[:, _band(n_wale)].transpose(1, 0, 2),
                                                   e_y, e_z)
    return RollProfile(s_x=s_x, theta=theta, s_y=s_y, phi=phi, theta_fit=theta_fit,
                       phi_fit=phi_fit, interior_curvature_x=k_x,
                       interior_curvature_y=k_y,
                       local_roll_deg={"left": left, "right": right, "top": top,
                                       "bottom": bottom})


def swatch_roll_profile(points, swatch):
    """:func:`roll_profile` of a deformed swatch from its yarn points
    (the knit yarn's, or all yarns stacked in ``swatch.points`` order)."""
    return roll_profile(loop_centres(points, swatch))


def profile_fields(points, swatch):
    """The roll profile's summary keys of a deformed swatch (JSON-ready):
    ``local_roll_deg`` and ``interior_curvature_x``, ``interior_curvature_y``."""
    p = swatch_roll_profile(points, swatch)
    return {"local_roll_deg": {k: float(v) for k, v in p.local_roll_deg.items()},
            "interior_curvature_x": p.interior_curvature_x,
            "interior_curvature_y": p.interior_curvature_y}
