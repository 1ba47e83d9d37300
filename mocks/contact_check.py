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
than that spacing between two samples can slip through. The held part is not replayed.

Usage: ``python -m mocks.contact_check --config cell.yaml --motions motions.jsonl
[--links links.json]`` (exit 0: no contact, 1: contacts, 2: bad input).
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


@dataclass(frozen=True)
class ContactReport:
    samples: int  # cycles replayed
    contacts: int  # of them, those at which the tool touched a bin or a box
    link_contacts: int  # those at which a link of the arm did
    closest_mm: float  # the smallest distance seen between a solid and a bin or a box
    closest: str  # which solid, which box, which motion

    def line(self) -> str:
        return (f"{self.samples} driven cycles replayed, {self.contacts} touch a bin; "
                f"{self.link_contacts} with an arm's link; closest {self.closest_mm:.1f} mm "
                f"({self.closest})")


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


def count_contacts(config_path: Path, motions: Iterable[Mapping[str, Any]],
                   links: Iterable[Mapping[str, Any]] = ()) -> ContactReport:
    """Replay every ``tcp_trace`` pose of ``motions`` with the tool, and with ``links`` every
    ``q_trace`` joint vector with the arm's links, against the bins and boxes of the config."""
    doc = yaml.safe_load(Path(config_path).read_text())
    T_tcp_flange = np.linalg.inv(pose_to_matrix(doc["robot"]["tcp_offset"]))
    boxes = scene_boxes(doc["scene"])
    tool = [(f"tool {name}", fcl.CollisionObject(geometry), T)
            for name, geometry, T in tool_solids(doc["tool"]["shape"])]
    arm = [(name, fcl.CollisionObject(geometry), frame, T)
           for name, geometry, frame, T in link_solids(links)]
    model = MODELS[str(doc["robot"]["model"])] if arm else None
    samples = contacts = link_contacts = 0
    closest, where = np.inf, "nothing replayed"
    request = fcl.DistanceRequest(enable_signed_distance=True)

    def touches(name: str, solid: fcl.CollisionObject, T: np.ndarray, motion: Any) -> bool:
        nonlocal closest, where
        solid.setTransform(fcl.Transform(T[:3, :3], T[:3, 3]))
        touched = False
        for box_name, box in boxes.items():
            distance = fcl.distance(solid, box, request, fcl.DistanceResult())
            touched |= distance <= 0.0
            if distance < closest:
                closest, where = distance, f"{name} to {box_name} in motion {motion}"
        return touched

    for motion in motions:
        index = motion.get("motion")
        traced_q = motion.get("q_trace", []) if model is not None else []
        F = frames(model, traced_q) if model is not None and traced_q else np.empty((0, 7, 4, 4))
        for pose in motion.get("tcp_trace", []):
            samples += 1
            T_base_flange = pose_to_matrix(pose) @ T_tcp_flange
            touched = [touches(name, solid, T_base_flange @ T_flange_solid, index)
                       for name, solid, T_flange_solid in tool]
            contacts += any(touched)
        for F_cycle in F:
            hit = [touches(name, solid, F_cycle[frame] @ T_frame_solid, index)
                   for name, solid, frame, T_frame_solid in arm]
            link_contacts += any(hit)
    return ContactReport(samples, contacts, link_contacts, float(closest) * 1000.0, where)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, required=True, help="the cell config")
    parser.add_argument("--motions", type=Path, required=True,
                        help="the controller's motion record (JSON lines, with tcp_trace)")
    parser.add_argument("--links", type=Path, default=None,
                        help="the arm's link solids (JSON list: name, kind, frame, radius_m, "
                             "length_m, T_frame_solid); without it the links are not replayed")
    args = parser.parse_args(argv)
    try:
        motions = [json.loads(line) for line in args.motions.read_text().splitlines() if line]
        links = json.loads(args.links.read_text()) if args.links is not None else []
        report = count_contacts(args.config, motions, links)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"contact check: cannot read the inputs: {exc}", file=sys.stderr)
        return 2
    print(report.line())
    return 1 if report.contacts or report.link_contacts else 0


if __name__ == "__main__":
    sys.exit(main())
