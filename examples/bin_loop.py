"""A vision client emptying a deep bin through `handeye-pick run`, every move of the tool and the
arm checked against the bin and a fixture beside the place.

Starts the simulated UR5e controller (with --trace-tcp: the motion record keeps the TCP pose and
the joints of every cycle), builds a simulated scene with the bin of config/bin.yaml (190 mm
deep: the wrist goes below its walls' top) and six 50 mm cubes in it (against walls, one in a
corner, one turned, ...), watched by the wrist camera of config/loop/hand_eye.yaml, starts

    handeye-pick run --config config/bin.yaml

and, until the bin is empty or every cube left is refused: captures at the pose `capture`,
finds the cubes' top faces in the cloud (points inside the bin's inner footprint and clearly
above its floor), sends every cube as a candidate with its orientation, size and symmetry (a
cube looks the same turned 90 degrees about its vertical), and takes the one picked out of the
scene. Against a wall the fingers fit along it, but the last wrist would come into the wall's
top: the tool-only check would pass those grasps, the arm's check refuses them (or takes a
tilted one). Then mocks/contact_check.py replays the driven TCP poses with the tool's shape, the
cube in the fingers while the gripper's output held them closed (where the simulated scene had
it), and the driven joints with the arm's links (the simulator's own kinematics, the package's
link sizes as data) against the bin and the fixture: zero contacts. Prints one line per cycle, the
refusals, how many grasps the tool-only check would have passed that the arm's refused, the
contact count and a summary; exits 0 when every cube was picked or refused with its reason and
nothing touched the bin or the fixture, 1 otherwise, 130 after a Ctrl-C (`run` stops the arm;
the simulated robot does not get it). The simulated controller's log goes to
out/bin_loop-simulator.log under the current folder.

Run it from anywhere after `pip install -e .`:  python examples/bin_loop.py
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ is not installed with the package: import it from the clone

from vision_loop import (  # noqa: E402  (this folder is on the path when the script runs)
    INTRINSICS,
    Cell,
    Cloud,
    exit_status,
    introduce,
    read_cell,
    run_session,
    shown,
    simulator,
)

from handeye_pick.config.load import load_config  # noqa: E402
from mocks.camera import Scene, SimulatedCamera, read_zivid_matrix  # noqa: E402
from mocks.contact_check import count_contacts  # noqa: E402
from mocks.ur_controller.kinematics import pose_to_matrix  # noqa: E402

CONFIG = ROOT / "config" / "bin.yaml"
SIMULATOR_LOG = Path("out") / "bin_loop-simulator.log"  # under the current folder
SPEED_FACTOR = 4.0
MAX_CYCLES = 10
CUBE_M = 0.05
# Cubes in the bin: (x, y) of the centre from the bin's centre (m) and the turn about z (deg).
# Against a wall with 8 mm to spare the fingers fit only along it; in a corner they fit nowhere.
CUBES: dict[str, tuple[float, float, float]] = {
    "middle": (0.0, 0.0, 20.0),
    "east": (0.130 - 0.025 - 0.008, -0.030, 0.0),
    "north": (-0.060, 0.090 - 0.025 - 0.008, 0.0),
    "west": (-0.130 + 0.025 + 0.008, 0.020, 0.0),
    "south": (0.040, -0.090 + 0.025 + 0.008, -15.0),
    "corner": (0.130 - 0.025 - 0.008, 0.090 - 0.025 - 0.008, 0.0),
}
# Cube finding
WALL_MARGIN_M = 0.003  # points this close to a wall's inside are the wall's
MIN_HEIGHT_M = 0.010  # points this far above the bin floor belong to a cube
TOP_FACE_BAND_M = 0.001
MIN_PIXELS = 50


class Bin:
    """The bin as config/bin.yaml gives it: its inner floor centre (base, m) and inner size."""

    def __init__(self, config: Path) -> None:
        entry = yaml.safe_load(config.read_text())["scene"]["bins"][0]
        self.name = str(entry["name"])
        self.centre_m = np.array(entry["pose"][:3], dtype=float)
        self.inner_m = np.array(entry["inner_mm"], dtype=float) / 1000.0
        self.wall_m = float(entry["wall_mm"]) / 1000.0
        self.floor_m = float(entry["floor_mm"]) / 1000.0


def build_scene(bin_: Bin) -> Scene:
    scene = Scene(table_height_m=0.0)
    scene.add_bin(bin_.name, tuple(bin_.centre_m), tuple(bin_.inner_m), bin_.wall_m,
                  bin_.floor_m)
    for name, (x, y, yaw_deg) in CUBES.items():
        T = scene.on_table(bin_.centre_m[0] + x, bin_.centre_m[1] + y, math.radians(yaw_deg))
        T[2, 3] = bin_.centre_m[2]
        scene.add_box(name, (CUBE_M, CUBE_M, CUBE_M), T)
    return scene


def find_cubes(cloud_mm: Cloud, T_base_cam: np.ndarray, bin_: Bin) -> list[dict[str, object]]:
    """The cubes' top faces as candidate detections (camera frame, mm): centre, the turn about
    the viewing axis from the face's corners, the size and the symmetry."""
    points = cloud_mm.astype(np.float64) / 1000.0
    base = points @ T_base_cam[:3, :3].T + T_base_cam[:3, 3]
    local = base - bin_.centre_m
    half = bin_.inner_m[:2] / 2.0 - WALL_MARGIN_M
    inside = (np.abs(local[..., 0]) < half[0]) & (np.abs(local[..., 1]) < half[1])
    height = np.where(inside, local[..., 2], np.nan)
    labels, count = ndimage.label(np.nan_to_num(height, nan=0.0) > MIN_HEIGHT_M)
    found = []
    for label in range(1, count + 1):
        blob = labels == label
        if blob.sum() < MIN_PIXELS:
            continue
        top = blob & (height > np.nanmax(height[blob]) - TOP_FACE_BAND_M)
        face = cloud_mm[top].astype(np.float64)
        centre = face.mean(axis=0)
        offsets = face[:, :2] - centre[:2]
        corner = offsets[np.argmax(np.einsum("ij,ij->i", offsets, offsets))]
        # A square's corner lies 45 deg from its edges; a cube's turn is known modulo 90 deg.
        yaw = math.atan2(corner[1], corner[0]) % (math.pi / 2.0) - math.pi / 4.0
        found.append({
            "position_mm": [round(float(v), 3) for v in centre],
            "orientation": {"rotvec_rad": [0.0, 0.0, round(yaw, 6)]},
            "size_mm": [CUBE_M * 1000.0] * 3,
            "symmetry": {"axis": "z", "order": 4},
        })
    return found


def link_solids(config: Path) -> list[dict[str, object]]:
    """The arm's link solids of the config's ``robot.model`` as the package models them, as
    data for the independent replay (which places them with the simulator's kinematics)."""
    model = load_config(config).robot.model
    if model is None:
        return []
    return [
        {"name": link.name, "kind": link.kind, "frame": link.frame, "radius_m": link.radius_m,
         "length_m": link.length_m, "T_frame_solid": link.T_frame_solid.tolist()}
        for link in model.links
    ]


def cube_parts(bin_: Bin) -> list[dict[str, object]]:
    """The cubes where they lie before the loop, as data for the independent replay (which
    puts the one the fingers close on in the gripper)."""
    return [
        {"name": name, "size_m": list(box.size_m), "T_base_part": box.T_base_box.tolist()}
        for name, box in build_scene(bin_).boxes.items() if name in CUBES
    ]


def arm_refusals(reasons: list[str]) -> int:
    """How many of a pick's refused grasps only the arm's check refused: the arm is swept once
    the tool's sweep passed, so each ``arm collision`` is a grasp the tool-only check passed."""
    return sum(" arm collision: " in f" {reason}" for reason in reasons)


def nearest_cube(scene: Scene, point_m: np.ndarray) -> str:
    cubes = {name: box for name, box in scene.boxes.items() if name in CUBES}
    return min(cubes, key=lambda n: float(np.linalg.norm(cubes[n].top_centre_m() - point_m)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=CONFIG, help="cell config (bin.yaml)")
    parser.add_argument("--speed-factor", type=float, default=SPEED_FACTOR,
                        help="the simulated arm moves this many times faster than real time")
    args = parser.parse_args(argv)
    config = args.config.resolve()
    cell, bin_ = read_cell(config), Bin(config)
    introduce(cell, f"bin loop: {len(CUBES)} cubes in bin '{bin_.name}', every move checked "
                    "against it", SIMULATOR_LOG)
    return exit_status(lambda: bin_loop(cell, bin_, args.speed_factor))


def bin_loop(cell: Cell, bin_: Bin, speed_factor: float) -> int:
    """The simulated controller, `run`, the cycles and the contact check; the exit status."""
    scene = build_scene(bin_)
    T_flange_cam = read_zivid_matrix(cell.hand_eye_file)
    T_flange_cam[:3, 3] /= 1000.0
    camera = SimulatedCamera(scene, INTRINSICS, T_flange_cam=T_flange_cam)
    started = time.monotonic()
    problems: list[str] = []
    refused: list[str] = []
    picked: list[str] = []
    arm_refused = 0
    with simulator(cell, SIMULATOR_LOG, speed_factor=speed_factor,
                   trace_tcp=True) as controller:
        with run_session(cell.config) as run:
            try:
                for cycle in range(1, MAX_CYCLES + 1):
                    capture = run.request("capture", pose="capture")
                    if not capture.get("ok"):
                        problems.append(f"capture failed: {capture.get('error')}")
                        break
                    T_base_cam = pose_to_matrix(capture["flange_pose_ur"]) @ T_flange_cam
                    candidates = find_cubes(camera.capture_from(controller), T_base_cam, bin_)
                    if not candidates:
                        break  # the bin is empty
                    pick = run.request("pick", capture_id=capture["capture_id"],
                                       candidates=candidates)
                    arm_refused += arm_refusals(
                        [reason for r in pick.get("refused", []) for reason in r["reasons"]]
                        + [reason for other in pick.get("alternative", {}).get("others", [])
                           for reason in other["reasons"]])
                    if pick.get("status") in ("refused", "no-candidate"):  # nothing moved
                        refused = [f"candidate {r['candidate']}: {'; '.join(r['reasons'])}"
                                   for r in pick.get("refused", [])] or [str(pick.get("error"))]
                        break
                    if pick.get("status") != "placed":
                        problems.append(f"pick ended {pick.get('status')}: {pick.get('error')}")
                        break
                    name = nearest_cube(scene, pose_to_matrix(pick["targets"]["grasp"])[:3, 3])
                    scene.remove_box(name)
                    picked.append(name)
                    turn = pick.get("alternative", {})
                    print(f"cycle {cycle}: {len(candidates)} cubes seen, picked '{name}' "
                          f"(candidate {pick['candidate']}, turned {turn.get('yaw_deg')} deg, "
                          f"tilted {turn.get('tilt_deg')} deg), {pick['cycle_s']:.1f} s",
                          flush=True)
            except RuntimeError as exc:  # no reply, or not the one asked for
                problems.append(str(exc))
        status = run.close()
        contacts = count_contacts(cell.config, controller.motions, link_solids(cell.config),
                                  cube_parts(bin_))
    if status != 0:
        problems.append(f"handeye-pick run exited with status {status}")
    left = sorted(set(CUBES) - set(picked))
    if bool(refused) != bool(left) and not problems:
        problems.append(f"cubes left {left} but the refusals say {refused}")
    for reason in refused:
        print(f"refused {reason}")
    print(f"{arm_refused} grasps the tool-only check would have passed were refused by the "
          "arm's check (a link in the way)")
    print(f"contact check: {contacts.line()}")
    if contacts.touched or contacts.samples == 0 or contacts.carried == 0 < len(picked):
        problems.append("the tool, the arm or the part touched the scene" if contacts.touched
                        else "nothing replayed" if contacts.samples == 0
                        else "no cube replayed in the gripper")
    for problem in problems:
        print(f"FAILED {problem}", file=sys.stderr)
    verdict = "every check passed" if not problems else f"{len(problems)} checks FAILED"
    print(f"{len(picked)} of {len(CUBES)} cubes picked ({', '.join(picked)}), left: "
          f"{', '.join(left) or 'none'}; {verdict}; {time.monotonic() - started:.1f} s in all")
    print(f"audit records: {shown(cell.audit_file)}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
