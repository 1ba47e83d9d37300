"""mocks/contact_check.py: it counts a pose at which the tool touches a bin, and only such."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mocks.contact_check import count_contacts, main

CONFIG = """
robot: {tcp_offset: [0, 0, 0.1, 0, 0, 0]}
scene:
  bins:
    - {name: parts, pose: [0.5, 0, 0.01, 0, 0, 0], inner_mm: [200, 200, 100], wall_mm: 10,
       floor_mm: 10}
tool:
  shape:
    - {name: finger, box: {size_mm: [10, 10, 40], pose: [0, 0, 0.08, 0, 0, 0]}}
"""
DOWN = [3.14159265, 0.0, 0.0]  # tool z pointing down


def _motion(points: list[list[float]]) -> dict[str, object]:
    return {"motion": 1, "tcp_trace": [[*p, *DOWN] for p in points]}


def test_a_descent_inside_the_bin_touches_nothing_one_onto_its_wall_does(tmp_path: Path) -> None:
    (tmp_path / "cell.yaml").write_text(CONFIG)
    heights = np.linspace(0.30, 0.05, 26).tolist()
    inside = _motion([[0.5, 0.0, z] for z in heights])
    onto_wall = _motion([[0.605, 0.0, z] for z in heights])  # over the east wall's middle
    clear = count_contacts(tmp_path / "cell.yaml", [inside])
    assert (clear.samples, clear.contacts) == (26, 0)
    assert clear.closest_mm > 0.0
    hit = count_contacts(tmp_path / "cell.yaml", [inside, onto_wall])
    assert hit.samples == 52
    # The fingertip (at the TCP) reaches the wall's top (0.11 m) at z 0.11 and stays in it.
    assert hit.contacts == sum(1 for z in heights if z <= 0.11 + 1e-9)
    assert "bin parts wall east" in hit.closest
    records = tmp_path / "motions.jsonl"
    records.write_text(json.dumps(onto_wall) + "\n")
    assert main(["--config", str(tmp_path / "cell.yaml"), "--motions", str(records)]) == 1
    records.write_text(json.dumps(inside) + "\n")
    assert main(["--config", str(tmp_path / "cell.yaml"), "--motions", str(records)]) == 0
    assert main(["--config", str(tmp_path / "missing.yaml"), "--motions", str(records)]) == 2
