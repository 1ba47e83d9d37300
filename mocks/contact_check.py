"""An independent check of what the simulated arm drove: replays the TCP poses of the simulated
controller's motion record (``tcp_trace``, recorded with ``--trace-tcp``) with the tool's solids
from a cell config and counts the poses at which a solid touches a bin.

It reads the cell config with plain YAML and builds the bins (a floor and four walls) and the
tool's boxes and cylinders itself with python-fcl; it never imports ``handeye_pick``, so it
shares no geometry with the check it judges. Config keys: ``robot.tcp_offset`` (T_flange_tcp,
m, rad), ``tool.shape`` (solids in the flange frame, sizes mm, poses m, rad) and
``scene.bins`` (``pose`` of the inner floor centre, ``inner_mm``, ``wall_mm``, ``floor_mm``).

A sample touches when FCL's distance between a solid and a bin's box is 0 or less; samples are
one control cycle apart (2 ms, a few mm of travel at the example's speeds), so a touch shallower
than that spacing between two samples can slip through.

Usage: ``python -m mocks.contact_check --config cell.yaml --motions motions.jsonl``
(exit 0: no contact, 1: contacts, 2: bad input).
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

from mocks.ur_controller.kinematics import pose_to_matrix


@dataclass(frozen=True)
class ContactReport:
    samples: int  # TCP poses replayed
    contacts: int  # of them, those at which some solid touched a bin
    closest_mm: float  # the smallest distance seen between a solid and a bin
    closest: str  # which solid, which box, which motion

    def line(self) -> str:
        return (f"{self.samples} driven TCP poses replayed, {self.contacts} touch a bin; "
                f"closest {self.closest_mm:.1f} mm ({self.closest})")


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


def count_contacts(config_path: Path, motions: Iterable[Mapping[str, Any]]) -> ContactReport:
    """Replay every ``tcp_trace`` pose of ``motions`` against the bins of the config."""
    doc = yaml.safe_load(Path(config_path).read_text())
    T_tcp_flange = np.linalg.inv(pose_to_matrix(doc["robot"]["tcp_offset"]))
    boxes: dict[str, fcl.CollisionObject] = {}
    for entry in doc["scene"]["bins"]:
        boxes.update(bin_boxes(entry))
    solids = [(name, fcl.CollisionObject(geometry), T)
              for name, geometry, T in tool_solids(doc["tool"]["shape"])]
    samples = contacts = 0
    closest, where = np.inf, "nothing replayed"
    request = fcl.DistanceRequest(enable_signed_distance=True)
    for motion in motions:
        for pose in motion.get("tcp_trace", []):
            samples += 1
            T_base_flange = pose_to_matrix(pose) @ T_tcp_flange
            touched = False
            for name, solid, T_flange_solid in solids:
                T = T_base_flange @ T_flange_solid
                solid.setTransform(fcl.Transform(T[:3, :3], T[:3, 3]))
                for box_name, box in boxes.items():
                    distance = fcl.distance(solid, box, request, fcl.DistanceResult())
                    touched |= distance <= 0.0
                    if distance < closest:
                        closest = distance
                        where = f"tool {name} to {box_name} in motion {motion.get('motion')}"
            contacts += touched
    return ContactReport(samples, contacts, float(closest) * 1000.0, where)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, required=True, help="the cell config")
    parser.add_argument("--motions", type=Path, required=True,
                        help="the controller's motion record (JSON lines, with tcp_trace)")
    args = parser.parse_args(argv)
    try:
        motions = [json.loads(line) for line in args.motions.read_text().splitlines() if line]
        report = count_contacts(args.config, motions)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"contact check: cannot read the inputs: {exc}", file=sys.stderr)
        return 2
    print(report.line())
    return 1 if report.contacts else 0


if __name__ == "__main__":
    sys.exit(main())
