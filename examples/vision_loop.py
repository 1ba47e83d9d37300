"""A vision client driving `handeye-pick run` through a pipe: five capture/pick/place cycles, the
vision hidden under the arm's motion.

Starts the simulated UR5e controller (mocks/ur_controller) at the address in the cell config,
builds a simulated scene (a table and five boxes, mocks/camera) watched by a camera mounted
exactly where the hand-eye file says (a perfect calibration, so every error left is the vision's
or the cell's), starts

    handeye-pick run --config config/loop.yaml    (or config/loop-eye-to-hand.yaml)

and picks the five boxes. Eye-in-hand (the default, a wrist camera): each cycle asks `run` to
capture at the named pose `capture`, renders the cloud from the simulated arm's pose, sends the
arm on to the pose `hover` above the boxes at once and finds the boxes' top faces (plain numpy
and scipy.ndimage) while it moves, then sends them as candidates of a pick that waits in run's
queue and plans from the pose latched at the image. Eye-to-hand (`--eye-to-hand`, a camera
fixed above the table): the first image is taken with the arm aside; after that each image is
taken on the pick's `view-clear` event, as soon as the arm has left the camera's view, and the
next pick is queued while the arm places. Every cycle checks that the grasp (planned and
reached) landed within 1 mm of the true centre of a box's top face and moves that box to where
it was placed, and prints its cycle time, the share of it the arm moved and the detection time
hidden under motion. Exits 0 when every check passed, 1 otherwise. A Ctrl-C reaches the example
and `run`, not the simulated robot: `run` stops the arm and exits 130, then the controller is
stopped and the example exits 130.

The terminal shows the loop's story: the example's lines (stdout) and `run`'s progress (stderr).
The simulated controller's log goes to out/vision_loop-simulator.log under the current folder,
named at the start.

Run it from anywhere after `pip install -e .`:  python examples/vision_loop.py [--eye-to-hand]
"""

from __future__ import annotations

import argparse
import json
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
import yaml
from numpy.typing import NDArray
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ is not installed with the package: import it from the clone

from mocks.camera import Intrinsics, Scene, SimulatedCamera, read_zivid_matrix  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402
from mocks.ur_controller.kinematics import pose_to_matrix  # noqa: E402

CONFIG = ROOT / "config" / "loop.yaml"
CONFIG_EYE_TO_HAND = ROOT / "config" / "loop-eye-to-hand.yaml"
SIMULATOR_LOG = Path("out") / "vision_loop-simulator.log"  # under the current folder
EXIT_INTERRUPTED = 130  # Ctrl-C, as handeye-pick's own commands
CYCLES = 5
TOLERANCE_MM = 1.0  # largest accepted distance of a grasp from the true top-face centre
SPEED_FACTOR = 4.0  # the simulated arm moves four times faster than real time
REPLY_TIMEOUT_S = 60.0
# 640 x 480 over 40 degrees: about 0.5 mm per pixel on the box tops at the capture pose, so a
# top face's centre (the mean of its points) is found to a few tenths of a millimetre.
INTRINSICS = Intrinsics.from_fov(640, 480, hfov_deg=40.0)
# Boxes on the table (robot base frame, m, deg): edge lengths x, y, height; position; yaw. All
# lie in the camera's view at the capture pose; the place poses (config) lie outside it.
BOXES: dict[str, tuple[tuple[float, float, float], float, float, float]] = {
    "a": ((0.08, 0.06, 0.05), -0.60, -0.20, 20.0),
    "b": ((0.06, 0.06, 0.04), -0.46, -0.20, -35.0),
    "c": ((0.10, 0.05, 0.06), -0.62, -0.07, 70.0),
    "d": ((0.07, 0.05, 0.035), -0.49, -0.06, 5.0),
    "e": ((0.05, 0.04, 0.045), -0.40, -0.13, 45.0),
}

# Box finding, in the camera frame (mm).
TABLE_BAND_MM = 3.0  # points less than this above the fitted table count as table
MIN_BOX_HEIGHT_MM = 10.0  # points this far above the table belong to a box
TOP_FACE_BAND_MM = 1.0  # a box's top face: its points within this of its highest point
MIN_BOX_PIXELS = 50  # smaller blobs are noise, not boxes

# The installed console script may not be on PATH (venv not activated): call its function.
HANDEYE_PICK = [sys.executable, "-c",
                "import sys; from handeye_pick.cli import main; sys.exit(main())"]

Cloud = NDArray[np.float32]
Array = NDArray[np.float64]  # a point (3,) or a pose (4, 4), as each name says


# --- the simulated world --------------------------------------------------------------------


@dataclass(frozen=True)
class Cell:
    """What the example reads from the cell config: where the robot is, its TCP, the hand-eye."""

    config: Path
    host: str
    tcp_offset: tuple[float, ...]  # T_flange_tcp as a UR vector (m, rad)
    eye_in_hand: bool
    hand_eye_file: Path  # T_flange_cam (eye-in-hand) or T_base_cam, Zivid format, mm
    audit_file: Path
    unsensed_output: str | None  # "tool output 0": a digital gripper without confirm_input


def read_cell(config: Path) -> Cell:
    """The controller address, TCP offset, camera mounting, hand-eye file, audit file and
    gripper of a cell config."""
    doc = yaml.safe_load(config.read_text())
    hand_eye = doc["hand_eye"]
    if hand_eye["units"] != "mm" or hand_eye.get("invert"):
        raise ValueError(f"{config}: this example needs a hand-eye file in mm, not inverted")
    gripper = doc["robot"].get("gripper")
    unsensed = (gripper is not None and gripper.get("type", "digital-output") == "digital-output"
                and "confirm_input" not in gripper)
    return Cell(
        config=config,
        host=str(doc["robot"]["host"]),
        tcp_offset=tuple(float(v) for v in doc["robot"]["tcp_offset"]),
        eye_in_hand=hand_eye["mode"] == "eye-in-hand",
        hand_eye_file=(config.parent / hand_eye["file"]).resolve(),
        audit_file=(config.parent / doc["audit"]["file"]).resolve(),
        unsensed_output=f"{gripper['bank']} output {gripper['index']}" if unsensed else None,
    )


def shown(path: Path) -> str:
    """A path for a person: relative to the current folder when it lies under it."""
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path.resolve())


def introduce(cell: Cell, what: str, log: Path) -> None:
    """The example's first lines: what runs, where the simulator's log goes and, for a gripper
    nothing senses, why every grasp will read `grasp unconfirmed`."""
    print(f"{what}, through handeye-pick run --config {shown(cell.config)}", flush=True)
    print(f"simulated UR controller on {cell.host}: its log goes to {shown(log)}", flush=True)
    if cell.unsensed_output is not None:
        print(f"the gripper ({cell.unsensed_output}) has no confirm_input in "
              f"{cell.config.name}: nothing senses the part, so every grasp reads 'grasp "
              "unconfirmed' and is carried as held (docs/grippers.md)", flush=True)


@contextmanager
def simulator(cell: Cell, log: Path, **options: Any) -> Iterator[SimulatedController]:
    """The simulated controller at the cell's address with its TCP offset (``options`` as
    SimulatedController's), its log in ``log`` (emptied first), stopped at the end; SystemExit
    with one line when it cannot start."""
    log.parent.mkdir(parents=True, exist_ok=True)
    log.write_text("")
    controller = SimulatedController(host=cell.host, tcp_offset=cell.tcp_offset, log_path=log,
                                     **options)
    try:
        controller.start()
    except OSError:
        raise SystemExit(f"error: the simulated controller cannot listen on {cell.host}: is "
                         "another simulator or example still running there? stop it, then run "
                         f"this again ({shown(log)} says why)") from None
    except RuntimeError as exc:
        raise SystemExit(f"error: {exc}") from None
    try:
        yield controller
    finally:
        controller.stop()


def build_scene() -> Scene:
    """The table (at the robot base's height) with the boxes of BOXES on it."""
    scene = Scene(table_height_m=0.0)
    for name, (size_m, x_m, y_m, yaw_deg) in BOXES.items():
        scene.add_box(name, size_m, scene.on_table(x_m, y_m, np.radians(yaw_deg)))
    return scene


def build_camera(scene: Scene, cell: Cell) -> SimulatedCamera:
    """A camera mounted exactly where the hand-eye file says (mm -> m): on the wrist at
    T_flange_cam, or in the cell at T_base_cam."""
    T_mount_cam = read_zivid_matrix(cell.hand_eye_file)
    T_mount_cam[:3, 3] /= 1000.0
    if cell.eye_in_hand:
        return SimulatedCamera(scene, INTRINSICS, T_flange_cam=T_mount_cam)
    return SimulatedCamera(scene, INTRINSICS, T_base_cam=T_mount_cam)


def place_box(scene: Scene, name: str, T_base_tcp_grasp: Array, T_base_tcp_place: Array) -> None:
    """Move box ``name`` as the gripper carried it from the grasp to the place pose, then let it
    drop onto the table (both tool poses point straight down, so the box stays upright)."""
    T_tcp_box = np.linalg.inv(T_base_tcp_grasp) @ scene.boxes[name].T_base_box
    T_base_box = T_base_tcp_place @ T_tcp_box
    T_base_box[2, 3] = scene.table_height_m
    scene.move_box(name, T_base_box)


# --- the vision: boxes in an organized cloud ----------------------------------------------------


def _plane(points: NDArray[np.float64]) -> tuple[Array, Array]:
    """Least-squares plane through points (N, 3): (centroid, unit normal towards the camera)."""
    centroid = points.mean(axis=0)
    _, vectors = np.linalg.eigh(np.cov((points - centroid).T))
    normal = vectors[:, 0]  # the direction of least spread
    if normal @ centroid > 0.0:  # the camera is at the origin: point the normal at it
        normal = -normal
    return centroid, normal


def height_above_table(cloud_mm: Cloud) -> NDArray[np.float64]:
    """Each pixel's height above the table plane (mm, NaN without data), shape (H, W).

    The table is fitted to every 4th row and column of the cloud, then again to those points not
    clearly above the last fit, until the set stops changing: the boxes (above the table) drop
    out, the table stays.
    """
    sample = cloud_mm[::4, ::4].reshape(-1, 3).astype(np.float64)
    sample = sample[np.isfinite(sample).all(axis=1)]
    table = np.ones(len(sample), dtype=bool)
    for _ in range(10):
        centroid, normal = _plane(sample[table])
        now = (sample - centroid) @ normal < TABLE_BAND_MM
        if np.array_equal(now, table):
            break
        table = now
    height: NDArray[np.float64] = (cloud_mm.astype(np.float64) - centroid) @ normal
    return height  # NaN where the cloud has none


def find_boxes(cloud_mm: Cloud) -> list[Array]:
    """The centres of the boxes' top faces in the camera frame (mm), tallest box first.

    Pixels clearly above the table form one connected blob per box (boxes must not touch in
    the image); a blob on the image's border is a box only partly seen and is left out. A box's
    top face is its blob's pixels within TOP_FACE_BAND_MM of its highest point, and its centre
    is their mean (exact for a face parallel to the image plane).
    """
    height = height_above_table(cloud_mm)
    above = np.nan_to_num(height, nan=0.0) > MIN_BOX_HEIGHT_MM
    labels, count = ndimage.label(above)
    border = set(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]).tolist())
    found: list[tuple[float, Array]] = []
    for label in range(1, count + 1):
        blob = labels == label
        if label in border or blob.sum() < MIN_BOX_PIXELS:
            continue
        top_height = float(height[blob].max())
        top = blob & (height > top_height - TOP_FACE_BAND_MM)
        found.append((top_height, cloud_mm[top].astype(np.float64).mean(axis=0)))
    found.sort(key=lambda item: -item[0])
    return [centre for _, centre in found]


# --- the pipe to `handeye-pick run` -------------------------------------------------------------


class RunSession:
    """`handeye-pick run --config CONFIG` as a child process: one JSON request per line on its
    stdin, one JSON reply per line on its stdout; its progress goes to our stderr."""

    def __init__(self, config: Path):
        self._process = subprocess.Popen(
            [*HANDEYE_PICK, "run", "--config", str(config)],
            cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1,
        )
        self._lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, args=(self._process.stdout,), daemon=True).start()
        self._next_id = 0

    def _read(self, stream: IO[str]) -> None:
        for line in stream:
            self._lines.put(line)
        self._lines.put(None)  # end of output: the process is gone

    def send(self, op: str, **fields: Any) -> str:
        """Send one request without waiting for its reply; returns its id."""
        self._next_id += 1
        request_id = str(self._next_id)
        stdin = self._process.stdin
        if stdin is None:
            raise RuntimeError("handeye-pick run has no input pipe")
        stdin.write(json.dumps({"id": request_id, "op": op, **fields}) + "\n")
        stdin.flush()
        return request_id

    def line(self) -> dict[str, Any]:
        """The next line run writes: a reply, or an event of a request that asked for them."""
        try:
            line = self._lines.get(timeout=REPLY_TIMEOUT_S)
        except queue.Empty:
            raise RuntimeError(f"nothing from run within {REPLY_TIMEOUT_S:.0f} s") from None
        if line is None:
            raise RuntimeError(f"handeye-pick run ended (exit {self._process.wait()})")
        reply: dict[str, Any] = json.loads(line)
        return reply

    def reply(self, request_id: str) -> dict[str, Any]:
        """The reply to ``request_id``, skipping its event lines; RuntimeError if another
        request's reply comes first (run answers motion requests in the order they came)."""
        while True:
            reply = self.line()
            if "event" in reply and reply.get("id") == request_id:
                continue
            if reply.get("id") != request_id:
                raise RuntimeError(f"{reply} came where the reply to {request_id} was due")
            return reply

    def request(self, op: str, **fields: Any) -> dict[str, Any]:
        """Send one request and return its reply; RuntimeError if none comes."""
        return self.reply(self.send(op, **fields))

    def close(self) -> int:
        """Send quit, close the pipe and return run's exit status."""
        stdin = self._process.stdin
        if stdin is not None and self._process.poll() is None:
            try:
                stdin.write(json.dumps({"id": "quit", "op": "quit"}) + "\n")
                stdin.close()
            except BrokenPipeError:
                pass  # it has already gone; its exit status says how
        try:
            return self._process.wait(timeout=30.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            return self._process.wait()


class CtrlC(Exception):
    """A Ctrl-C stopped the loop; the message says how `run` ended."""


@contextmanager
def run_session(config: Path) -> Iterator[RunSession]:
    """`handeye-pick run --config CONFIG` for the body, closed at its end. A Ctrl-C in the body
    reached `run` too: wait (a second Ctrl-C ignored) until it has stopped the arm and exited,
    then raise CtrlC saying how it ended."""
    run = RunSession(config)
    try:
        yield run
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        raise CtrlC(run_ending(run.close())) from None
    finally:
        run.close()


def run_ending(status: int) -> str:
    """How `run` ended after a Ctrl-C, from its exit status (negative: killed by that signal)."""
    if status == EXIT_INTERRUPTED:
        return "handeye-pick run stopped the arm and exited 130"
    if status < 0:
        return f"handeye-pick run was ended by {signal.Signals(-status).name}"
    return f"handeye-pick run exited {status}"


def exit_status(loop: Callable[[], int]) -> int:
    """``loop()``'s exit status; after a Ctrl-C, one line and 130 (the simulated controller is
    stopped by then: the loops run inside ``simulator``)."""
    try:
        return loop()
    except CtrlC as stop:
        ended = f": {stop}"
    except KeyboardInterrupt:  # before `run` started, or after it ended
        ended = ""
    print(f"interrupted (Ctrl-C){ended}; the simulated controller is stopped", file=sys.stderr,
          flush=True)
    return EXIT_INTERRUPTED


# --- one cycle ----------------------------------------------------------------------------------


def nearest_box(scene: Scene, point_m: Array) -> tuple[str, float]:
    """The box whose top-face centre is nearest ``point_m`` (base, m), and the distance (mm)."""
    distances = {name: float(np.linalg.norm(box.top_centre_m() - point_m)) * 1000.0
                 for name, box in scene.boxes.items()}
    name = min(distances, key=distances.__getitem__)
    return name, distances[name]


@dataclass
class Timing:
    """Where one cycle's wall time went (s): all of it, the arm moving, detection hidden."""

    cycle_s: float
    moving_s: float  # controller time the arm moved, from the simulator's motion record
    hidden_s: float  # detection time that ran while the arm moved

    def line(self) -> str:
        return (f"{self.cycle_s:.2f} s, arm moving {self.moving_s / self.cycle_s:.0%}, "
                f"vision hidden {self.hidden_s * 1000.0:.0f} ms")


def check_pick(scene: Scene, pick: dict[str, Any], name: str | None = None) -> tuple[
    list[str], str, float, float
]:
    """A placed pick's grasp against the true box centres: (problems, the box picked, planned
    and reached grasp's distance from its top centre in mm)."""
    grasp = pose_to_matrix(pick["targets"]["grasp"])
    reached = pose_to_matrix(pick["reached"]["grasp"])
    nearest, planned_mm = nearest_box(scene, grasp[:3, 3])
    name = name or nearest
    planned_mm = float(np.linalg.norm(scene.top_centre_m(name) - grasp[:3, 3])) * 1000.0
    reached_mm = float(np.linalg.norm(scene.top_centre_m(name) - reached[:3, 3])) * 1000.0
    problems = [f"{what} grasp {error_mm:.2f} mm from box {name}'s top centre"
                for what, error_mm in (("planned", planned_mm), ("reached", reached_mm))
                if error_mm > TOLERANCE_MM]
    return problems, name, planned_mm, reached_mm


def run_cycle(number: int, run: RunSession, controller: SimulatedController, scene: Scene,
              camera: SimulatedCamera) -> list[str]:
    """One eye-in-hand capture/pick/place cycle, vision under motion: the arm heads for the
    hover pose as soon as the image is taken and the boxes are found meanwhile; the pick waits
    in run's queue and plans from the pose latched at the image. Returns what went wrong."""
    started, first_motion = time.monotonic(), len(controller.motions)
    capture = run.request("capture", pose="capture")
    if not capture.get("ok"):
        return [f"capture failed: {capture.get('error')}"]
    cloud = camera.capture_from(controller)  # the acquisition: the arm stands still
    latched = pose_to_matrix(capture["flange_pose_ur"])
    now = pose_to_matrix(controller.snapshot().flange_pose)
    problems = []
    if float(np.abs(latched - now).max()) > 1e-6:
        problems.append("the latched flange pose is not where the arm stood at the image")
    hover = run.send("move", pose="hover")
    detect_start = time.monotonic()
    boxes = find_boxes(cloud)
    detect_end = time.monotonic()
    if not boxes:
        run.reply(hover)
        return [*problems, "no box found in the cloud"]
    candidates = [{"position_mm": [round(float(v), 4) for v in centre]} for centre in boxes]
    pick_id = run.send("pick", capture_id=capture["capture_id"], candidates=candidates)
    moved = run.reply(hover)
    hover_end = time.monotonic()
    pick = run.reply(pick_id)
    if not moved.get("ok"):
        return [*problems, f"move to hover ended {moved.get('status')}: {moved.get('error')}"]
    if not pick.get("ok") or pick.get("status") != "placed":
        return [*problems, f"pick ended {pick.get('status')}: {pick.get('error')}"]
    timing = Timing(time.monotonic() - started,
                    sum(m["moving_s"] for m in controller.motions[first_motion:]),
                    max(0.0, min(detect_end, hover_end) - detect_start))
    found, name, planned_mm, reached_mm = check_pick(scene, pick)
    place_box(scene, name, pose_to_matrix(pick["reached"]["grasp"]),
              pose_to_matrix(pick["place"]["pose"]))
    print(f"cycle {number}: boxes seen {len(boxes)}, picked box {name} (candidate "
          f"{pick['candidate']}), grasp {planned_mm:.2f} mm planned / {reached_mm:.2f} mm reached "
          f"from its top centre, placed at {pick['place']['index']}, {timing.line()}",
          flush=True)
    return problems + found


def run_eye_to_hand(run: RunSession, controller: SimulatedController, scene: Scene,
                    camera: SimulatedCamera) -> tuple[int, list[str]]:
    """CYCLES picks with the camera fixed in the cell, vision under motion: the first image is
    taken with the arm aside; after that, each image is taken on the pick's ``view-clear`` event
    (the arm has left the camera's view) and the next pick is queued while the arm places.
    One candidate per pick, the tallest box, so the client knows which box the arm carries.
    Returns the cycles done and what went wrong."""
    first = run.request("capture")  # to the capture pose, out of the camera's view
    if not first.get("ok"):
        return 0, [f"capture failed: {first.get('error')}"]
    T_base_cam = camera.T_base_cam()

    def next_pick() -> tuple[str, str] | None:
        boxes = find_boxes(camera.capture())
        if not boxes:
            return None
        point = [round(float(v), 4) for v in boxes[0]]
        name, _ = nearest_box(scene, (T_base_cam @ np.append(np.array(point) / 1000.0, 1.0))[:3])
        return run.send("pick", candidates=[{"position_mm": point}], events=True), name

    pending = next_pick()
    for number in range(1, CYCLES + 1):
        if pending is None:
            return number, ["no box found in the cloud"]
        pick_id, name = pending
        started, first_motion = time.monotonic(), len(controller.motions)
        while True:  # the pick runs: wait until the arm has left the camera's view
            line = run.line()
            if "ok" in line:
                return number, [f"pick ended {line.get('status')} before the arm left the view: "
                                f"{line.get('error')}"]
            if line.get("event") == "view-clear":
                break
        T_base_box = scene.boxes[name].T_base_box.copy()
        scene.remove_box(name)  # in the gripper, out of the camera's view
        detect_start = time.monotonic()
        pending = next_pick() if number < CYCLES else None
        detect_end = time.monotonic()
        pick = run.reply(pick_id)
        if not pick.get("ok") or pick.get("status") != "placed":
            return number, [f"pick ended {pick.get('status')}: {pick.get('error')}"]
        timing = Timing(time.monotonic() - started,
                        sum(m["moving_s"] for m in controller.motions[first_motion:]),
                        detect_end - detect_start)  # all of it ran while the arm placed
        scene.add_box(name, scene_size(name), T_base_box)
        found, name, planned_mm, reached_mm = check_pick(scene, pick, name)
        place_box(scene, name, pose_to_matrix(pick["reached"]["grasp"]),
                  pose_to_matrix(pick["place"]["pose"]))
        print(f"cycle {number}: picked box {name}, grasp {planned_mm:.2f} mm planned / "
              f"{reached_mm:.2f} mm reached from its top centre, placed at "
              f"{pick['place']['index']}, {timing.line()}", flush=True)
        if found:
            return number, found
    return CYCLES, []


def scene_size(name: str) -> tuple[float, float, float]:
    return BOXES[name][0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=None,
                        help="cell config (config/loop.yaml, or loop-eye-to-hand.yaml)")
    parser.add_argument("--eye-to-hand", action="store_true",
                        help="the camera fixed above the table (config/loop-eye-to-hand.yaml)")
    args = parser.parse_args(argv)
    config = args.config or (CONFIG_EYE_TO_HAND if args.eye_to_hand else CONFIG)
    cell = read_cell(config.resolve())
    scene = build_scene()
    camera = build_camera(scene, cell)
    mount = "a wrist camera" if cell.eye_in_hand else "a camera fixed above the table"
    introduce(cell, f"vision loop: {CYCLES} capture, pick and place cycles with {mount}",
              SIMULATOR_LOG)
    return exit_status(lambda: vision_loop(cell, scene, camera))


def vision_loop(cell: Cell, scene: Scene, camera: SimulatedCamera) -> int:
    """The simulated controller, `run` and the cycles; the example's exit status."""
    started = time.monotonic()
    problems: list[str] = []
    done = 0
    with simulator(cell, SIMULATOR_LOG, speed_factor=SPEED_FACTOR) as controller:
        with run_session(cell.config) as run:
            try:
                if not cell.eye_in_hand:
                    done, found = run_eye_to_hand(run, controller, scene, camera)
                    problems += [f"cycle {done}: {p}" for p in found]
                while cell.eye_in_hand and done < CYCLES and not problems:
                    done += 1
                    problems += [f"cycle {done}: {p}"
                                 for p in run_cycle(done, run, controller, scene, camera)]
                if not problems:
                    home = run.request("move", pose="home")
                    if not home.get("ok"):
                        problems.append(f"move home ended {home.get('status')}: "
                                        f"{home.get('error')}")
            except RuntimeError as exc:  # no reply, or not the one asked for
                problems.append(str(exc))
        status = run.close()
        moving_s = sum(motion["moving_s"] for motion in controller.motions)
    if status != 0:
        problems.append(f"handeye-pick run exited with status {status}")
    for problem in problems:
        print(f"FAILED {problem}", file=sys.stderr)
    verdict = "every check passed" if not problems else f"{len(problems)} checks FAILED"
    total_s = time.monotonic() - started
    print(f"{done} of {CYCLES} cycles, {verdict} (grasps within {TOLERANCE_MM} mm of the true "
          f"top centres), {total_s:.1f} s in all, of which the arm moved {moving_s:.1f} s "
          f"({moving_s / total_s:.0%}; motion runs {SPEED_FACTOR:g} x real speed)")
    print(f"audit records: {shown(cell.audit_file)}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
