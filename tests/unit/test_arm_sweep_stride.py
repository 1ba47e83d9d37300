"""The whole arm's sweep looks first at every ``SWEEP_STRIDE``-th look of a joint path and adds
the looks inside the steps those do not prove (scene/arm_collide.py): on random obstacles near
the arm's path it refuses exactly what a sweep of every look refuses, with the same words; and
a step's bound counts every turn of a joint, also one that turns back within the step."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from handeye_pick.config.schema import SceneBox
from handeye_pick.geometry import make_transform
from handeye_pick.safety import CheckResult
from handeye_pick.scene import arm_collide
from tests.unit.test_scene_arm_check import (
    DESCENT,
    Q_START,
    T_START,
    _box_at_link,
    _check,
    _end_joints,
)


def _swept(box: SceneBox, stride: int) -> list[CheckResult]:
    before = arm_collide.SWEEP_STRIDE
    arm_collide.SWEEP_STRIDE = stride
    try:
        return _check((box,)).check_tool(DESCENT, T_START, tuple(Q_START))
    finally:
        arm_collide.SWEEP_STRIDE = before


@settings(max_examples=30, deadline=None)
@given(
    link=st.sampled_from(["forearm", "wrist 1", "wrist 2", "wrist 3", "elbow"]),
    offset=st.tuples(*[st.floats(-0.15, 0.15)] * 3),
    size_mm=st.floats(10.0, 80.0),
)
def test_the_strided_sweep_refuses_what_the_sweep_of_every_look_refuses(
    link: str, offset: tuple[float, float, float], size_mm: float
) -> None:
    box = _box_at_link(link, _end_joints(DESCENT), "box", size_mm)
    box = SceneBox("box", box.size_mm, make_transform(np.eye(3), box.T_base_box[:3, 3] + offset))
    every, strided = _swept(box, 1), _swept(box, arm_collide.SWEEP_STRIDE)
    assert [r.passed for r in strided] == [r.passed for r in every]
    assert [r.detail for r in strided if not r.passed] == [r.detail for r in every if not r.passed]


def test_a_joint_that_turns_back_counts_both_ways() -> None:
    q = np.zeros((5, 6))
    q[:, 2] = [0.0, 0.02, 0.04, 0.02, 0.0]  # out and back within the second step
    turned = arm_collide._turned(q, np.array([0, 2, 4]))
    assert turned[:, 2] == pytest.approx([0.0, 0.04, 0.04])
    assert np.all(turned[:, [0, 1, 3, 4, 5]] == 0.0)


def test_the_pairs_with_the_part_begin_with_those_without_it() -> None:
    """The sweep screens the pairs of the tool with the part once and reads a leg without the
    part from their beginning."""
    arm = _check(()).arm
    assert arm is not None
    plain = arm._pairs(list(arm._tool))
    held = arm._pairs([*arm._tool, arm._tool[0]])
    P = len(plain.body)
    assert len(held.body) > P
    for mine, theirs in ((plain.body, held.body), (plain.other, held.other)):
        assert np.array_equal(mine, theirs[:P])
    assert np.array_equal(plain.moving, held.moving[:P])


def test_every_strided_look_set_begins_and_ends_with_the_path() -> None:
    for looks in range(1, 12):
        looked = arm_collide._strided(looks)
        assert looked[0] == 0
        assert looked[-1] == looks - 1
        assert np.all(np.diff(looked) >= 1)
        assert np.all(np.diff(looked) <= arm_collide.SWEEP_STRIDE)
