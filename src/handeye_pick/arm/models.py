"""The arm models ``robot.model`` names: Universal Robots' published DH parameters and a solid
per link, each default's source in docs/arm-model.md.

Frames and units: standard DH, frame 0 the controller's base frame (z up along joint 1), frame 6
the tool flange; joint ``j`` (1 to 6) turns about the z axis of frame ``j - 1``. Lengths in
metres. A link solid is a capsule or a cylinder along its own z axis, centred on its origin,
riding one DH frame: ``T_frame_solid`` places it there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from handeye_pick.geometry import Transform, make_transform

ALPHA_RAD = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
"""The twist of every UR arm's six DH rows (rad)."""

LINK_NAMES = ("shoulder", "upper arm", "elbow", "forearm", "wrist 1", "wrist 2", "wrist 3")
"""The link solids of every model, base to flange, as refusals name them."""

MESH_MARGIN_M = 0.005
"""Added to a radius taken from a collision mesh's bounding box (the bigger arms)."""

SolidKind = Literal["capsule", "cylinder"]


@dataclass(frozen=True)
class LinkSolid:
    """One link's solid: a capsule (a segment of ``length_m`` swept by a ball of ``radius_m``)
    or a cylinder (``radius_m``, ``length_m``), along its own z axis and centred on its origin,
    at ``T_frame_solid`` (m) in DH frame ``frame`` (1 to 5: it turns with joints 1 to ``frame``)."""

    name: str
    kind: SolidKind
    frame: int
    radius_m: float
    length_m: float
    T_frame_solid: Transform


@dataclass(frozen=True)
class ArmModel:
    """One UR arm: its DH rows ``d`` and ``a`` (m; the twists are ``ALPHA_RAD``) and its link
    solids in ``LINK_NAMES`` order."""

    name: str  # as robot.model spells it: "ur5e"
    d: tuple[float, float, float, float, float, float]
    a: tuple[float, float, float, float, float, float]
    links: tuple[LinkSolid, ...] = field(repr=False)

    @property
    def e_series(self) -> bool:
        """An e-Series arm or a UR20/UR30 (PolyScope 5), not a CB3 (PolyScope 3)."""
        return self.name not in CB3_NAMES

    @cached_property
    def solid_frames(self) -> NDArray[np.intp]:
        """The DH frame every link rides, (L,)."""
        return np.array([link.frame for link in self.links], dtype=np.intp)

    def link(self, name: str) -> LinkSolid:
        """The link solid called ``name`` (``LINK_NAMES``)."""
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)


@dataclass(frozen=True)
class _Radii:
    """The radii (m) of a model's link solids, by ``LINK_NAMES`` (the wrists share one)."""

    shoulder: float
    upper_arm: float
    elbow: float
    forearm: float
    wrist: float


@dataclass(frozen=True)
class _Figures:
    """What a model's defaults are built from: its DH rows (m), the sideways offsets of the
    upper arm's and the forearm's tubes from the DH plane (m) and its links' radii."""

    dh: tuple[float, float, float, float, float, float]  # d1, a2, a3, d4, d5, d6
    shoulder_offset: float
    elbow_offset: float
    radii: _Radii


_MEASURED = _Radii(shoulder=0.060, upper_arm=0.054, elbow=0.060, forearm=0.040, wrist=0.045)
"""Measured on a UR5 and given for the UR3, UR5, UR3e and UR5e alike (docs/arm-model.md)."""


def _from_mesh(upper_arm: tuple[float, float], forearm: tuple[float, float],
               wrist_across: float) -> _Radii:
    """Radii from the collision meshes' bounding boxes: the cross-sections (m) of the upper
    arm and the forearm and a wrist's width across (m). Half the smaller cross-section for a
    tube, half the larger for the joint housings, half the width for a wrist; each plus
    ``MESH_MARGIN_M``."""
    housing = max(upper_arm) / 2.0 + MESH_MARGIN_M
    return _Radii(
        shoulder=housing,
        upper_arm=min(upper_arm) / 2.0 + MESH_MARGIN_M,
        elbow=housing,
        forearm=min(forearm) / 2.0 + MESH_MARGIN_M,
        wrist=wrist_across / 2.0 + MESH_MARGIN_M,
    )


_UR10E_MESH = _from_mesh((0.153, 0.175), (0.116, 0.125), 0.094)
_UR20_MESH = _from_mesh((0.180, 0.223), (0.151, 0.183), 0.100)
_FIGURES: dict[str, _Figures] = {
    "ur3e": _Figures((0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921), 0.120, 0.027,
                     _MEASURED),
    "ur5e": _Figures((0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996), 0.138, 0.007,
                     _MEASURED),
    "ur10e": _Figures((0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655), 0.1762, 0.0393,
                      _UR10E_MESH),
    "ur16e": _Figures((0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655), 0.176, 0.040,
                      _UR10E_MESH),
    "ur20": _Figures((0.2363, -0.8620, -0.7287, 0.2010, 0.1593, 0.1543), 0.260, 0.043,
                     _UR20_MESH),
    "ur30": _Figures((0.2363, -0.6370, -0.5037, 0.2010, 0.1593, 0.1543), 0.260, 0.043,
                     _UR20_MESH),
    "ur3": _Figures((0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819), 0.1198, 0.0275,
                    _MEASURED),
    "ur5": _Figures((0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823), 0.13585, 0.0165,
                    _MEASURED),
    "ur10": _Figures((0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922), 0.220941, 0.049042,
                     _UR10E_MESH),
}
CB3_NAMES = ("ur3", "ur5", "ur10")
MODEL_NAMES = tuple(_FIGURES)
"""Every ``robot.model``: the e-Series, UR20 and UR30, then the CB3 arms."""

_ALONG_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # solid z along x


def _along_z(name: str, frame: int, radius: float, z0: float, z1: float) -> LinkSolid:
    """A joint housing: a cylinder on frame ``frame``'s z axis from ``z0`` to ``z1`` (m)."""
    T = make_transform(np.eye(3), [0.0, 0.0, (z0 + z1) / 2.0])
    return LinkSolid(name, "cylinder", frame, radius, z1 - z0, T)


def _tube(name: str, frame: int, radius: float, a: float, offset: float) -> LinkSolid:
    """A tube: a capsule along frame ``frame``'s x from the previous joint's axis (x = -a) to
    this frame's origin (x = 0), ``offset`` (m) sideways along z."""
    T = make_transform(_ALONG_X, [-a / 2.0, 0.0, offset])
    return LinkSolid(name, "capsule", frame, radius, abs(a), T)


def _links(f: _Figures, r: _Radii) -> tuple[LinkSolid, ...]:
    """The seven solids: housings around the joint axes, reaching a radius past the tubes they
    join; the tubes along the upper arm and the forearm at their sideways offsets."""
    _, a2, a3, d4, d5, d6 = f.dh
    return (
        _along_z("shoulder", 1, r.shoulder, -r.shoulder, f.shoulder_offset + r.shoulder),
        _tube("upper arm", 2, r.upper_arm, a2, f.shoulder_offset),
        _along_z("elbow", 2, r.elbow, f.elbow_offset - r.elbow, f.shoulder_offset + r.elbow),
        _tube("forearm", 3, r.forearm, a3, f.elbow_offset),
        _along_z("wrist 1", 3, r.wrist, f.elbow_offset - r.wrist, d4 + r.wrist),
        _along_z("wrist 2", 4, r.wrist, -r.wrist, d5),
        _along_z("wrist 3", 5, r.wrist, -r.wrist, d6),
    )


def arm_model(name: str, radii_m: Mapping[str, float] | None = None) -> ArmModel:
    """The model ``name`` (``MODEL_NAMES``), with the radii (m) of the links ``radii_m`` names
    (``LINK_NAMES``) in place of the defaults: a housing's length follows its radius (it reaches
    a radius past the tubes it joins). KeyError for an unknown model or link."""
    f = _FIGURES[name]
    overrides = dict(radii_m or {})
    unknown = set(overrides) - set(LINK_NAMES)
    if unknown:
        raise KeyError(sorted(unknown)[0])
    links = _links(f, f.radii)
    if overrides:
        # Each link's own radius; the wrists share one in the defaults, not in an override.
        links = tuple(
            _links(f, replace(f.radii, **_radius_field(link.name, overrides[link.name])))[index]
            if link.name in overrides
            else link
            for index, link in enumerate(links)
        )
    d1, a2, a3, d4, d5, d6 = f.dh
    return ArmModel(name=name, d=(d1, 0.0, 0.0, d4, d5, d6), a=(0.0, a2, a3, 0.0, 0.0, 0.0),
                    links=links)


def _radius_field(link: str, radius_m: float) -> dict[str, float]:
    """The ``_Radii`` field a link's radius is (the three wrists share ``wrist``)."""
    return {"wrist" if link.startswith("wrist") else link.replace(" ", "_"): radius_m}
