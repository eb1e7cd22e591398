"""Output files: .vtu round trip, .pvd series, off-screen render, the CLI."""
import json

import meshio
import numpy as np
import pytest

from knitfem.cli import main
from knitfem.io import beam_mesh, write_beam_state, write_series
from knitfem.verify import cases


@pytest.fixture(scope="module")
def bent():
    model = cases.cantilever_end_moment(8, moment=np.pi)
    return model, model.solve(loads=[0.5, 1.0])[-1].state


def test_vtu_round_trip_keeps_positions_frames_and_strains(tmp_path, bent):
    model, state = bent
    path = write_beam_state(tmp_path / "s.vtu", model, state)
    mesh = meshio.read(path)
    assert np.allclose(mesh.points, state.x)
    assert np.allclose(mesh.point_data["d1"], state.frames[:, :, 0])
    assert mesh.cells_dict["line"].shape == (8, 2)
    assert np.allclose(mesh.cell_data["curvature"][0][:, 1], np.pi, atol=1e-5)
    pvd = write_series(tmp_path / "s.pvd", [path], [1.0])
    assert 's.vtu' in pvd.read_text()


def test_offscreen_render_writes_a_nonblank_png(tmp_path, bent):
    pytest.importorskip("pyvista")
    from matplotlib.image import imread
    from knitfem.viz.render import render_rods
    model, state = bent
    png = render_rods(tmp_path / "r.png", beam_mesh(model, state), radius=0.03,
                      window_size=(320, 240))
    image = imread(png)
    assert image.shape[:2] == (240, 320) and image[..., :3].std() > 0.05


def test_cli_gallery_writes_its_summary(tmp_path):
    assert main(["gallery", "--out", str(tmp_path), "--no-render", "--quiet"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["a_rollup"]["tip_distance_from_root_over_L"] < 1e-6
    assert abs(summary["b_column"]["clamped"]["relative_error"]) < 5e-3
    for name in ("a_rollup.png", "b_column_buckling.png", "c_elastica.png", "d_bend45.png",
                 "rollup/rollup.pvd"):
        assert (tmp_path / name).exists()
