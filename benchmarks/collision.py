"""How long does the scene's swept collision check take (docs/scene.md), the tool alone
(``scene.arm: unchecked``) and with the whole arm (a UR5e), side by side in one run?

Usage: ``.venv/bin/python benchmarks/collision.py [--repeats 200]``

A bin (300 x 200 x 150 mm inside, 10 mm walls) and three fixtures (a column beside the bin, a
conveyor and a fixture at the place), the floor, and a gripper of four solids (body, two open
fingers, a wrist camera); the arm starts with its elbow up and its wrist down above the bin.
Prints, for each check:

- one candidate: the time to check its whole pick and place (move to the approach, descent,
  lift-off, transfer, place descent, place retreat; 40 mm blends at the approach and the
  retreat) with the part in hand, parts spread over the bin's free middle; median and p90;
- a 20-candidate request near the walls: 19 parts against walls and in corners (cubes,
  symmetric about z by 90 deg, tilts up to 15 deg allowed: 16 alternatives each, most of which
  collide) and a last one that fits, through ``plan.choose`` with an arm that answers every
  controller query at once; the median and p90 time to the answer, and how many alternatives
  were checked.

Goals (issue 27): with the arm, one candidate at most 2 ms median CPU and the 20-candidate
request at most 40 ms; the tool alone no slower than before (2.2 ms and 51 ms idle). Then the
ratios of the two, and where the arm check's time goes (the joint paths, the sweep).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from measure import machine

from handeye_pick.cell.plan import blended, choose, pick_steps, place_steps
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig
from handeye_pick.detection import Detection, Symmetry
from handeye_pick.geometry import Transform, invert, make_transform, rotation_from_euler
from handeye_pick.hand_eye.files import load_hand_eye
from handeye_pick.scene.arm_legs import legs, start_joints
from handeye_pick.scene.check import SceneCheck

T_BASE_CAM = np.array([[1.0, 0, 0, -0.4], [0, -1.0, 0, 0], [0, 0, -1.0, 1.0], [0, 0, 0, 1.0]])
DOWN = np.diag([1.0, -1.0, -1.0])
T_FLANGE_TCP = make_transform(np.eye(3), [0.0, 0.0, 0.15])
T_BASE_FLANGE = make_transform(DOWN, [-0.4, 0.0, 0.6])
BIN = np.array([-0.4, 0.0, 0.05])  # the bin's inner floor centre (m)
CONFIG = """
robot: {host: benchmark, tcp_offset: [0, 0, 0.15, 0, 0, 0], model: ur5e}
hand_eye: {mode: eye-to-hand, file: eth.yaml, units: mm, camera_position_mm: [-400, 0, 1000]}
grasp:
  approach_mm: 200
  retreat_mm: 200
  object_T_tcp: [0, 0, 0.025, 0, 0, 0]
  tilt_max_deg: 15
motion: {speed_mps: 0.25, accel_mps2: 1.2, grasp_speed_mps: 0.05, blend_mm: 40}
workspace: {min_mm: [-800, -800, 0], max_mm: [800, 800, 800], max_tilt_deg: 30}
audit: {file: picks.jsonl}
place:
  poses: [[0.0, 0.40, 0.040, 3.14159265, 0, 0]]
  approach_mm: 250
  retreat_mm: 250
scene:
  arm: ARM
  clearance_mm: 5
  floor_z_mm: 0
  bins:
    - {name: parts, pose: [-0.4, 0, 0.05, 0, 0, 0], inner_mm: [300, 200, 150], wall_mm: 10,
       floor_mm: 10}
  boxes:
    - {name: column, pose: [-0.7, 0.3, 0.4, 0, 0, 0], size_mm: [100, 100, 800]}
    - {name: conveyor, pose: [0.3, 0.0, 0.35, 0, 0, 0], size_mm: [200, 1000, 100]}
    - {name: fixture, pose: [0.0, 0.40, 0.0075, 0, 0, 0], size_mm: [200, 200, 15]}
tool:
  shape:
    - {name: body, box: {size_mm: [50, 50, 80], pose: [0, 0, 0.055, 0, 0, 0]}}
    - {name: finger +x, box: {size_mm: [10, 20, 45], pose: [0.040, 0, 0.1275, 0, 0, 0]}}
    - {name: finger -x, box: {size_mm: [10, 20, 45], pose: [-0.040, 0, 0.1275, 0, 0, 0]}}
    - {name: camera, cylinder: {radius_mm: 20, length_mm: 60, pose: [0, 0.06, 0.03, 0, 0, 0]}}
"""


Q_CAPTURE = (-0.34, -1.8, 1.48, -1.25, -1.57, 1.23)
"""The arm's joints at the capture (rad): elbow up, wrist down, above the bin."""


class ReachableArm:
    """Answers every controller query of the pre-flight at once: every target reachable."""

    def joint_positions(self) -> tuple[float, ...]:
        return Q_CAPTURE

    def is_pose_within_safety_limits(self, T_base_tcp: Transform) -> bool:
        return True

    def has_ik_solution(self, T_base_tcp: Transform) -> bool:
        return True

    def joints_within_safety_limits(self, q_rad: object) -> bool:
        return True


def _config(folder: Path, arm: str) -> CellConfig:
    """The cell with ``scene.arm`` ``arm`` (checked or unchecked)."""
    (folder / "eth.yaml").write_text(
        "[[1, 0, 0, -400], [0, -1, 0, 0], [0, 0, -1, 1000], [0, 0, 0, 1]]\n"
    )
    (folder / f"{arm}.yaml").write_text(CONFIG.replace("ARM", arm))
    return load_config(folder / f"{arm}.yaml")


def _part(x_m: float, y_m: float, yaw_deg: float, symmetric: bool) -> Detection:
    """A 50 mm cube on the bin floor at (x, y) from the bin's centre."""
    R = rotation_from_euler([0.0, 0.0, yaw_deg], "xyz", "deg") @ DOWN
    T_base_obj = make_transform(R, BIN + np.array([x_m, y_m, 0.05]))
    return Detection(
        invert(T_BASE_CAM) @ T_base_obj,
        position_only=False,
        source=f"part at {x_m * 1000:.0f}, {y_m * 1000:.0f} mm",
        size_mm=(50.0, 50.0, 50.0),
        symmetry=Symmetry("z", 4) if symmetric else None,
    )


def _percentiles(times_s: list[float]) -> str:
    ms = sorted(t * 1000.0 for t in times_s)
    p90 = ms[min(len(ms) - 1, int(0.9 * len(ms)))]
    return f"median {statistics.median(ms):.2f} ms, p90 {p90:.2f} ms"


def one_candidate(config: CellConfig, repeats: int) -> tuple[str, float]:
    """The line to print and the median CPU time (s)."""
    if config.scene is None or config.place is None:
        raise SystemExit("the benchmark's config has a scene and a place")
    check = SceneCheck(config.scene, config.tool_shape, T_FLANGE_TCP, config.robot.model)
    start = T_BASE_FLANGE @ T_FLANGE_TCP
    rng = np.random.default_rng(1)
    times, cpu, paths, passed, looks = [], [], [], 0, 0
    for _ in range(repeats):
        x, y = rng.uniform(-0.06, 0.06), rng.uniform(-0.03, 0.03)
        yaw = rng.uniform(-30.0, 30.0)
        R = rotation_from_euler([0.0, 0.0, yaw], "xyz", "deg") @ DOWN
        T_base_obj = make_transform(R, BIN + np.array([x, y, 0.05]))
        grasp = T_base_obj @ config.grasp.T_obj_tcp
        approach = make_transform(R, grasp[:3, 3] + [0.0, 0.0, 0.2])
        plan_steps = pick_steps(_Plan(approach, grasp, approach), grip=True)
        plan_steps += place_steps(config.place.T_base_tcp[0], config.place, grip=True)
        steps = blended(config, plan_steps, start, 0.0)  # as choose with no path start cost
        began, began_cpu = time.perf_counter(), time.process_time()
        results = check.check(steps, start, (50.0, 50.0, 50.0), T_base_obj, grasp, Q_CAPTURE)
        if all(r.passed for r in results):  # a clear candidate is swept whole: the cost
            times.append(time.perf_counter() - began)
            cpu.append(time.process_time() - began_cpu)
            passed += 1
            if check.arm is not None:  # of which the joint paths alone
                began_cpu = time.process_time()
                model = check.arm.model
                q_start = start_joints(model, T_FLANGE_TCP, start, Q_CAPTURE)
                driven = legs(model, T_FLANGE_TCP, steps, start, q_start)
                looks = sum(len(leg.path.q) for leg in driven)
                paths.append(time.process_time() - began_cpu)
    share = (
        f"; the joint paths alone ({looks} looks): {_percentiles(paths)} CPU" if paths else ""
    )
    return (
        f"one clear candidate's pick and place: {_percentiles(times)} wall, "
        f"{_percentiles(cpu)} CPU ({passed} of {repeats} spread over the bin clear){share}",
        statistics.median(cpu) if cpu else float("nan"),
    )


class _Plan:
    """The three pick targets ``pick_steps`` reads."""

    def __init__(self, approach: Transform, grasp: Transform, retreat: Transform) -> None:
        self.approach, self.grasp, self.retreat = approach, grasp, retreat


def near_the_walls(config: CellConfig, repeats: int) -> tuple[str, float]:
    """The line to print and the median CPU time (s)."""
    calibration = load_hand_eye(config.hand_eye.file, config.hand_eye.mode, config.hand_eye.units)
    if config.place is None:
        raise SystemExit("the benchmark's config has a place")
    edge_x, edge_y = 0.150 - 0.025 - 0.008, 0.100 - 0.025 - 0.008
    corners = [_part(sx * edge_x, sy * edge_y, 0.0, True) for sx in (-1, 1) for sy in (-1, 1)]
    # Against the east and west walls with the fingers pointing at them, and no symmetry
    along_x = [_part(sx * edge_x, y, 0.0, False) for sx in (-1, 1) for y in (-0.05, 0.0, 0.05)]
    along_y = [_part(x, sy * edge_y, 90.0, False) for sy in (-1, 1) for x in (-0.1, -0.05, 0.0)]
    fits = _part(0.0, 0.0, 10.0, True)
    parts = [*corners, *along_x, *along_y, *along_x[:3], fits]  # 19 that collide, 1 that fits
    times, cpu = [], []
    chosen = None
    for _ in range(repeats):
        began, began_cpu = time.perf_counter(), time.process_time()
        chosen, refused = choose(
            config,
            calibration,
            parts,
            T_BASE_FLANGE,
            T_FLANGE_TCP,
            ReachableArm(),  # type: ignore[arg-type]
            {},
            T_base_tcp_place=config.place.T_base_tcp[0],
            grip=True,
        )
        times.append(time.perf_counter() - began)
        cpu.append(time.process_time() - began_cpu)
    tried = sum(len(r.reasons) for r in refused)
    index = chosen.index if chosen is not None else None
    return (
        f"20 candidates near the walls: {_percentiles(times)} wall, {_percentiles(cpu)} CPU to "
        f"the answer (candidate {index} taken, {tried} alternatives refused before it)",
        statistics.median(cpu),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        print(machine())
        medians: dict[str, list[float]] = {}
        for arm, title in (("unchecked", "the tool alone"), ("checked", "the whole arm")):
            config = _config(Path(folder), arm)
            print(f"{title} (scene.arm: {arm}):")
            one, one_s = one_candidate(config, args.repeats)
            twenty, twenty_s = near_the_walls(config, max(1, args.repeats // 10))
            print(f"  {one}\n  {twenty}")
            medians[arm] = [one_s, twenty_s]
        tool, arm_ = medians["unchecked"], medians["checked"]
        print(
            f"whole arm / tool alone (median CPU): one candidate {arm_[0] / tool[0]:.1f}x "
            f"({arm_[0] * 1000:.2f} vs {tool[0] * 1000:.2f} ms), 20 candidates "
            f"{arm_[1] / tool[1]:.1f}x ({arm_[1] * 1000:.1f} vs {tool[1] * 1000:.1f} ms)"
        )


if __name__ == "__main__":
    main()
