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


GRIPPER = (
    "robot: {tcp_offset: [0, 0, 0.1, 0, 0, 0], gripper: {bank: tool, index: 0, close_value: true}}"
)
CLOSED = 1 << 16  # tool output 0 in the motion record's digital_out
# A 40 x 40 x 80 mm part standing on the bin's floor (z 0.01 m) in its middle
PART = {"name": "post", "size_m": [0.04, 0.04, 0.08],
        "T_base_part": [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 0.01], [0, 0, 0, 1]]}


def test_the_held_part_rides_in_the_closed_gripper_and_counts_when_it_meets_a_wall(
    tmp_path: Path,
) -> None:
    (tmp_path / "cell.yaml").write_text(CONFIG.replace(CONFIG.splitlines()[1], GRIPPER))
    descent = {**_motion([[0.5, 0.0, z] for z in np.linspace(0.3, 0.07, 24)]), "digital_out": 0}
    # Grasped 20 mm below its top, lifted off the floor (resting on it: no contact) and carried
    # at TCP z 0.13 over the east wall (top 0.11): the fingers clear it by 20 mm, the part,
    # hanging 60 mm below the TCP, runs through it.
    lift = [[0.5, 0.0, z] for z in np.linspace(0.07, 0.13, 7)]
    carry = [[x, 0.0, 0.13] for x in np.linspace(0.5, 0.7, 21)]
    carried = {"motion": 2, "tcp_trace": [[*p, *DOWN] for p in lift + carry]}
    # more than 2 mm into the wall (x 0.60 to 0.61) with its 20 mm half width: 0.59 to 0.62
    through_wall = sum(1 for x in np.linspace(0.5, 0.7, 21) if 0.582 < x < 0.628)
    config = tmp_path / "cell.yaml"
    hit = count_contacts(config, [descent, {**carried, "digital_out": CLOSED}], parts=[PART])
    assert (hit.samples, hit.contacts, hit.carried) == (52, 0, 28)
    assert hit.part_contacts == through_wall
    assert hit.touched
    # The same motions with the gripper open, or without the parts: nothing in the fingers
    open_ = count_contacts(config, [descent, {**carried, "digital_out": 0}], parts=[PART])
    assert (open_.carried, open_.part_contacts, open_.touched) == (0, 0, False)
    assert count_contacts(config, [descent, {**carried, "digital_out": CLOSED}]).carried == 0
    # Released before the carry: the part stays behind
    lifted = {"motion": 2, "tcp_trace": [[*p, *DOWN] for p in lift], "digital_out": CLOSED}
    away = {"motion": 3, "tcp_trace": [[*p, *DOWN] for p in carry], "digital_out": 0}
    released = count_contacts(config, [descent, lifted, away], parts=[PART])
    assert (released.carried, released.part_contacts) == (7, 0)
    records, parts = tmp_path / "motions.jsonl", tmp_path / "parts.json"
    closed = {**carried, "digital_out": CLOSED}
    records.write_text("\n".join(json.dumps(m) for m in (descent, closed)))
    parts.write_text(json.dumps([PART]))
    argv = ["--config", str(config), "--motions", str(records)]
    assert main([*argv, "--parts", str(parts)]) == 1
    assert main(argv) == 0
