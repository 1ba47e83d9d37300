"""Point cloud files: ``.npy`` arrays and PLY as Zivid Studio and Open3D write them.

Coordinates are kept exactly as stored (Zivid and most camera tools: mm); nothing here converts
units. PLY vertices become an unorganized ``(N, 3)`` cloud, NaN rows included: Zivid writes an
organized cloud as a vertex list in row-major pixel order, and that order is kept.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from plyfile import PlyData, PlyElement, PlyParseError

from handeye_pick.cloud import FloatArray
from handeye_pick.errors import DetectionError, InputError

log = logging.getLogger(__name__)

CLOUD_SUFFIXES = (".npy", ".ply")
"""File types ``read_cloud`` and ``write_cloud`` handle, chosen by the file name's suffix."""

_COLOUR_NAMES = ("red", "green", "blue")


@dataclass(frozen=True)
class PointCloud:
    """A cloud in one frame, in its stored length unit (Zivid: mm).

    Attributes:
        xyz: float32 or float64, organized ``(H, W, 3)`` or unorganized ``(N, 3)``; NaN where
            the camera has no data.
        rgb: uint8 colours with the same shape as ``xyz``, or None when the source had none.
    """

    xyz: FloatArray
    rgb: NDArray[np.uint8] | None = None

    def __post_init__(self) -> None:
        xyz = self.xyz
        if not isinstance(xyz, np.ndarray) or xyz.ndim not in (2, 3) or xyz.shape[-1] != 3:
            shape = xyz.shape if isinstance(xyz, np.ndarray) else type(xyz).__name__
            raise InputError(f"point cloud: xyz must have shape (H, W, 3) or (N, 3), got {shape}")
        if xyz.dtype not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise InputError(f"point cloud: xyz must be float32 or float64, got {xyz.dtype}")
        if self.rgb is not None and (
            not isinstance(self.rgb, np.ndarray)
            or self.rgb.shape != xyz.shape
            or self.rgb.dtype != np.uint8
        ):
            found = (
                f"shape {self.rgb.shape}, dtype {self.rgb.dtype}"
                if isinstance(self.rgb, np.ndarray)
                else type(self.rgb).__name__
            )
            raise InputError(
                f"point cloud: rgb must be uint8 with the shape of xyz {xyz.shape}, got {found}"
            )


def cloud_file_type(path: Path, operation: str, error: type[InputError] = InputError) -> str:
    """The suffix of a cloud file name (".npy" or ".ply"), or ``error`` naming ``operation``."""
    suffix = path.suffix.lower()
    if suffix not in CLOUD_SUFFIXES:
        raise error(
            f"{operation} {path}: unsupported file type {suffix or '(none)'!r}, "
            f"expected one of {', '.join(CLOUD_SUFFIXES)}"
        )
    return suffix


def read_cloud(path: Path | str) -> PointCloud:
    """Read a cloud from ``.npy`` (an ``(H, W, 3)`` or ``(N, 3)`` float array) or ``.ply``.

    PLY: ASCII or binary, a ``vertex`` element with float or double ``x y z``; uchar
    ``red green blue`` are kept when present; other elements and properties (normals, alpha,
    faces, comments, obj_info) are ignored. Values are returned in native byte order, unit as
    stored.

    Raises:
        DetectionError: the file is missing, unreadable, of another type, or lacks x/y/z.
    """
    path = Path(path)
    suffix = cloud_file_type(path, "read cloud", DetectionError)
    if not path.is_file():
        raise DetectionError(f"read cloud {path}: file not found")
    if suffix == ".npy":
        return PointCloud(xyz=_read_npy(path))
    return _read_ply(path)


def _native(arr: NDArray[Any]) -> NDArray[Any]:
    """``arr`` in native byte order (files may hold big-endian data)."""
    return arr.astype(arr.dtype.newbyteorder("="), copy=False)


def _read_npy(path: Path) -> FloatArray:
    try:
        arr = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise DetectionError(f"read cloud {path}: not a readable .npy array ({exc})") from None
    if not isinstance(arr, np.ndarray) or arr.dtype.kind != "f" or arr.itemsize not in (4, 8):
        found = arr.dtype if isinstance(arr, np.ndarray) else type(arr).__name__
        raise DetectionError(f"read cloud {path}: expected float32 or float64 xyz, got {found}")
    if arr.ndim not in (2, 3) or arr.shape[-1] != 3:
        raise DetectionError(
            f"read cloud {path}: expected shape (H, W, 3) or (N, 3), got {arr.shape}"
        )
    xyz: FloatArray = _native(arr)
    return xyz


def _read_ply(path: Path) -> PointCloud:
    try:
        ply = PlyData.read(str(path))
    except (PlyParseError, OSError, ValueError) as exc:
        raise DetectionError(f"read cloud {path}: not a readable PLY file ({exc})") from None
    if "vertex" not in ply:
        raise DetectionError(f"read cloud {path}: PLY has no 'vertex' element")
    vertices = ply["vertex"].data
    names = vertices.dtype.names or ()
    missing = [name for name in "xyz" if name not in names]
    if missing:
        raise DetectionError(
            f"read cloud {path}: PLY vertices lack {', '.join(missing)} "
            f"(properties found: {', '.join(names) or 'none'})"
        )
    coord_types = [vertices.dtype[name] for name in "xyz"]
    if any(t.kind != "f" or t.itemsize not in (4, 8) for t in coord_types):
        raise DetectionError(
            f"read cloud {path}: PLY x, y, z must be float or double, "
            f"got {', '.join(str(t) for t in coord_types)}"
        )
    # float32 when the file stores float, as Zivid does; float64 when any coordinate is double.
    xyz_dtype = np.float32 if all(t.itemsize == 4 for t in coord_types) else np.float64
    xyz = np.empty((len(vertices), 3), dtype=xyz_dtype)
    for column, name in enumerate("xyz"):
        xyz[:, column] = vertices[name]
    return PointCloud(xyz=xyz, rgb=_read_ply_colours(path, vertices, names))


def _read_ply_colours(
    path: Path, vertices: NDArray[Any], names: tuple[str, ...]
) -> NDArray[np.uint8] | None:
    present = [name for name in _COLOUR_NAMES if name in names]
    if not present:
        return None
    if len(present) != len(_COLOUR_NAMES):
        raise DetectionError(
            f"read cloud {path}: PLY has colour properties {', '.join(present)} but not all of "
            "red, green, blue"
        )
    colour_types = [vertices.dtype[name] for name in _COLOUR_NAMES]
    if any(t != np.uint8 for t in colour_types):
        raise DetectionError(
            f"read cloud {path}: PLY red, green, blue must be uchar, "
            f"got {', '.join(str(t) for t in colour_types)}"
        )
    rgb = np.empty((len(vertices), 3), dtype=np.uint8)
    for column, name in enumerate(_COLOUR_NAMES):
        rgb[:, column] = vertices[name]
    return rgb


def write_cloud(path: Path | str, cloud: PointCloud) -> None:
    """Write ``cloud`` to ``.npy`` or binary little-endian ``.ply``, unit as stored.

    ``.npy`` keeps the array's shape (organized stays organized) and holds xyz only: colours are
    dropped with a warning. ``.ply`` writes one vertex per point in row-major order with
    ``float`` (float32 data) or ``double`` (float64) x y z and uchar red green blue when the
    cloud has colours, the layout Open3D and Zivid Studio read.

    Raises:
        InputError: unsupported suffix, or the file cannot be written.
    """
    path = Path(path)
    suffix = cloud_file_type(path, "write cloud")
    try:
        if suffix == ".npy":
            if cloud.rgb is not None:
                log.warning("write cloud %s: .npy holds xyz only; colours not written", path)
            # An open file, because np.save(path) appends ".npy" to a name ending in ".NPY".
            with path.open("wb") as file:
                np.save(file, cloud.xyz, allow_pickle=False)
        else:
            _write_ply(path, cloud)
    except OSError as exc:
        raise InputError(f"write cloud {path}: cannot write ({exc.strerror or exc})") from None


def _write_ply(path: Path, cloud: PointCloud) -> None:
    coord = "<f4" if cloud.xyz.dtype == np.float32 else "<f8"
    fields = [(name, coord) for name in "xyz"]
    if cloud.rgb is not None:
        fields += [(name, "u1") for name in _COLOUR_NAMES]
    xyz = cloud.xyz.reshape(-1, 3)
    vertices = np.empty(len(xyz), dtype=fields)
    for column, name in enumerate("xyz"):
        vertices[name] = xyz[:, column]
    if cloud.rgb is not None:
        rgb = cloud.rgb.reshape(-1, 3)
        for column, name in enumerate(_COLOUR_NAMES):
            vertices[name] = rgb[:, column]
    element = PlyElement.describe(vertices, "vertex")
    ply = PlyData([element], text=False, byte_order="<", comments=["written by handeye-pick"])
    ply.write(str(path))
