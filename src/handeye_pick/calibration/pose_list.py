"""The calibration pose list: the poses ``collect`` visits in order, as ``poses`` writes them.

One YAML file, read strictly like the cell config (unknown keys, wrong types, a unit mix-up are
errors naming the file and the key)::

    tcp_offset: [0, 0, 0.12, 0, 0, 0]                  # optional: the TCP of the tcp_pose entries
    poses:
      - tcp_pose: [-0.5, -0.12, 0.45, 3.1416, 0, 0]    # T_base_tcp, UR vector (m, rad): moveL
      - joints_rad: [0, -1.57, 1.57, -1.57, -1.57, 0]  # six joint positions (rad): moveJ

Each entry holds exactly one of ``tcp_pose`` and ``joints_rad``, with the same checks as the
config's named poses. Entries are named by their place in the list (``pose 0``, ``pose 1``, ...)
in progress lines and audit records. A ``tcp_pose`` puts the active TCP, not the flange, at the
pose; ``tcp_offset`` (m, rad) records which TCP that was, so a list made for another TCP is
refused rather than followed (``collect`` compares it with ``robot.tcp_offset``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from handeye_pick.config.poses import NAMED_POSE_KEYS, named_pose, pose_vector
from handeye_pick.config.reader import Fields, read_yaml_mapping
from handeye_pick.config.schema import MAX_TCP_OFFSET_M, NamedPose
from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform, ur_pose_list


@dataclass(frozen=True)
class PoseList:
    """The poses of one list file, in file order."""

    path: Path
    poses: tuple[NamedPose, ...]  # named "pose 0", "pose 1", ...
    T_flange_tcp: Transform | None  # the TCP offset the tcp_pose entries are for (m), or None


def pose_name(index: int) -> str:
    """The name of the list's entry ``index`` (from 0) in messages and audit records."""
    return f"pose {index}"


def read_pose_list(path: Path) -> PoseList:
    """Read and check a pose list; ``InputError`` naming the file and the key on any defect."""
    top = Fields(
        read_yaml_mapping(path, InputError),
        source=str(path),
        prefix="",
        allowed=("tcp_offset", "poses"),
        error=InputError,
    )
    listed = top.raw("poses")
    if not isinstance(listed, list) or not listed:
        top.fail("poses", "expected a list of poses (tcp_pose: [m, rad] or joints_rad: [rad])")
    entries = Fields(
        {str(i): entry for i, entry in enumerate(listed)},
        source=str(path),
        prefix="poses",
        allowed=[str(i) for i in range(len(listed))],
        error=InputError,
    )
    poses = tuple(
        named_pose(entries.section(str(i), NAMED_POSE_KEYS), pose_name(i))
        for i in range(len(listed))
    )
    T_flange_tcp = (
        pose_vector(top, "tcp_offset", MAX_TCP_OFFSET_M) if top.has("tcp_offset") else None
    )
    return PoseList(Path(path), poses, T_flange_tcp)


def write_pose_list(
    path: Path, T_base_tcp: Sequence[Transform], T_flange_tcp: Transform, comment: Sequence[str]
) -> None:
    """Write TCP poses (m) as a pose list for the TCP ``T_flange_tcp`` (m), with ``comment``
    lines on top (what made the list). Floats are written with their full precision."""
    lines = [f"# {line}" for line in comment]
    lines.append(f"tcp_offset: {_flow(ur_pose_list(T_flange_tcp))}  # m, rad")
    lines.append("poses:  # T_base_tcp as UR vectors (m, rad), visited in this order")
    lines += [f"  - tcp_pose: {_flow(ur_pose_list(T))}" for T in T_base_tcp]
    try:
        Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None


def _flow(values: list[float]) -> str:
    return "[" + ", ".join(_yaml_float(v) for v in values) + "]"


def _yaml_float(value: float) -> str:
    """Full precision, and a YAML 1.1 float: PyYAML reads 1e-05 (no dot) as text, 1.0e-05 not."""
    text = repr(value)
    return text.replace("e", ".0e", 1) if "e" in text and "." not in text else text
