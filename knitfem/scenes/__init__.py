"""Named experiments that wire geometry, models and solvers together."""
