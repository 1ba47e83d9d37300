"""The path ur_rtde injects into its control script, read as a controller's compiler would.

ur_rtde's moveL(path), moveJ(path) and movePath() put one waypoint per two lines right after
the line `# inject move path` inside `def exec_move_path():` and re-upload the whole script:

    signal_async_progress(0)
    movel(p[x,y,z,rx,ry,rz],a=A,v=V,r=R)        (movej([q1,...,q6],a=A,v=V,r=R) for joints)
    signal_async_progress(1)
    ...

up to the `end` that closes the function. Numbers are C++ stream output (6 significant digits,
`1e-07` style exponents). Anything else in that place is a compile error: the program does not
start (`PathSyntaxError`). movel targets are TCP poses in the base frame (m, rad), movej targets
joints (rad); a is m/s^2 or rad/s^2, v m/s or rad/s, r the blend radius in m.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

INJECT_MARKER = "# inject move path"

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_SIGNAL = re.compile(r"signal_async_progress\((\d+)\)")
_MOVE = re.compile(
    rf"(movel|movej)\((p?)\[([^\]]*)\],\s*a=({_NUMBER}),\s*v=({_NUMBER}),\s*r=({_NUMBER})\)"
)
_NUMBER_ONLY = re.compile(rf"{_NUMBER}")


class PathSyntaxError(ValueError):
    """The injected path does not compile; the message says which line and why."""


@dataclass(frozen=True)
class Waypoint:
    """One `movel`/`movej` line: target (pose or joints), accel, speed and blend radius (m)."""

    target: tuple[float, ...]
    accel: float
    speed: float
    blend: float


@dataclass(frozen=True)
class PathSpec:
    """The injected path: "movel" (TCP poses) or "movej" (joints), waypoints in order."""

    move: str
    waypoints: tuple[Waypoint, ...]


def injected_path(program: str) -> PathSpec | None:
    """The path injected into `program`, None when the marker is absent or nothing follows it.

    Raises PathSyntaxError for a line a controller would not compile, a mix of movel and movej
    (ur_rtde never sends one, and the simulator models one kind per path), or movep/movec lines,
    which the simulator does not model.
    """
    lines = program.splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == INJECT_MARKER]
    if not starts:
        return None
    body: list[str] = []
    for line in lines[starts[0] + 1 :]:
        text = line.strip()
        if text == "end":
            break
        if text:
            body.append(text)
    else:
        raise PathSyntaxError("exec_move_path() has no closing `end`")
    if not body:
        return None
    return _parse(body)


def _parse(body: list[str]) -> PathSpec:
    if len(body) % 2:
        raise PathSyntaxError(
            f"{len(body)} lines: each waypoint is a signal_async_progress line and a move line"
        )
    waypoints: list[Waypoint] = []
    kinds: set[str] = set()
    for index in range(len(body) // 2):
        signal, move = body[2 * index], body[2 * index + 1]
        found = _SIGNAL.fullmatch(signal)
        if found is None or int(found.group(1)) != index:
            raise PathSyntaxError(f"expected signal_async_progress({index}), got {signal!r}")
        kind, waypoint = _move_line(move)
        kinds.add(kind)
        waypoints.append(waypoint)
    if len(kinds) > 1:
        raise PathSyntaxError("a path mixes movel and movej lines")
    return PathSpec(kinds.pop(), tuple(waypoints))


def _move_line(line: str) -> tuple[str, Waypoint]:
    if line.startswith(("movep(", "movec(")):
        raise PathSyntaxError(f"{line.split('(')[0]} is not simulated: {line!r}")
    found = _MOVE.fullmatch(line)
    if found is None:
        raise PathSyntaxError(f"not a movel/movej line: {line!r}")
    kind, pose_prefix, values, accel, speed, blend = found.groups()
    if (kind == "movel") != (pose_prefix == "p"):
        raise PathSyntaxError(f"movel takes a pose p[...], movej joints [...]: {line!r}")
    items = [item.strip() for item in values.split(",")]
    if len(items) != 6 or not all(_NUMBER_ONLY.fullmatch(item) for item in items):
        raise PathSyntaxError(f"the target must be 6 numbers: {line!r}")
    target = tuple(float(item) for item in items)
    numbers = (*target, float(accel), float(speed), float(blend))
    if not all(math.isfinite(value) for value in numbers):
        raise PathSyntaxError(f"a number out of range: {line!r}")
    return kind, Waypoint(target, float(accel), float(speed), float(blend))
