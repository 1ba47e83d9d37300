"""Cycle time at the motion floor: a realistic UR5e pick cell through ``handeye-pick run``, as a
vision client drives it, stop-and-go against blended against blended with vision under motion.

One cell (transfers 1.0 m/s and 3 m/s², descents and put-downs 0.25 m/s, a suction gripper that
takes 0.15 s to switch, a camera acquisition of 0.3 s and 0.5 s of detection in the client),
eye-in-hand and eye-to-hand, each cycle a capture, a pick and a place of a part lying within a few
centimetres of the bin's centre. The simulated controller runs on 127.0.0.246 (``--host``) at
``--speed-factor`` times real speed; every wait of the client and the gripper is divided by the
same factor and every time printed is multiplied back, so the figures are real-speed cycle times
(the software's own time is multiplied too: the figures err on the slow side).

Variants, side by side in one run, each waited for by the client and with vision under motion:

- stop-and-go: ``motion.blend_mm: 0`` (every target a stop);
- blended always: ``blend_mm: 50`` (radii limited as docs/motion.md says) and
  ``blend_always: true``: every stretch of corners sent as one path, whatever its start costs;
- blended where it pays: ``blend_mm: 50``: a stretch goes as one path only where the session's
  motion-time model says its corners save more than the path start it measured at connect
  (docs/motion.md, "Blend only where it pays").

The client that waits: capture, acquire, detect, pick (which places), next. Vision under motion:
eye-in-hand, the pick keeps the part (``"place": false``); the client captures at once, from the
capture pose above the bin with the part in hand, and as soon as the acquisition returns sends
``place`` and detects while the arm places; the next pick waits in ``run``'s queue and plans from
the pose latched at the image. Eye-to-hand: the camera is fixed, so the client acquires and
detects on the pick's ``view-clear`` event (the arm has left the camera's view after the retreat)
and queues the next pick while the arm places.

The floor of a variant with vision under motion: its controller motion time per cycle (from the
simulator's motion record), the stops motion cannot hide (the gripper's switching and,
eye-in-hand, the acquisition: the camera needs a still arm) and the start of every path it sent
(the profile's start cost for the uploaded script); detection fully hidden.

``--ahead`` runs only the variants with vision under motion, each twice side by side: the queued
pick checked while the place moves (docs/motion.md, "The next pick checked under motion") and
checked only in its turn (``run --no-check-ahead``).

The simulated controller charges a program start as its profile says (``program_start_cost``,
mocks/ur_controller/README.md "Program start cost"): every path ur_rtde uploads starts that
long after it arrives, as on a real controller; the figure used is printed.

Prints per variant the median cycle time (p90), picks per hour and paths per cycle, each
overlapped variant's floor, and the best variant against its floor and against stop-and-go.
Goals (issue 29): the best variant within 2 % of its floor; blending where it pays never slower
than stop-and-go.
Run: ``.venv/bin/python benchmarks/cycle_time.py [--cycles 10] [--speed-factor 1]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ lives beside src/

from benchmarks.run_pipe import Pipe  # noqa: E402
from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix  # noqa: E402
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402
from mocks.ur_controller.profiles import DEFAULT_PROFILE, PROFILES  # noqa: E402

HOST = "127.0.0.246"  # not 127.0.0.1: leaves the demo and the tests' addresses alone
CLI = [sys.executable, "-c", "import sys; from handeye_pick.cli import main; sys.exit(main())"]
TCP_OFFSET = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)  # a 120 mm suction tool
DOWN = "3.14159265, 0, 0"  # tool z straight down
ACQUISITION_S = 0.3  # the camera's exposure and read-out (arm still, eye-in-hand)
DETECTION_S = 0.5  # the client's detection on the cloud
GRIPPER_S = 0.15  # the valve and the cup's vacuum
BIN_CENTRE_M = np.array([-0.50, -0.25, 0.06])  # the grasp point of a part in the bin, base frame
# Eye-to-hand: a camera 1.2 m above the base looking straight down over the bin (T_base_cam, mm).
T_BASE_CAM_MM = "[[0, 1, 0, -500], [1, 0, 0, -250], [0, 0, -1, 1200], [0, 0, 0, 1]]\n"
SCRIPT_LINES = 1180  # lines of ur_rtde 1.6.5's control script with a short path injected
PLACES = ["[-0.20, 0.35, 0.10, {d}]", "[-0.30, 0.35, 0.10, {d}]", "[-0.40, 0.35, 0.10, {d}]"]


@dataclass(frozen=True)
class Mode:
    """One camera mounting: its hand-eye section and the capture pose it uses."""

    name: str
    eye_in_hand: bool


@dataclass(frozen=True)
class Variant:
    """How the cell blends and how the client drives it."""

    label: str
    blend_mm: float
    always: bool  # motion.blend_always
    overlap: bool  # vision under motion
    ahead: bool = True  # the queued pick checked while the place moves


VARIANTS = [
    Variant("stop-and-go", 0.0, False, False),
    Variant("blended always", 50.0, True, False),
    Variant("blended where it pays", 50.0, False, False),
    Variant("stop-and-go, vision under motion", 0.0, False, True),
    Variant("blended always, vision under motion", 50.0, True, True),
    Variant("where it pays, vision under motion", 50.0, False, True),
]


def cell_yaml(folder: Path, mode: Mode, variant: Variant, factor: float, host: str) -> str:
    if mode.eye_in_hand:
        hand_eye = f"  mode: eye-in-hand\n  file: {ROOT / 'config/loop/hand_eye.yaml'}\n"
        capture = "  pose: capture\n"
    else:
        (folder / "eth.yaml").write_text(T_BASE_CAM_MM)
        hand_eye = f"  mode: eye-to-hand\n  file: {folder / 'eth.yaml'}\n"
        hand_eye += "  camera_position_mm: [-500, -250, 1200]\n"
        capture = "  pose: aside\n  view_clear_at: retreat\n"
    places = "".join(f"    - {p.format(d=DOWN)}\n" for p in PLACES)
    return f"""
robot:
  host: {host}
  tcp_offset: {list(TCP_OFFSET)}
  watchdog_s: 1.0  # the simulated controller falls behind on a busy shared machine
  gripper: {{bank: tool, index: 0, close_value: true, settle_s: {GRIPPER_S / factor:.4f}}}
hand_eye:
{hand_eye}  units: mm
grasp: {{approach_mm: 100, retreat_mm: 100}}
motion: {{speed_mps: 1.0, accel_mps2: 3.0, grasp_speed_mps: 0.25, blend_mm: {variant.blend_mm},
         blend_always: {str(variant.always).lower()}}}
workspace: {{min_mm: [-750, -500, 20], max_mm: [0, 500, 600], max_tilt_deg: 10}}
audit: {{file: {folder / 'picks.jsonl'}}}
poses:
  capture: {{tcp_pose: [-0.50, -0.10, 0.45, {DOWN}]}}
  aside: {{tcp_pose: [-0.30, 0.10, 0.30, {DOWN}]}}
place:
  poses:
{places}  approach_mm: 100
  retreat_mm: 100
capture:
{capture}"""


class Client:
    """The vision program: drives ``run`` through its pipe, acquiring and detecting in
    simulated time (sleeps scaled by the speed factor)."""

    def __init__(self, pipe: Pipe, mode: Mode, folder: Path, factor: float, seed: int) -> None:
        self.pipe, self.mode, self.factor = pipe, mode, factor
        self._rng = np.random.default_rng(seed)
        self._T_flange_cam_m = (
            load_hand_eye(ROOT / "config/loop/hand_eye.yaml", HandEyeMode.EYE_IN_HAND, "mm").T_cal
            if mode.eye_in_hand
            else None
        )
        self._T_base_cam_m = (
            None
            if mode.eye_in_hand
            else load_hand_eye(folder / "eth.yaml", HandEyeMode.EYE_TO_HAND, "mm").T_cal
        )

    def wait(self, seconds: float) -> None:
        time.sleep(seconds / self.factor)

    def detection(self, capture: dict[str, Any]) -> dict[str, Any]:
        """The part's grasp point as the camera sees it (mm), a few cm around the bin centre."""
        p_base = BIN_CENTRE_M + np.append(self._rng.uniform(-0.03, 0.03, 2), 0.0)
        if self._T_flange_cam_m is not None:
            T_base_cam = ur_pose_to_matrix(capture["flange_pose_ur"]) @ self._T_flange_cam_m
        else:
            assert self._T_base_cam_m is not None
            T_base_cam = self._T_base_cam_m
        p_cam = transform_point(invert(T_base_cam), p_base) * 1000.0
        return {"position_mm": [float(v) for v in p_cam]}

    def until(self, rid: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
        """Lines up to the reply to ``rid``: (the reply, the lines before it)."""
        before = []
        while True:
            line = self.pipe.reply()
            if str(line.get("id")) == rid and "ok" in line:
                if not line["ok"]:
                    raise RuntimeError(f"request {rid} failed: {line}")
                return line, before
            before.append(line)

    def ask(self, request: dict[str, Any]) -> dict[str, Any]:
        reply, _ = self.until(self.pipe.send(request))
        return reply

    def stop_and_go(self, cycles: int) -> list[float]:
        """(a), (b): capture, acquire, detect, pick and place, each waited for."""
        ends = [time.perf_counter()]
        for _ in range(cycles):
            capture = self.ask({"op": "capture"})
            self.wait(ACQUISITION_S + DETECTION_S)
            pick = {"op": "pick", "candidates": [self.detection(capture)]}
            if self.mode.eye_in_hand:
                pick["capture_id"] = capture["capture_id"]
            self.ask(pick)
            ends.append(time.perf_counter())
        return list(np.diff(ends))

    def eye_in_hand_overlap(self, cycles: int) -> list[float]:
        """(c) eye-in-hand: the next image is taken right after the lift, part in hand, from
        the capture pose above the bin; the part is placed while the client detects, and the
        next pick waits in run's queue, planned from the pose latched at that image."""
        capture = self.ask({"op": "capture"})
        self.wait(ACQUISITION_S + DETECTION_S)
        pending = self.pipe.send(self._keep(capture))
        ends = [time.perf_counter()]
        for cycle in range(cycles):
            self.until(pending)  # picked and lifted: the part is in the gripper
            capture = self.ask({"op": "capture"})
            self.wait(ACQUISITION_S)
            place = self.pipe.send({"op": "place"})
            self.wait(DETECTION_S)  # while the arm places
            if cycle + 1 < cycles:
                pending = self.pipe.send(self._keep(capture))
            self.until(place)
            ends.append(time.perf_counter())
        return list(np.diff(ends))

    def _keep(self, capture: dict[str, Any]) -> dict[str, Any]:
        """A pick of the part seen in ``capture`` that keeps it in the gripper (no place)."""
        return {
            "op": "pick",
            "capture_id": capture["capture_id"],
            "candidates": [self.detection(capture)],
            "place": False,
        }

    def eye_to_hand_overlap(self, cycles: int) -> list[float]:
        """(c) eye-to-hand: image and detect on view-clear, the next pick queued while the arm
        places; the first image is taken at the capture pose."""
        capture = self.ask({"op": "capture"})
        self.wait(ACQUISITION_S + DETECTION_S)
        pending = self.pipe.send(
            {"op": "pick", "candidates": [self.detection(capture)], "events": True}
        )
        ends = [time.perf_counter()]
        for cycle in range(cycles):
            while True:  # up to the arm leaving the camera's view
                line = self.pipe.reply()
                if "ok" in line:
                    raise RuntimeError(f"the pick ended before view-clear: {line}")
                if line.get("event") == "view-clear":
                    break
            self.wait(ACQUISITION_S + DETECTION_S)
            following = None
            if cycle + 1 < cycles:
                following = self.pipe.send(
                    {"op": "pick", "candidates": [self.detection(capture)], "events": True}
                )
            self.until(pending)
            ends.append(time.perf_counter())
            if following is not None:
                pending = following
        return list(np.diff(ends))


@dataclass(frozen=True)
class Measured:
    """One variant's run: cycle times and, per cycle, the controller's motion time and the
    paths sent (s, real speed)."""

    times: list[float]
    moving_s: float
    paths: float


def run_variant(
    mode: Mode, variant: Variant, cycles: int, factor: float, seed: int, host: str
) -> Measured:
    """Cycle times (s, real speed), the controller's motion time and the paths per cycle."""
    with tempfile.TemporaryDirectory() as tmp, SimulatedController(
        host=host, tcp_offset=TCP_OFFSET, speed_factor=factor, program_start_cost=True
    ) as ctl:
        folder = Path(tmp)
        (folder / "cell.yaml").write_text(cell_yaml(folder, mode, variant, factor, host))
        process = subprocess.Popen(
            [*CLI, "run", "--config", str(folder / "cell.yaml")]
            + ([] if variant.ahead else ["--no-check-ahead"]),
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
        )
        try:
            client = Client(Pipe(process), mode, folder, factor, seed)
            client.ask({"op": "capture"})  # to the capture pose: the first cycle starts there
            first_motion, first_command = len(ctl.motions), len(ctl.commands)
            if not variant.overlap:
                times = client.stop_and_go(cycles)
            elif mode.eye_in_hand:
                times = client.eye_in_hand_overlap(cycles)
            else:
                times = client.eye_to_hand_overlap(cycles)
            # Controller time runs at wall speed; the arm covers its path factor times faster.
            moving_s = factor * sum(m["moving_s"] for m in ctl.motions[first_motion:])
            paths = sum(c["kind"] == "movePath" for c in ctl.commands[first_command:])
        finally:
            process.kill()
            process.wait()
    return Measured([t * factor for t in times], moving_s / cycles, paths / cycles)


def _median_p90(values: list[float]) -> tuple[float, float]:
    ordered = sorted(values)
    return statistics.median(ordered), ordered[min(len(ordered) - 1, int(0.9 * len(ordered)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=10, help="cycles per variant (default 10)")
    # At 1: the session measures a path's start in wall-clock time and its motion-time model
    # counts real-speed time; at another speed the two disagree and skew where blending pays.
    parser.add_argument("--speed-factor", type=float, default=1.0, help="simulated speed (1)")
    parser.add_argument("--seed", type=int, default=1, help="where the parts lie (default 1)")
    parser.add_argument("--host", default=HOST, help=f"simulated controller address ({HOST})")
    parser.add_argument(
        "--ahead",
        action="store_true",
        help="only vision under motion, the queued pick checked under motion against in its turn",
    )
    args = parser.parse_args()
    if args.ahead:
        ahead_main(args)
        return
    factor = args.speed_factor
    print(
        f"cycle time per capture/pick/place ({args.cycles} cycles per variant, simulated UR5e "
        f"at {args.host} run at {factor:g} x speed, times scaled back to real speed)"
    )
    print(
        f"  transfers 1.0 m/s 3 m/s^2, descents 0.25 m/s, gripper {GRIPPER_S} s, acquisition "
        f"{ACQUISITION_S} s, detection {DETECTION_S} s"
    )
    per_line_s = PROFILES[DEFAULT_PROFILE].program_start_s_per_line
    print(
        f"  program start cost ({DEFAULT_PROFILE} profile): {per_line_s * 1e3:g} ms a line, about "
        f"{SCRIPT_LINES * per_line_s:.2f} s for each path's {SCRIPT_LINES}-line upload (an "
        f"estimate, mocks/ur_controller/README.md)"
    )
    path_start_s = SCRIPT_LINES * per_line_s
    for mode in (Mode("eye-in-hand", True), Mode("eye-to-hand", False)):
        try:
            results = {
                v: run_variant(mode, v, args.cycles, factor, args.seed, args.host)
                for v in VARIANTS
            }
        except (RuntimeError, TimeoutError, OSError) as exc:
            sys.exit(f"cycle_time: {mode.name} did not run through: {exc}")
        unavoidable_s = 2 * GRIPPER_S + (ACQUISITION_S if mode.eye_in_hand else 0.0)
        print(f"{mode.name}:")
        medians = {v: statistics.median(m.times) for v, m in results.items()}
        floors = {
            v: m.moving_s + unavoidable_s + m.paths * path_start_s
            for v, m in results.items()
            if v.overlap
        }
        for variant, measured in results.items():
            median, p90 = _median_p90(measured.times)
            floor = f"  floor {floors[variant]:5.2f} s" if variant in floors else ""
            print(
                f"  {variant.label:<36} median {median:5.2f} s  p90 {p90:5.2f} s  "
                f"{3600.0 / median:6.0f} picks/h  (arm moving {measured.moving_s:4.2f} s, "
                f"{measured.paths:3.1f} paths){floor}"
            )
        best = min(floors, key=lambda v: medians[v])
        pays_overlap, always_overlap, stop_overlap = VARIANTS[5], VARIANTS[4], VARIANTS[3]
        print(
            f"  best: {best.label}, {medians[best] / floors[best]:.3f} x its floor; where it "
            f"pays / stop-and-go {medians[VARIANTS[2]] / medians[VARIANTS[0]]:.3f} (client "
            f"waits), {medians[pays_overlap] / medians[stop_overlap]:.3f} (vision under "
            f"motion); always / stop-and-go {medians[always_overlap] / medians[stop_overlap]:.3f}"
            " (vision under motion)"
        )

def ahead_main(args: argparse.Namespace) -> None:
    """``--ahead``: each variant with vision under motion, the queued pick checked while the
    place moves against checked only in its turn, side by side in one run."""
    factor = args.speed_factor
    print(
        f"vision under motion, the queued pick checked under motion vs in its turn "
        f"({args.cycles} cycles per variant, simulated UR5e at {args.host}, {factor:g} x speed)"
    )
    for mode in (Mode("eye-in-hand", True), Mode("eye-to-hand", False)):
        print(f"{mode.name}:")
        for variant in VARIANTS[3:]:
            turn = replace(variant, ahead=False)
            try:
                ahead = run_variant(mode, variant, args.cycles, factor, args.seed, args.host)
                later = run_variant(mode, turn, args.cycles, factor, args.seed, args.host)
            except (RuntimeError, TimeoutError, OSError) as exc:
                sys.exit(f"cycle_time: {mode.name} did not run through: {exc}")
            ahead_s, later_s = statistics.median(ahead.times), statistics.median(later.times)
            print(
                f"  {variant.label:<36} checked ahead {ahead_s:5.3f} s  in its turn "
                f"{later_s:5.3f} s  ratio {ahead_s / later_s:.3f}"
            )


if __name__ == "__main__":
    main()
