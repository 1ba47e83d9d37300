"""The ``scene`` section (bins, box obstacles, the floor plane, the clearance) and the ``tool``
section (``tool.shape``: the tool's boxes and cylinders in the flange frame).

Poses are UR pose vectors [x, y, z, rx, ry, rz] in metres and radians (a bin's is its inner
floor's centre, a box's and a tool solid's their centre); sizes are millimetres. The collision
check that uses them is ``handeye_pick.scene`` (docs/scene.md).
"""

from __future__ import annotations

from handeye_pick.config.arm import read_arm_checked
from handeye_pick.config.poses import pose_vector
from handeye_pick.config.reader import Fields, Number, describe
from handeye_pick.config.schema import (
    MAX_REACH_M,
    MAX_TCP_OFFSET_M,
    MAX_WORKSPACE_MM,
    BinConfig,
    SceneBox,
    SceneConfig,
    ToolShape,
)
from handeye_pick.errors import ConfigError

MIN_SIZE_MM = 1.0  # a solid thinner than a millimetre is one written in metres
MAX_SIZE_MM = MAX_WORKSPACE_MM  # nothing in a cell is bigger than the reach of a UR arm
MAX_TOOL_SIZE_MM = 1000.0  # no tool solid is a metre long
MAX_CLEARANCE_MM = 100.0

_SIZE = Number("mm", minimum=MIN_SIZE_MM, maximum=MAX_SIZE_MM)
_TOOL_SIZE = Number("mm", minimum=MIN_SIZE_MM, maximum=MAX_TOOL_SIZE_MM)
_SCENE_NUMBERS = {
    "clearance_mm": Number(
        "mm", minimum=0.0, maximum=MAX_CLEARANCE_MM, default=SceneConfig.clearance_mm
    ),
    "floor_z_mm": Number("mm", minimum=-MAX_WORKSPACE_MM, maximum=MAX_WORKSPACE_MM),
}
_BIN_NUMBERS = {"wall_mm": _SIZE, "floor_mm": _SIZE}
_CYLINDER_NUMBERS = {"radius_mm": _TOOL_SIZE, "length_mm": _TOOL_SIZE}
_BIN_KEYS = ("name", "pose", "inner_mm", *_BIN_NUMBERS)
_BOX_KEYS = ("name", "pose", "size_mm")
_SOLID_KEYS = ("name", "box", "cylinder")


def read_scene(top: Fields) -> SceneConfig:
    """``scene``: ``bins``, ``boxes``, ``floor_z_mm``, ``clearance_mm`` and ``arm``; names are
    unique within their kind, and at least one obstacle is given."""
    scene = top.section("scene", ("bins", "boxes", "arm", *_SCENE_NUMBERS))
    bins = tuple(_bin(item) for item in _entries(scene, "bins", _BIN_KEYS))
    boxes = tuple(_box(item) for item in _entries(scene, "boxes", _BOX_KEYS))
    _unique(scene, "bins", [b.name for b in bins])
    _unique(scene, "boxes", [b.name for b in boxes])
    floor = scene.number("floor_z_mm", _SCENE_NUMBERS) if scene.has("floor_z_mm") else None
    if not bins and not boxes and floor is None:
        scene.fail("", "give at least one of bins, boxes or floor_z_mm")
    return SceneConfig(
        bins=bins,
        boxes=boxes,
        floor_z_mm=floor,
        clearance_mm=scene.number("clearance_mm", _SCENE_NUMBERS),
        arm_checked=read_arm_checked(scene),
    )


def read_tool_shape(top: Fields) -> tuple[ToolShape, ...]:
    """``tool.shape``: a list of solids, each ``name`` and exactly one of ``box: {size_mm,
    pose}`` or ``cylinder: {radius_mm, length_mm, pose}`` (pose in the flange frame, m, rad)."""
    tool = top.section("tool", ("shape",))
    shapes = tuple(_tool_solid(item) for item in _entries(tool, "shape", _SOLID_KEYS))
    if not shapes:
        tool.fail("shape", "expected at least one solid (box or cylinder)")
    _unique(tool, "shape", [s.name for s in shapes])
    return shapes


def _entries(fields: Fields, key: str, allowed: tuple[str, ...]) -> list[Fields]:
    """The items of an optional list of mappings, each opened as ``key[i]`` with ``allowed``."""
    if not fields.has(key):
        return []
    listed = fields.raw(key)
    if not isinstance(listed, list):
        fields.fail(key, f"expected a list, got {describe(listed)}")
    return [
        Fields(
            item,
            source=fields.source,
            prefix=f"{fields.path(key)}[{i}]",
            allowed=allowed,
            error=ConfigError,
        )
        for i, item in enumerate(listed)
    ]


def _sizes(fields: Fields, key: str, spec: Number) -> tuple[float, float, float]:
    """Three edge lengths (mm) within ``spec``'s bounds."""
    values = fields.vector(key, 3)
    low, high = spec.minimum or 0.0, spec.maximum or MAX_SIZE_MM
    if not all(low <= v <= high for v in values):
        fields.fail(
            key,
            f"every size must lie within {low:g} to {high:g} mm, got {values.tolist()} "
            "(metres given?)",
        )
    return float(values[0]), float(values[1]), float(values[2])


def _bin(item: Fields) -> BinConfig:
    return BinConfig(
        name=item.string("name"),
        T_base_bin=pose_vector(item, "pose", MAX_REACH_M),
        inner_mm=_sizes(item, "inner_mm", _SIZE),
        wall_mm=item.number("wall_mm", _BIN_NUMBERS),
        floor_mm=item.number("floor_mm", _BIN_NUMBERS),
    )


def _box(item: Fields) -> SceneBox:
    return SceneBox(
        name=item.string("name"),
        size_mm=_sizes(item, "size_mm", _SIZE),
        T_base_box=pose_vector(item, "pose", MAX_REACH_M),
    )


def _tool_solid(item: Fields) -> ToolShape:
    name = item.string("name")
    if item.has("box") == item.has("cylinder"):
        item.fail(
            "", "give exactly one of box {size_mm, pose} or cylinder {radius_mm, length_mm, pose}"
        )
    if item.has("box"):
        box = item.section("box", ("size_mm", "pose"))
        return ToolShape(
            name=name,
            T_flange_shape=pose_vector(box, "pose", MAX_TCP_OFFSET_M),
            size_mm=_sizes(box, "size_mm", _TOOL_SIZE),
        )
    cylinder = item.section("cylinder", ("radius_mm", "length_mm", "pose"))
    return ToolShape(
        name=name,
        T_flange_shape=pose_vector(cylinder, "pose", MAX_TCP_OFFSET_M),
        radius_mm=cylinder.number("radius_mm", _CYLINDER_NUMBERS),
        length_mm=cylinder.number("length_mm", _CYLINDER_NUMBERS),
    )


def _unique(fields: Fields, key: str, names: list[str]) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            fields.fail(key, f"the name {name!r} is used twice: refusals name solids by it")
        seen.add(name)
