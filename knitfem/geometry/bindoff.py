"""Bind-off: helical rods that hold the top and bottom edges of a swatch.

Each helix winds along x, one turn per wale, around the line through the
loop tops it binds (the heads of the top course, at z = -d; the sinkers of
the bottom course), so it threads every loop once: at a head it passes
inside the loop (below the head), between heads outside the fabric.  For
tall loops on thin yarn (c/r > ~300) a straight axis would cut the heads;
there the axis sags between the loops to follow each loop top.  Its
radius R (about 2.2 r) is solved so that it clears the knitted yarn by
2r (1 + 2 %): it touches the heads it wraps.  Like the paper's bind-off,
these are separate yarns; their self-contact is irrelevant (one turn per
wale is far longer than a yarn diameter).
"""
import math

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import cKDTree

from .knit import T1, TOUCH
from .swatch import YarnPath


def helix(x0, x1, apex_x, apex_y, z_axis, R, pitch, inward, n, sag=(0.0, 0.0)):
    """Points and unit tangents (n+1, 3) of a helix along x from x0 to x1.

    At x = apex_x (+ multiples of the pitch) it is a distance R on the
    ``inward`` side (+1: +y, -1: -y) of its axis, half a pitch further on the
    other side; z = z_axis - R sin(theta), theta = 2 pi (x - apex_x)/pitch.
    The axis runs at y = apex_y and sags toward the inward side by
    s1 v + s2 v^2, v = (1 - cos theta)/2, ``sag`` = (s1, s2), so that near an
    apex it can follow the top of a loop (:func:`apex_sag`).
    """
    x = np.linspace(x0, x1, n + 1)
    k = 2.0 * math.pi / pitch
    th = k * (x - apex_x)
    v = 0.5 * (1.0 - np.cos(th))
    y = apex_y + inward * (sag[0] * v + sag[1] * v * v + R * np.cos(th))
    dy = inward * k * np.sin(th) * (0.5 * sag[0] + sag[1] * v - R)
    p = np.stack([x, y, z_axis - R * np.sin(th)], axis=1)
    dp = np.stack([np.ones_like(x), dy, -R * k * np.cos(th)], axis=1)
    return p, dp / np.linalg.norm(dp, axis=1, keepdims=True)


def apex_sag(loop):
    """Axis sag (s1, s2) that follows a head top: the bend at the apex, radius
    u^2 (1 + 2a)^2 / h, and the drop of the head a quarter wale away."""
    s1 = 2.0 * loop.h / (1.0 + 2.0 * loop.a) ** 2
    t = brentq(lambda t: loop.curve(np.array([t]))[0][0, 0] - 0.25 * loop.w, 0.0, T1)
    drop = loop.h * (1.0 - math.cos(t))
    return s1, 4.0 * (drop - 0.5 * s1)


def bindoff_radius(loop):
    """Helix radius R and axis sag (s1, s2) that clear the heads of a course
    (and the course below) by 2r (1 + TOUCH), from a three-loop neighbourhood.

    The straight axis is kept when it reaches that clearance (it does for
    ordinary knits); tall loops on thin yarn (c/r > ~300) need the sagging
    axis.  R is the smallest radius in [2r, 4r] that clears, or the one with
    the widest clearance if none does (near radius = w/8, still >= 2r)."""
    r, w = loop.radius, loop.w
    n = max(1801, int(3.0 * loop.length / (0.1 * r)))          # samples ~r/20 apart
    t = np.linspace(-3.0 * math.pi, 3.0 * math.pi, n)
    knit = np.concatenate([loop.curve(t, 0)[0], loop.curve(t, -1)[0]])
    knit = cKDTree(knit[knit[:, 1] > loop.h - 6.0 * r])        # what a helix of R <= 4r can reach
    target = 2.0 * r * (1.0 + TOUCH)

    def solve(sag):
        def gap(R):
            p, _ = helix(-0.5 * w, 0.5 * w, 0.0, loop.h, -loop.d, R, w, -1,
                         max(600, int(math.hypot(2.0 * math.pi * R, w) / (0.1 * r))), sag)
            return knit.query(p)[0].min() - target
        # not monotone: a wider helix clears the head it wraps but nears the
        # course below, so scan upward and refine in the first bracket
        grid = np.linspace(2.0, 4.0, 41) * r
        gaps = np.array([gap(R) for R in grid])
        above = np.nonzero(gaps >= 0.0)[0]
        if len(above) == 0:
            return float(grid[np.argmax(gaps)]), float(gaps.max())
        i = above[0]
        R = grid[0] if i == 0 else brentq(gap, grid[i - 1], grid[i], xtol=1e-6 * r)
        return float(R), 0.0

    R, g = solve((0.0, 0.0))
    if g >= 0.0:
        return R, (0.0, 0.0)
    sag = apex_sag(loop)
    R_sag, g_sag = solve(sag)
    return (R_sag, sag) if g_sag > g else (R, (0.0, 0.0))


def bindoff_helices(loop, n_wale, n_course, spacing):
    """The bottom and top bind-off yarns (:class:`YarnPath`, course -1 and
    n_course) of a swatch, points about ``spacing`` apart."""
    w = loop.w
    R, sag = bindoff_radius(loop)
    x0, x1 = -0.5 * w, (n_wale - 0.5) * w
    turn = math.hypot(2.0 * math.pi * R, w)
    n = max(8 * n_wale, int(math.ceil(n_wale * turn / spacing)))
    out = []
    # bottom: around the sinkers (x = (j + 1/2) w, y = -h); top: around the heads
    for course, apex_x, apex_y, inward in ((-1, -0.5 * w, -loop.h, 1.0),
                                           (n_course, 0.0, (n_course - 1) * loop.c + loop.h,
                                            -1.0)):
        p, tg = helix(x0, x1, apex_x, apex_y, -loop.d, R, w, inward, n, sag)
        mid = 0.5 * (p[1:, 0] + p[:-1, 0])
        wale = np.clip(np.round(mid / w), 0, n_wale - 1).astype(int)
        out.append(YarnPath(p, tg, np.full(n, course), wale, np.zeros(n, bool),
                            np.zeros(0, int), bindoff=True))
    return out
