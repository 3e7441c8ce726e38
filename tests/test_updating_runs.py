"""Updating a folder of repetitions takes each repetition's own modes."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from structbench.identifier.updating.data import load


def test_each_repetition_reads_its_own_run(tmp_path: Path) -> None:
    runs = [{"tests": ["knock"], "repetition": r, "omega": [10.0 + r], "omega_std": [0.01],
             "sensors": ["displacement_1_x"], "mode_shapes": [[1.0]]} for r in range(3)]
    path = tmp_path / "modal.json"
    path.write_text(json.dumps({"format": "structbench-result", "runs": runs}))
    for r in range(3):
        data = load(path, ["knock"], r)
        np.testing.assert_allclose(data.omega, [10.0 + r])
    np.testing.assert_allclose(load(path, ["other"], 2).omega, [12.0])  # the repetition alone
    np.testing.assert_allclose(load(path, ["knock"], None).omega, [10.0])  # the tests alone: the first
