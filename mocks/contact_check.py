"""An independent check of what the simulated arm drove: replays the simulated controller's motion
record (recorded with ``--trace-tcp``: the target TCP pose ``tcp_trace`` and joints ``q_trace`` of
every cycle) and counts the cycles at which the tool's solids or the arm's links touch a bin or
a box of the scene.

It reads the cell config with plain YAML and builds the bins (a floor and four walls), the
scene's boxes and the tool's boxes and cylinders itself with python-fcl, and places the arm's
links with the simulated controller's own forward kinematics (its DH table of ``robot.model``);
it never imports ``handeye_pick``, so it shares no geometry with the check it judges. The link
solids' sizes come as data (``--links``, JSON: what the package's model says each link is, as a
capsule or cylinder in a DH frame), so a wrong FK or a wrong link placement in the package shows
here. Config keys: ``robot.tcp_offset`` (T_flange_tcp, m, rad), ``robot.model``, ``tool.shape``
(solids in the flange frame, sizes mm, poses m, rad), ``scene.bins`` (``pose`` of the inner
floor centre, ``inner_mm``, ``wall_mm``, ``floor_mm``) and ``scene.boxes`` (``pose`` of the
centre, ``size_mm``).

A sample touches when FCL's distance between a solid and a box is 0 or less; samples are one
control cycle apart (2 ms, a few mm of travel at the example's speeds), so a touch shallower
than that spacing between two samples can slip through.

The held part (``--parts``, JSON: each part's ``name``, ``size_m`` and ``T_base_part``, the
centre of its bottom face with z up, where it lies before the cell picks it) rides with the
TCP from the motion the gripper's digital output (``robot.gripper``: ``bank``, ``index``,
``close_value``; the motion record's ``digital_out``) starts closed until one starts open: the
part nearest the TCP where the fingers closed, at the pose it had in the TCP frame there. It
lies on a surface when it is grasped and set down, so it touches only when it comes more than
``PART_PRESS_M`` into a bin or a box.

Usage: ``python -m mocks.contact_check --config cell.yaml --motions motions.jsonl
[--links links.json] [--parts parts.json]`` (exit 0: no contact, 1: contacts, 2: bad input).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import fcl
import numpy as np
import yaml

from mocks.ur_controller.kinematics import MODELS, frames, pose_to_matrix

PART_PRESS_M = 0.002
"""How far the held part may press into the surface it lies on: the detection's error."""
GRAB_M = 0.1
"""A part whose centre is farther than this from the TCP where the fingers close is not the
one grasped (none is)."""
OUTPUT_BIT = {"standard": 0, "configurable": 8, "tool": 16}
"""Where each bank's outputs sit in the motion record's ``digital_out``."""


@dataclass(frozen=True)
class ContactReport:
    samples: int  # cycles replayed
    contacts: int  # of them, those at which the tool touched a bin or a box
    link_contacts: int  # those at which a link of the arm did
    part_contacts: int  # those at which the held part came more than PART_PRESS_M into one
    carried: int  # cycles replayed with a part in the gripper
    closest_mm: float  # the smallest distance seen between a solid and a bin or a box
    closest: str  # which solid, which box, which motion

    def line(self) -> str:
        return (f"{self.samples} driven cycles replayed, {self.contacts} touch a bin; "
                f"{self.link_contacts} with an arm's link, {self.part_contacts} with the held "
                f"part ({self.carried} carried); closest {self.closest_mm:.1f} mm "
                f"({self.closest})")

    @property
    def touched(self) -> bool:
        """Whether any replayed solid touched the scene."""
        return bool(self.contacts or self.link_contacts or self.part_contacts)


def _box(size_m: Iterable[float], T: np.ndarray) -> fcl.CollisionObject:
    return fcl.CollisionObject(fcl.Box(*size_m), fcl.Transform(T[:3, :3], T[:3, 3]))


def bin_boxes(entry: Mapping[str, Any]) -> dict[str, fcl.CollisionObject]:
    """A bin's floor and walls by name, from its config entry (the floor under the walls, east
    and west across the whole outer width)."""
    T_base_bin = pose_to_matrix(entry["pose"])
    x, y, z = (float(v) / 1000.0 for v in entry["inner_mm"])
    wall, floor = float(entry["wall_mm"]) / 1000.0, float(entry["floor_mm"]) / 1000.0
    boxes = {
        "floor": ((x + 2 * wall, y + 2 * wall, floor), (0.0, 0.0, -floor / 2)),
        "wall east": ((wall, y + 2 * wall, z), ((x + wall) / 2, 0.0, z / 2)),
        "wall west": ((wall, y + 2 * wall, z), (-(x + wall) / 2, 0.0, z / 2)),
        "wall north": ((x, wall, z), (0.0, (y + wall) / 2, z / 2)),
        "wall south": ((x, wall, z), (0.0, -(y + wall) / 2, z / 2)),
    }
    out = {}
    for name, (size, centre) in boxes.items():
        T = np.eye(4)
        T[:3, 3] = centre
        out[f"bin {entry['name']} {name}"] = _box(size, T_base_bin @ T)
    return out


def tool_solids(shape: Iterable[Mapping[str, Any]]) -> list[tuple[str, Any, np.ndarray]]:
    """(name, fcl geometry, T_flange_solid) of each solid of ``tool.shape``."""
    solids = []
    for solid in shape:
        if "box" in solid:
            spec = solid["box"]
            geometry: Any = fcl.Box(*(float(v) / 1000.0 for v in spec["size_mm"]))
        else:
            spec = solid["cylinder"]
            geometry = fcl.Cylinder(float(spec["radius_mm"]) / 1000.0,
                                    float(spec["length_mm"]) / 1000.0)
        solids.append((str(solid["name"]), geometry, pose_to_matrix(spec["pose"])))
    return solids


def scene_boxes(scene: Mapping[str, Any]) -> dict[str, fcl.CollisionObject]:
    """The bins' floors and walls and the scene's boxes by name."""
    boxes: dict[str, fcl.CollisionObject] = {}
    for entry in scene.get("bins", []):
        boxes.update(bin_boxes(entry))
    for entry in scene.get("boxes", []):
        size = [float(v) / 1000.0 for v in entry["size_mm"]]
        boxes[f"box {entry['name']}"] = _box(size, pose_to_matrix(entry["pose"]))
    return boxes


def link_solids(links: Iterable[Mapping[str, Any]]) -> list[tuple[str, Any, int, np.ndarray]]:
    """(name, fcl geometry, DH frame, T_frame_solid) of each link solid of ``--links``."""
    solids = []
    for link in links:
        radius, length = float(link["radius_m"]), float(link["length_m"])
        geometry = (fcl.Capsule(radius, length) if link["kind"] == "capsule"
                    else fcl.Cylinder(radius, length))
        T = np.array(link["T_frame_solid"], dtype=np.float64)
        solids.append((str(link["name"]), geometry, int(link["frame"]), T))
    return solids


def gripper_bit(robot: Mapping[str, Any]) -> tuple[int, bool] | None:
    """The bit of ``digital_out`` that drives a digital gripper (``robot.gripper``) and the
    value that closes it; None without one (the part is not replayed then)."""
    gripper = robot.get("gripper")
    if not isinstance(gripper, Mapping) or "bank" not in gripper:
        return None
    return OUTPUT_BIT[str(gripper["bank"])] + int(gripper["index"]), bool(gripper["close_value"])


def part_boxes(parts: Iterable[Mapping[str, Any]]) -> dict[str, tuple[Any, np.ndarray]]:
    """Each part's fcl box and the pose of its centre in the base frame, by name."""
    boxes = {}
    for part in parts:
        size = [float(v) for v in part["size_m"]]
        centre = np.eye(4)
        centre[2, 3] = size[2] / 2.0
        T_base_part = np.array(part["T_base_part"], dtype=np.float64) @ centre
        boxes[str(part["name"])] = (fcl.Box(*size), T_base_part)
    return boxes


def _grab(lying: dict[str, tuple[Any, np.ndarray]],
          T_base_tcp: np.ndarray) -> tuple[fcl.CollisionObject, np.ndarray] | None:
    """The part the fingers closed on at ``T_base_tcp`` (taken from ``lying``): its solid and
    the pose of its centre in the TCP frame; None when no part lies within ``GRAB_M``."""
    if not lying:
        return None
    name = min(lying, key=lambda n: float(np.linalg.norm(lying[n][1][:3, 3] - T_base_tcp[:3, 3])))
    box, T_base_part = lying[name]
    if np.linalg.norm(T_base_part[:3, 3] - T_base_tcp[:3, 3]) > GRAB_M:
        return None
    del lying[name]
    return fcl.CollisionObject(box), np.linalg.inv(T_base_tcp) @ T_base_part


def count_contacts(config_path: Path, motions: Iterable[Mapping[str, Any]],
                   links: Iterable[Mapping[str, Any]] = (),
                   parts: Iterable[Mapping[str, Any]] = ()) -> ContactReport:
    """Replay every ``tcp_trace`` pose of ``motions`` with the tool (and the held part, one of
    ``parts``, while the gripper is closed on it), and with ``links`` every ``q_trace`` joint
    vector with the arm's links, against the bins and boxes of the config."""
    doc = yaml.safe_load(Path(config_path).read_text())
    T_tcp_flange = np.linalg.inv(pose_to_matrix(doc["robot"]["tcp_offset"]))
    boxes = scene_boxes(doc["scene"])
    tool = [(f"tool {name}", fcl.CollisionObject(geometry), T)
            for name, geometry, T in tool_solids(doc["tool"]["shape"])]
    arm = [(name, fcl.CollisionObject(geometry), frame, T)
           for name, geometry, frame, T in link_solids(links)]
    model = MODELS[str(doc["robot"]["model"])] if arm else None
    lying = part_boxes(parts)
    grip = gripper_bit(doc["robot"]) if lying else None
    held: tuple[fcl.CollisionObject, np.ndarray] | None = None
    closed_at: np.ndarray | None = None  # the TCP (base) where the last motion ended
    samples = contacts = link_contacts = part_contacts = carried = 0
    closest, where = np.inf, "nothing replayed"
    request = fcl.DistanceRequest(enable_signed_distance=True)

    def nearest(solid: fcl.CollisionObject, T: np.ndarray) -> tuple[float, str]:
        """The smallest distance (m) from ``solid`` at ``T`` to a bin or a box, and which."""
        solid.setTransform(fcl.Transform(T[:3, :3], T[:3, 3]))
        return min((fcl.distance(solid, box, request, fcl.DistanceResult()), box_name)
                   for box_name, box in boxes.items())

    def touches(name: str, solid: fcl.CollisionObject, T: np.ndarray, motion: Any) -> bool:
        nonlocal closest, where
        distance, box_name = nearest(solid, T)
        if distance < closest:
            closest, where = distance, f"{name} to {box_name} in motion {motion}"
        return distance <= 0.0

    for motion in motions:
        index = motion.get("motion")
        if grip is not None:
            bit, close_value = grip
            if bool(int(motion.get("digital_out", 0)) >> bit & 1) != close_value:
                held = None  # released: set down where the place put it
            elif held is None and closed_at is not None:
                held = _grab(lying, closed_at)
        traced_q = motion.get("q_trace", []) if model is not None else []
        F = frames(model, traced_q) if model is not None and traced_q else np.empty((0, 7, 4, 4))
        for pose in motion.get("tcp_trace", []):
            samples += 1
            T_base_tcp = pose_to_matrix(pose)
            T_base_flange = T_base_tcp @ T_tcp_flange
            touched = [touches(name, solid, T_base_flange @ T_flange_solid, index)
                       for name, solid, T_flange_solid in tool]
            contacts += any(touched)
            if held is not None:
                solid, T_tcp_part = held
                carried += 1
                # resting on a surface where it is grasped and set down: not the closest
                part_contacts += nearest(solid, T_base_tcp @ T_tcp_part)[0] < -PART_PRESS_M
            closed_at = T_base_tcp
        for F_cycle in F:
            hit = [touches(name, solid, F_cycle[frame] @ T_frame_solid, index)
                   for name, solid, frame, T_frame_solid in arm]
            link_contacts += any(hit)
    return ContactReport(samples, contacts, link_contacts, part_contacts, carried,
                         float(closest) * 1000.0, where)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, required=True, help="the cell config")
    parser.add_argument("--motions", type=Path, required=True,
                        help="the controller's motion record (JSON lines, with tcp_trace)")
    parser.add_argument("--links", type=Path, default=None,
                        help="the arm's link solids (JSON list: name, kind, frame, radius_m, "
                             "length_m, T_frame_solid); without it the links are not replayed")
    parser.add_argument("--parts", type=Path, default=None,
                        help="the parts where they lie (JSON list: name, size_m, T_base_part); "
                             "without it no held part is replayed")
    args = parser.parse_args(argv)
    try:
        motions = [json.loads(line) for line in args.motions.read_text().splitlines() if line]
        links = json.loads(args.links.read_text()) if args.links is not None else []
        parts = json.loads(args.parts.read_text()) if args.parts is not None else []
        report = count_contacts(args.config, motions, links, parts)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"contact check: cannot read the inputs: {exc}", file=sys.stderr)
        return 2
    print(report.line())
    return 1 if report.touched else 0


if __name__ == "__main__":
    sys.exit(main())
