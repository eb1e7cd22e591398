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
    assert np.allclose(mesh.cell_data["kappa"][0][:, 2], np.pi, atol=1e-5)
    assert np.allclose(mesh.point_data["curvature"], np.pi, atol=1e-5)
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


def test_cli_popup_writes_json_csv_shapes_plot_and_render(tmp_path):
    out, js = tmp_path / "run", tmp_path / "popup.json"
    assert main(["popup", "--elements", "30", "--c-to", "0.55", "--c-step", "0.1",
                 "--out", str(out), "--json", str(js), "--quiet"]) == 0
    summary = json.loads(js.read_text())
    assert set(summary) >= {"w_over_L", "elements", "gj_over_ei", "critical_c_over_L",
                            "branch", "elapsed_s"}
    assert [round(b["c_over_L"], 2) for b in summary["branch"]] == [0.95, 0.85, 0.75, 0.65, 0.55]
    assert all(set(b) == {"c_over_L", "max_abs_z_over_L", "stable"} for b in summary["branch"])
    for name in ("branch.csv", "branches.csv", "popup_z.png", "popup_c0.60.png",
                 "shapes/popup.pvd", "shapes/popup_c0.9500.vtu"):
        assert (out / name).exists(), name
    mesh = meshio.read(out / "shapes" / "popup_c0.5500.vtu")
    assert {"d1", "d2", "d3", "twist", "curvature"} <= set(mesh.point_data)


def test_cli_reports_bad_input_without_a_traceback(capsys):
    assert main(["popup", "--w-over-L", "1.2"]) == 2
    err = capsys.readouterr().err
    assert err == "knitfem popup: error: --w-over-L must be a number in (0, 1), got 1.2\n"
