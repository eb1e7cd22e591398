"""The README's Python example runs and does what it says."""
import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_example_rolls_the_rod_into_a_circle(tmp_path, monkeypatch):
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(code, "README.md", "exec"), scope)
    assert np.linalg.norm(scope["tip"]) < 1e-6 * 105.0
    assert (tmp_path / "rollup.vtu").exists()
