"""Point cloud files: ``.npy`` arrays and PLY as Zivid Studio and Open3D write them.

Coordinates are kept exactly as stored (Zivid and most camera tools: mm); nothing here converts
units. PLY vertices become an unorganized ``(N, 3)`` cloud, NaN rows included: Zivid writes an
organized cloud as a vertex list in row-major pixel order, and that order is kept.

Files are read and written a chunk of points at a time (``open_cloud``, ``CloudWriter``), so a
whole-file job such as the ``cloud`` command holds a few MB whatever the cloud's size, and
``read_cloud`` fills its arrays straight from the file without a second copy. Every header is
checked against the file's size before anything is allocated: a header that claims more points
than the file holds is refused at once, however large the claim.
"""

from __future__ import annotations

import io
import logging
import math
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from numpy.lib import format as npy_format
from numpy.typing import NDArray

from handeye_pick.cloud.ply import PlyElement, check_size, read_ply_header, vertex_header
from handeye_pick.cloud.transform import FloatArray
from handeye_pick.errors import DetectionError, InputError

log = logging.getLogger(__name__)

CLOUD_SUFFIXES = (".npy", ".ply")
"""File types ``read_cloud`` and ``write_cloud`` handle, chosen by the file name's suffix."""

CHUNK_POINTS = 262_144
"""Points per chunk when a file is streamed: a few MB of buffers, which stay in the CPU's cache
between reading, transforming and writing a chunk."""

_COLOUR_NAMES = ("red", "green", "blue")
_FLOAT_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))

ColourArray = NDArray[np.uint8]


@dataclass(frozen=True)
class PointCloud:
    """A cloud in one frame, in its stored length unit (Zivid: mm).

    Attributes:
        xyz: float32 or float64, organized ``(H, W, 3)`` or unorganized ``(N, 3)``; NaN where
            the camera has no data.
        rgb: uint8 colours with the same shape as ``xyz``, or None when the source had none.
    """

    xyz: FloatArray
    rgb: ColourArray | None = None

    def __post_init__(self) -> None:
        xyz = self.xyz
        if not isinstance(xyz, np.ndarray) or xyz.ndim not in (2, 3) or xyz.shape[-1] != 3:
            shape = xyz.shape if isinstance(xyz, np.ndarray) else type(xyz).__name__
            raise InputError(f"point cloud: xyz must have shape (H, W, 3) or (N, 3), got {shape}")
        if xyz.dtype not in _FLOAT_DTYPES:
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


@dataclass(frozen=True)
class CloudLayout:
    """What a cloud file holds, known from its header before any point is read.

    Attributes:
        shape: of the xyz array, ``(H, W, 3)`` or ``(N, 3)``.
        dtype: native float32 or float64, the dtype the points are read in.
        has_rgb: whether the file has uint8 colours for every point.
    """

    shape: tuple[int, ...]
    dtype: np.dtype[Any]
    has_rgb: bool

    @property
    def points(self) -> int:
        return math.prod(self.shape[:-1])


def cloud_file_type(path: Path, operation: str, error: type[InputError] = InputError) -> str:
    """The suffix of a cloud file name (".npy" or ".ply"), or ``error`` naming ``operation``."""
    suffix = path.suffix.lower()
    if suffix not in CLOUD_SUFFIXES:
        raise error(
            f"{operation} {path}: unsupported file type {suffix or '(none)'!r}, "
            f"expected one of {', '.join(CLOUD_SUFFIXES)}"
        )
    return suffix


# --- reading ------------------------------------------------------------------------------------


class CloudReader:
    """A cloud file open for reading, its header checked; points come in file order.

    Use as a context manager. ``layout`` says what the file holds; ``read_into`` fills the next
    points; ``chunks`` iterates over the whole file in reused buffers.
    """

    def __init__(self, path: Path, file: io.BufferedReader, layout: CloudLayout):
        self.path = path
        self.layout = layout
        self._file = file

    def read_into(self, xyz: FloatArray, rgb: ColourArray | None) -> None:
        """Fill ``xyz`` (C-contiguous ``(n, 3)`` of ``layout.dtype``) and, when the file has
        colours, ``rgb`` (``(n, 3)`` uint8) with the next ``n`` points of the file."""
        raise NotImplementedError

    def chunks(
        self, max_points: int = CHUNK_POINTS
    ) -> Iterator[tuple[FloatArray, ColourArray | None]]:
        """Every point of the file as ``(xyz, rgb)`` chunks of at most ``max_points`` points.

        The arrays are reused: each chunk is valid until the next one is asked for.
        """
        size = min(max_points, self.layout.points)
        xyz = np.empty((size, 3), dtype=self.layout.dtype)
        rgb = np.empty((size, 3), dtype=np.uint8) if self.layout.has_rgb else None
        for start in range(0, self.layout.points, max_points):
            n = min(max_points, self.layout.points - start)
            xyz_n, rgb_n = xyz[:n], None if rgb is None else rgb[:n]
            self.read_into(xyz_n, rgb_n)
            yield xyz_n, rgb_n

    def _read_exactly(self, buffer: NDArray[Any]) -> None:
        """Fill ``buffer`` (C-contiguous, or the cast raises) with the file's next bytes."""
        view = buffer.data.cast("B")
        try:
            while view:
                got = self._file.readinto(view)
                if not got:
                    raise DetectionError(f"read cloud {self.path}: the file ends early (cut?)")
                view = view[got:]
        except OSError as exc:
            raise DetectionError(f"read cloud {self.path}: cannot read ({exc.strerror})") from None

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> CloudReader:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def open_cloud(path: Path | str) -> CloudReader:
    """Open a ``.npy`` (an ``(H, W, 3)`` or ``(N, 3)`` float array) or ``.ply`` cloud file.

    PLY: ASCII or binary, a ``vertex`` element with float or double ``x y z``; uchar
    ``red green blue`` are kept when present; other elements and properties (normals, alpha,
    faces, comments, obj_info) are ignored. Values are read in native byte order, unit as stored.

    Raises:
        DetectionError: the file is missing, unreadable, of another type, lacks x/y/z, or its
            header declares more data than the file holds.
    """
    path = Path(path)
    suffix = cloud_file_type(path, "read cloud", DetectionError)
    if not path.is_file():
        raise DetectionError(f"read cloud {path}: file not found")
    try:
        file = path.open("rb")
    except OSError as exc:
        raise DetectionError(f"read cloud {path}: cannot read ({exc.strerror or exc})") from None
    try:
        size = os.fstat(file.fileno()).st_size
        return _open_npy(path, file, size) if suffix == ".npy" else _open_ply(path, file, size)
    except BaseException:
        file.close()
        raise


def read_cloud(path: Path | str) -> PointCloud:
    """The whole cloud of a ``.npy`` or ``.ply`` file (see ``open_cloud``), read in one pass.

    Raises:
        DetectionError: as ``open_cloud``.
    """
    with open_cloud(path) as reader:
        layout = reader.layout
        xyz = np.empty(layout.shape, dtype=layout.dtype)
        rgb = np.empty(layout.shape, dtype=np.uint8) if layout.has_rgb else None
        reader.read_into(xyz.reshape(-1, 3), None if rgb is None else rgb.reshape(-1, 3))
    return PointCloud(xyz=xyz, rgb=rgb)


# .npy: a header (shape, dtype, order), then the array's bytes.


class _NpyReader(CloudReader):
    def __init__(
        self,
        path: Path,
        file: io.BufferedReader,
        layout: CloudLayout,
        stored: np.dtype[Any],
        fortran: bool,
    ):
        super().__init__(path, file, layout)
        self._stored = stored  # as in the file, byte order included
        self._points: FloatArray | None = None
        self._next = 0
        if fortran:
            # Column-major (np.save of a transposed array, rare): no point is contiguous in the
            # file, so it is read whole and served in row-major point order.
            whole = np.empty(layout.shape[::-1], dtype=stored)
            self._read_exactly(whole)
            self._points = whole.T.astype(layout.dtype).reshape(-1, 3)

    def read_into(self, xyz: FloatArray, rgb: ColourArray | None) -> None:
        if self._points is not None:
            xyz[:] = self._points[self._next : self._next + len(xyz)]
            self._next += len(xyz)
            return
        self._read_exactly(xyz)  # straight into the caller's array: no second copy
        if self._stored != self.layout.dtype:  # big-endian file
            xyz.byteswap(inplace=True)


def _open_npy(path: Path, file: io.BufferedReader, file_size: int) -> CloudReader:
    try:
        version = npy_format.read_magic(file)
        if version == (1, 0):
            shape, fortran, stored = npy_format.read_array_header_1_0(file)
        elif version == (2, 0):
            shape, fortran, stored = npy_format.read_array_header_2_0(file)
        else:
            raise ValueError(f"format version {version} is not supported")
    except (ValueError, EOFError) as exc:
        raise DetectionError(f"read cloud {path}: not a readable .npy array ({exc})") from None
    if stored.kind != "f" or stored.itemsize not in (4, 8):
        raise DetectionError(f"read cloud {path}: expected float32 or float64 xyz, got {stored}")
    if len(shape) not in (2, 3) or shape[-1] != 3 or min(shape) < 0:
        raise DetectionError(f"read cloud {path}: expected shape (H, W, 3) or (N, 3), got {shape}")
    needed = math.prod(shape) * stored.itemsize
    available = file_size - file.tell()
    if needed > available:
        raise DetectionError(
            f"read cloud {path}: not a readable .npy array (its header declares shape {shape}, "
            f"{needed} bytes, but only {available} bytes follow the header)"
        )
    layout = CloudLayout(tuple(shape), stored.newbyteorder("="), has_rgb=False)
    return _NpyReader(path, file, layout, stored, fortran)


# PLY: the vertex element's records, from the file a chunk at a time (binary) or parsed whole
# (ascii, which has no fixed record size; Zivid Studio and Open3D write binary by default).


class _PlyReader(CloudReader):
    def __init__(
        self,
        path: Path,
        file: io.BufferedReader,
        layout: CloudLayout,
        record: np.dtype[Any],
        parsed: NDArray[Any] | None = None,
    ):
        """Binary records are read from ``file``; an ascii file's come ``parsed`` whole."""
        super().__init__(path, file, layout)
        self._parsed = parsed
        scratch_size = min(CHUNK_POINTS, layout.points) if parsed is None else 0
        self._scratch = np.empty(scratch_size, dtype=record)
        self._next = 0

    def _next_records(self, n: int) -> NDArray[Any]:
        if self._parsed is not None:
            records = self._parsed[self._next : self._next + n]
        else:
            records = self._scratch[:n]
            self._read_exactly(records)
        self._next += n
        return records

    def read_into(self, xyz: FloatArray, rgb: ColourArray | None) -> None:
        for start in range(0, len(xyz), CHUNK_POINTS):
            records = self._next_records(min(CHUNK_POINTS, len(xyz) - start))
            done = slice(start, start + len(records))
            for column, name in enumerate("xyz"):
                xyz[done, column] = records[name]
            if rgb is not None:
                for column, name in enumerate(_COLOUR_NAMES):
                    rgb[done, column] = records[name]


def _open_ply(path: Path, file: io.BufferedReader, file_size: int) -> CloudReader:
    try:
        header = read_ply_header(file)
        check_size(header, file_size)
    except ValueError as exc:
        raise DetectionError(f"read cloud {path}: not a readable PLY file ({exc})") from None
    vertex = header.element("vertex")
    if vertex is None:
        raise DetectionError(f"read cloud {path}: PLY has no 'vertex' element")
    layout = _ply_layout(path, vertex)
    if vertex.has_lists:
        raise DetectionError(f"read cloud {path}: PLY vertices with list properties are not read")
    before = header.elements[: header.elements.index(vertex)]
    if header.byte_order is None:
        record = vertex.record_dtype("=")
        parsed = _parse_text(path, file, record, vertex.count, sum(e.count for e in before))
        return _PlyReader(path, file, layout, record, parsed)
    if any(e.has_lists for e in before):
        raise DetectionError(
            f"read cloud {path}: binary PLY with list properties before the vertices is not read"
        )
    file.seek(header.size + sum(e.count * e.record_dtype("<").itemsize for e in before))
    return _PlyReader(path, file, layout, vertex.record_dtype(header.byte_order))


def _parse_text(
    path: Path, file: io.BufferedReader, record: np.dtype[Any], count: int, skip_lines: int
) -> NDArray[Any]:
    """The ``count`` vertex lines of an ascii PLY, after ``skip_lines`` of earlier elements."""
    text = io.TextIOWrapper(file, encoding="ascii")
    try:
        with warnings.catch_warnings():
            # Blank lines are skipped, not counted as vertices; numpy warns it once did so.
            warnings.filterwarnings("ignore", "Input line", UserWarning)
            parsed: NDArray[Any] = np.loadtxt(
                text, dtype=record, skiprows=skip_lines, max_rows=count, comments=None, ndmin=1
            )
    except (ValueError, UnicodeDecodeError) as exc:
        reason = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise DetectionError(
            f"read cloud {path}: not a readable PLY file (vertex data: {reason})"
        ) from None
    finally:
        text.detach()  # the reader closes the file itself
    if len(parsed) != count:
        raise DetectionError(
            f"read cloud {path}: not a readable PLY file (its header declares {count} vertices, "
            f"the file holds {len(parsed)})"
        )
    return parsed


def _ply_layout(path: Path, vertex: PlyElement) -> CloudLayout:
    types = {p.name: p for p in vertex.properties}
    missing = [name for name in "xyz" if name not in types]
    if missing:
        raise DetectionError(
            f"read cloud {path}: PLY vertices lack {', '.join(missing)} "
            f"(properties found: {', '.join(types) or 'none'})"
        )
    coords = [types[name] for name in "xyz"]
    if any(p.count_type is not None or p.type not in ("f4", "f8") for p in coords):
        raise DetectionError(
            f"read cloud {path}: PLY x, y, z must be float or double, "
            f"got {', '.join(_describe(p.type, p.count_type) for p in coords)}"
        )
    colours = [types[name] for name in _COLOUR_NAMES if name in types]
    if colours and len(colours) != len(_COLOUR_NAMES):
        raise DetectionError(
            f"read cloud {path}: PLY has colour properties "
            f"{', '.join(p.name for p in colours)} but not all of red, green, blue"
        )
    if any(p.count_type is not None or p.type != "u1" for p in colours):
        raise DetectionError(
            f"read cloud {path}: PLY red, green, blue must be uchar, "
            f"got {', '.join(_describe(p.type, p.count_type) for p in colours)}"
        )
    # float32 when the file stores float, as Zivid does; float64 when any coordinate is double.
    dtype = np.dtype(np.float32 if all(p.type == "f4" for p in coords) else np.float64)
    return CloudLayout((vertex.count, 3), dtype, has_rgb=bool(colours))


def _describe(type_code: str, count_type: str | None) -> str:
    name = str(np.dtype(type_code))
    return name if count_type is None else f"list of {name}"


# --- writing ------------------------------------------------------------------------------------


class CloudWriter:
    """A cloud file being written a chunk at a time, as ``.npy`` or binary little-endian ``.ply``.

    The data goes to a temporary file next to ``path`` that ``commit`` renames into place, so
    ``path`` is never left half written, and it may even be the file being read. Use as a
    context manager: leaving it without ``commit`` removes the temporary file.

    ``.npy`` keeps the array's shape (organized stays organized) and holds xyz only: colours are
    dropped with a warning. ``.ply`` writes one vertex per point in row-major order with
    ``float`` (float32 data) or ``double`` (float64) x y z and uchar red green blue when the
    cloud has colours, the layout Open3D and Zivid Studio read.

    Raises:
        InputError: unsupported suffix, or the file cannot be written.
    """

    def __init__(self, path: Path | str, layout: CloudLayout):
        self.path = Path(path)
        self.layout = layout
        self._ply = cloud_file_type(self.path, "write cloud") == ".ply"
        self._written = 0
        fields = [(name, layout.dtype.str[1:]) for name in "xyz"]  # "f4" or "f8"
        if layout.has_rgb:
            fields += [(name, "u1") for name in _COLOUR_NAMES]
        self._record = np.dtype([(name, "<" + code) for name, code in fields])
        if layout.has_rgb and not self._ply:
            log.warning("write cloud %s: .npy holds xyz only; colours not written", self.path)
        # Created like any new file (mode 0666 less the umask), in the target's directory so the
        # rename is atomic.
        self._partial = self.path.with_name(f".{self.path.name}.{os.getpid()}.partial")
        with _write_errors(self.path):
            self._file = self._partial.open("xb")
        try:
            with _write_errors(self.path):
                self._write_header(fields)
        except BaseException:
            self.close()
            raise

    def _write_header(self, fields: list[tuple[str, str]]) -> None:
        if self._ply:
            self._file.write(vertex_header(self.layout.points, fields, "written by handeye-pick"))
        else:
            npy_format.write_array_header_1_0(
                self._file,
                {
                    "descr": npy_format.dtype_to_descr(self.layout.dtype),
                    "fortran_order": False,
                    "shape": self.layout.shape,
                },
            )

    def write(self, xyz: FloatArray, rgb: ColourArray | None) -> None:
        """Append the points ``xyz`` (``(n, 3)``) and, when the layout has colours, their
        colours ``rgb`` (``(n, 3)`` uint8)."""
        with _write_errors(self.path):
            for start in range(0, len(xyz), CHUNK_POINTS):
                part = slice(start, start + CHUNK_POINTS)
                if self._ply:
                    data = self._records(xyz[part], None if rgb is None else rgb[part])
                else:
                    data = np.ascontiguousarray(xyz[part], dtype=self.layout.dtype)
                self._file.write(data.data)
        self._written += len(xyz)

    def _records(self, xyz: FloatArray, rgb: ColourArray | None) -> NDArray[Any]:
        records = np.empty(len(xyz), dtype=self._record)
        for column, name in enumerate("xyz"):
            records[name] = xyz[:, column]
        if self.layout.has_rgb:
            if rgb is None:
                raise ValueError(f"write cloud {self.path}: the layout has colours, rgb is None")
            for column, name in enumerate(_COLOUR_NAMES):
                records[name] = rgb[:, column]
        return records

    def commit(self) -> None:
        """Close the file and move it to ``path``; every point of the layout must be written."""
        if self._written != self.layout.points:
            raise ValueError(
                f"write cloud {self.path}: {self._written} of {self.layout.points} points written"
            )
        with _write_errors(self.path):
            self._file.close()
            os.replace(self._partial, self.path)

    def close(self) -> None:
        """Drop the temporary file unless ``commit`` has moved it into place."""
        self._file.close()
        self._partial.unlink(missing_ok=True)

    def __enter__(self) -> CloudWriter:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


@contextmanager
def _write_errors(path: Path) -> Iterator[None]:
    """An OSError while writing becomes an InputError naming the file."""
    try:
        yield
    except OSError as exc:
        raise InputError(f"write cloud {path}: cannot write ({exc.strerror or exc})") from None


def write_cloud(path: Path | str, cloud: PointCloud) -> None:
    """Write ``cloud`` to ``.npy`` or binary little-endian ``.ply``, unit as stored (see
    ``CloudWriter``).

    Raises:
        InputError: unsupported suffix, or the file cannot be written.
    """
    layout = CloudLayout(cloud.xyz.shape, cloud.xyz.dtype, has_rgb=cloud.rgb is not None)
    with CloudWriter(path, layout) as writer:
        rgb = None if cloud.rgb is None else cloud.rgb.reshape(-1, 3)
        writer.write(cloud.xyz.reshape(-1, 3), rgb)
        writer.commit()
