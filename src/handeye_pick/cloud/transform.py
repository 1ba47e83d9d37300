"""Point clouds in memory: rigid transforms of whole clouds, and picking one point by pixel.

Clouds are numpy arrays of shape ``(..., 3)``: organized ``(H, W, 3)`` as a Zivid camera delivers
them (row ``r``, column ``c`` is image pixel ``(c, r)``), or unorganized ``(N, 3)``. Missing points
are NaN. Coordinates are in whatever length unit the cloud is stored in (Zivid: mm); a transform
applied to a cloud must carry its translation in that same unit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.errors import DetectionError, InputError
from handeye_pick.geometry import validate_transform

_FLOAT_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))

FloatArray = NDArray[np.floating[Any]]
"""A float32 or float64 array; the dtype of a cloud is kept through every operation here."""


JIT_AFTER_POINTS = 150_000_000
"""Points a process transforms with numpy before it loads the numba kernel (30 Zivid 2+ clouds).

Loading numba and the cached kernel costs a process time and memory (about a second and 130 MiB
on a 2-core machine), after which the kernel saves a few ns a point over the numpy blocks.
``benchmarks/cloud_transform.py`` measures both and prints the break-even. As when renting until
the rent paid would have bought: numpy until the time the kernel would have saved is about its
load, so a process never pays much more than twice the better choice in hindsight; a one-off
command never loads numba, and a process that transforms cloud after cloud soon runs at memory
speed.
"""

_BLOCK_POINTS = 65_536
"""Points per block of the numpy kernel: its few block-sized buffers stay in a core's L2 cache."""

_jit_kernel: Callable[..., None] | None = None
_points_without_jit = 0  # transformed by numpy in this process so far


def _transform_flat_in_place(xyz_flat: FloatArray, R: FloatArray, t: FloatArray) -> None:
    """``x <- R x + t`` for each point of a contiguous flat cloud: numpy blocks, later numba."""
    global _jit_kernel, _points_without_jit
    if _jit_kernel is None:
        _points_without_jit += xyz_flat.size // 3
        if _points_without_jit < JIT_AFTER_POINTS:
            _transform_numpy(xyz_flat, R, t)
            return
        _jit_kernel = _compile_kernel()
    _jit_kernel(xyz_flat, R, t)


def _transform_numpy(xyz_flat: FloatArray, R: FloatArray, t: FloatArray) -> None:
    """The numba loop's arithmetic, ``((r0 x + r1 y) + r2 z) + t`` in the data's dtype, in blocks.

    Each block is split into contiguous x, y and z rows first, so the ufuncs run on unit-stride
    data; the buffers are reused, so the whole cloud is never copied. Same operations in the same
    order as the numba loop: both kernels give the same bits.
    """
    points = xyz_flat.reshape(-1, 3)
    size = min(len(points), _BLOCK_POINTS)
    planes = np.empty((3, size), dtype=points.dtype)
    total = np.empty(size, dtype=points.dtype)
    term = np.empty(size, dtype=points.dtype)
    for start in range(0, len(points), _BLOCK_POINTS):
        block = points[start : start + _BLOCK_POINTS]
        n = len(block)
        x, y, z = planes[:, :n]
        acc, tmp = total[:n], term[:n]
        np.copyto(planes[:, :n], block.T)
        for row in range(3):
            np.multiply(x, R[row, 0], out=acc)
            acc += np.multiply(y, R[row, 1], out=tmp)
            acc += np.multiply(z, R[row, 2], out=tmp)
            acc += t[row]
            block[:, row] = acc


def _compile_kernel() -> Callable[..., None]:
    """The compiled transform loop; numba is imported here, by the first call that needs it.

    One fused pass over the points in place: each point is read once and written back, so the
    loop runs at memory bandwidth (a plain copy's speed or better: it touches one buffer, a copy
    two). Working on one flat array lets LLVM vectorize the stride-3 loop; with separate source
    and destination arrays it must allow for overlap and, in place, falls back to scalar code.
    One thread: a single vectorized thread already saturates memory, and a parallel loop runs
    twice as slow when another process holds a core. Arithmetic stays in the dtype of the data
    (float32 for Zivid clouds). fastmath stays off: it would let LLVM assume there is no NaN.
    ``cache=True`` keeps the machine code on disk, so only the very first call compiles.
    """
    import numba

    @numba.njit(cache=True)
    def transform_in_place(xyz_flat: FloatArray, R: FloatArray, t: FloatArray) -> None:
        # Copied to locals so LLVM keeps them in registers: xyz_flat could alias R for all it knows.
        r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
        r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
        r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
        t0, t1, t2 = t[0], t[1], t[2]
        for i in range(xyz_flat.shape[0] // 3):
            j = 3 * i
            x = xyz_flat[j]
            y = xyz_flat[j + 1]
            z = xyz_flat[j + 2]
            xyz_flat[j] = r00 * x + r01 * y + r02 * z + t0
            xyz_flat[j + 1] = r10 * x + r11 * y + r12 * z + t1
            xyz_flat[j + 2] = r20 * x + r21 * y + r22 * z + t2

    kernel: Callable[..., None] = transform_in_place
    return kernel


def _check_cloud_array(arr: object, what: str) -> FloatArray:
    """Return ``arr`` if it is a float32/float64 ndarray of shape (..., 3), else raise."""
    if not isinstance(arr, np.ndarray):
        raise InputError(
            f"transform_points: {what} must be a numpy array of shape (..., 3), "
            f"got {type(arr).__name__}"
        )
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise InputError(
            f"transform_points: {what} must have shape (..., 3) (x, y, z last), got {arr.shape}"
        )
    if arr.dtype not in _FLOAT_DTYPES:
        raise InputError(
            f"transform_points: {what} must be native float32 or float64, got dtype {arr.dtype}"
        )
    return arr


def _same_memory(a: np.ndarray[Any, Any], b: np.ndarray[Any, Any]) -> bool:
    """True when ``a`` and ``b`` view exactly the same elements in the same layout."""
    return (
        a.__array_interface__["data"][0] == b.__array_interface__["data"][0]
        and a.shape == b.shape
        and a.strides == b.strides
    )


def transform_points(points: FloatArray, T: ArrayLike, out: FloatArray | None = None) -> FloatArray:
    """Apply the rigid transform ``T_a_b`` to every point: ``p_a = R p_b + t``.

    Args:
        points: float32 or float64 array of shape ``(..., 3)`` in frame b: an organized
            ``(H, W, 3)`` cloud or an ``(N, 3)`` list. NaN points (no data) stay NaN.
        T: 4x4 rigid transform ``T_a_b``, validated here. Its translation must be in the length
            unit of the points (for a Zivid cloud in mm, scale a metre transform by 1000).
        out: where to write the result, same shape and dtype as ``points``; ``out=points``
            transforms in place. None allocates a new array.

    Returns:
        The points in frame a, same shape and dtype as ``points`` (``out`` when given). float32
        data is transformed in float32 arithmetic (relative error about 1e-7 of the coordinates).

    Speed: numpy in blocks (several times ``np.copyto`` of the cloud) until this process
    has transformed ``JIT_AFTER_POINTS`` points, then a numba kernel that runs in place at about
    the speed of the copy; the call that crosses the line imports numba (and compiles, once per
    machine). Out of place is a copy plus that.

    Raises:
        InputError: ``points`` or ``out`` has the wrong type, shape, dtype, or is read-only.
        TransformError: ``T`` is not a rigid 4x4 transform.
    """
    points = _check_cloud_array(points, "points")
    T_a_b = validate_transform(T, "transform_points: T")
    if out is None:
        out = np.empty(points.shape, dtype=points.dtype)
    else:
        out = _check_cloud_array(out, "out")
        if out.shape != points.shape or out.dtype != points.dtype:
            raise InputError(
                f"transform_points: out must match points (shape {points.shape}, dtype "
                f"{points.dtype}), got shape {out.shape}, dtype {out.dtype}"
            )
        if not out.flags.writeable:
            raise InputError("transform_points: out is read-only")

    R = T_a_b[:3, :3].astype(points.dtype)
    t = T_a_b[:3, 3].astype(points.dtype)
    # The kernel works in place on a contiguous array: points itself, out after a copy, or,
    # when out is strided or partly overlaps points, a private copy copied into out at the end.
    if out.flags.c_contiguous and _same_memory(out, points):
        work = out
    elif out.flags.c_contiguous and not np.may_share_memory(out, points):
        np.copyto(out, points)
        work = out
    else:
        work = np.array(points, order="C")
    _transform_flat_in_place(work.reshape(-1), R, t)
    if work is not out:
        np.copyto(out, work)
    return out


def pick_point(xyz: FloatArray, col: int, row: int) -> NDArray[np.float64]:
    """The point at image pixel ``(col, row)`` of an organized cloud: ``xyz[row, col]``.

    Args:
        xyz: organized cloud ``(H, W, 3)`` in the camera frame, in its stored unit (Zivid: mm).
        col: image column (x), 0 <= col < W.
        row: image row (y), 0 <= row < H.

    Returns:
        The camera-frame point as float64 ``(3,)``, same unit as the cloud.

    Raises:
        DetectionError: the cloud is not organized, the pixel is outside it, or the camera has
            no data there (NaN).
    """
    if not isinstance(xyz, np.ndarray) or xyz.ndim != 3 or xyz.shape[2] != 3:
        shape = xyz.shape if isinstance(xyz, np.ndarray) else type(xyz).__name__
        raise DetectionError(
            f"pick a pixel: expected an organized cloud of shape (H, W, 3), got {shape}; "
            "an unorganized (N, 3) cloud has no pixel grid"
        )
    for name, value in (("col", col), ("row", row)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise DetectionError(f"pick a pixel: {name} must be an integer, got {value!r}")
    height, width = xyz.shape[:2]
    if not (0 <= col < width and 0 <= row < height):
        raise DetectionError(
            f"pick a pixel: pixel (col {col}, row {row}) is outside the cloud "
            f"(cols 0..{width - 1}, rows 0..{height - 1})"
        )
    point = np.asarray(xyz[row, col], dtype=np.float64)
    if not np.all(np.isfinite(point)):
        raise DetectionError(
            f"pick a pixel: the cloud has no 3D data at pixel (col {col}, row {row}) "
            f"(got {point.tolist()}); choose a pixel on the object's surface"
        )
    return point
