"""The calibration pose list: what ``poses`` writes ``collect`` reads back exactly; every defect
is an error naming the file and the key."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from handeye_pick.calibration.pose_list import read_pose_list, write_pose_list
from handeye_pick.errors import InputError
from handeye_pick.geometry import ur_pose_to_matrix

TCP = ur_pose_to_matrix([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
ur_poses = st.tuples(
    *([st.floats(-1.0, 1.0)] * 3),
    *([st.floats(-math.pi, math.pi)] * 3),
)


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(poses=st.lists(ur_poses, min_size=1, max_size=6))
def test_written_poses_read_back_exactly(tmp_path: Path, poses: list[tuple[float, ...]]) -> None:
    path = tmp_path / "poses.yaml"
    targets = [ur_pose_to_matrix(list(pose)) for pose in poses]
    write_pose_list(path, targets, TCP, ["made by a test", "second line"])
    read = read_pose_list(path)
    assert [pose.name for pose in read.poses] == [f"pose {i}" for i in range(len(poses))]
    for pose, T in zip(read.poses, targets, strict=True):
        assert pose.q_rad is None
        assert pose.T_base_tcp is not None
        np.testing.assert_allclose(pose.T_base_tcp, T, atol=1e-12)
    assert read.T_flange_tcp is not None
    np.testing.assert_allclose(read.T_flange_tcp, TCP, atol=1e-12)
    assert path.read_text().startswith("# made by a test\n# second line\n")


def test_joint_entries_and_no_tcp_offset(tmp_path: Path) -> None:
    path = tmp_path / "poses.yaml"
    path.write_text(
        "poses:\n  - joints_rad: [0, -1.57, 1.57, -1.57, -1.57, 0]\n"
        "  - tcp_pose: [-0.5, -0.1, 0.4, 3.1416, 0, 0]\n"
    )
    read = read_pose_list(path)
    assert read.T_flange_tcp is None
    assert read.poses[0].q_rad == (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)
    assert read.poses[1].T_base_tcp is not None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("tcp_offset: [0, 0, 0.1, 0, 0, 0]\n", "poses: missing"),
        ("poses: []\n", "poses: expected a list of poses"),
        ("poses:\n  - {tcp_pose: [0.3, 0, 0.3, 0, 0, 0]}\nextra: 1\n", "extra: unknown key"),
        ("poses:\n  - tcp_pse: [0.3, 0, 0.3, 0, 0, 0]\n", "did you mean 'tcp_pose'"),
        (
            "poses:\n  - {tcp_pose: [0.3, 0, 0.3, 0, 0, 0], joints_rad: [0, 0, 0, 0, 0, 0]}\n",
            "poses.0: give exactly one",
        ),
        ("poses:\n  - joints_rad: [0, -90, 90, -90, -90, 0]\n", "degrees given"),
        ("poses:\n  - tcp_pose: [0.3, 0, 0.3, 0, 0, 0]\n  - tcp_pose: [300, 0, 300, 0, 0, 0]\n",
         "poses.1.tcp_pose: translation"),
        ("tcp_offset: [0, 0, 0.1]\nposes:\n  - tcp_pose: [0.3, 0, 0.3, 0, 0, 0]\n", "tcp_offset"),
        ("poses: [\n", "not valid YAML"),
    ],
    ids=[
        "no-poses", "empty", "unknown-key", "misspelt", "both", "degrees", "millimetres",
        "short-tcp-offset", "syntax",
    ],
)  # fmt: skip
def test_defects_are_errors_naming_the_file_and_key(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "poses.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as caught:
        read_pose_list(path)
    assert str(path) in str(caught.value)


def test_a_missing_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read"):
        read_pose_list(tmp_path / "none.yaml")
