"""transform_points against a float64 reference, in place and out of place, both kernels (numpy
blocks and numba) bit for bit; pick_point by pixel."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

import handeye_pick
from handeye_pick.cloud import transform as cloud
from handeye_pick.cloud.transform import pick_point, transform_points
from handeye_pick.errors import DetectionError, InputError, TransformError
from handeye_pick.geometry import make_transform

DTYPES = (np.float32, np.float64)

# Relative rounding of one float operation; the float32 kernel rounds R, t and a few products.
UNIT_ROUNDOFF = {np.dtype(np.float32): 2.0**-24, np.dtype(np.float64): 2.0**-53}


@st.composite
def rigid_transforms(draw: st.DrawFn) -> NDArray[np.float64]:
    """Random rotations (including identity and half turns) with translations up to 2 m in mm."""
    special = [
        np.eye(3),
        Rotation.from_rotvec([np.pi, 0.0, 0.0]).as_matrix(),
        Rotation.from_rotvec([0.0, np.pi - 1e-7, 0.0]).as_matrix(),
    ]
    if draw(st.booleans()):
        R = draw(st.sampled_from(special))
    else:
        q = draw(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4))
        if np.linalg.norm(q) < 1e-3:
            q = [0.0, 0.0, 0.0, 1.0]
        R = Rotation.from_quat(q).as_matrix()
    t = draw(st.lists(st.floats(-2000.0, 2000.0), min_size=3, max_size=3))
    return make_transform(R, t)


@st.composite
def clouds(draw: st.DrawFn, dtype: type[np.floating[Any]]) -> NDArray[np.floating[Any]]:
    """Organized (H, W, 3) or unorganized (N, 3) clouds in mm, with whole NaN points."""
    if draw(st.booleans()):
        shape: tuple[int, ...] = (draw(st.integers(1, 7)), draw(st.integers(1, 9)), 3)
    else:
        shape = (draw(st.integers(0, 40)), 3)
    elements = st.floats(-5000.0, 5000.0, width=32 if dtype == np.float32 else 64)
    points = draw(hnp.arrays(dtype, shape, elements=elements))
    missing = draw(hnp.arrays(np.bool_, shape[:-1]))
    points[missing] = np.nan
    return points


def reference(points: NDArray[np.floating[Any]], T: NDArray[np.float64]) -> NDArray[np.float64]:
    """p_a = R p_b + t in float64, row by row."""
    return points.astype(np.float64) @ T[:3, :3].T + T[:3, 3]


def assert_close_to_reference(
    result: NDArray[np.floating[Any]],
    points: NDArray[np.floating[Any]],
    T: NDArray[np.float64],
) -> None:
    expected = reference(points, T)
    # Error bound of a few roundings of the largest term in each row, |R| |p| + |t|, plus the
    # smallest normal number for values that underflow in float32.
    scale = np.abs(points.astype(np.float64)).sum(axis=-1, keepdims=True) + np.abs(T[:3, 3]).sum()
    tolerance = 8 * UNIT_ROUNDOFF[points.dtype] * scale + 8 * np.finfo(points.dtype).tiny
    valid = ~np.isnan(expected).any(axis=-1)
    assert np.all(np.abs(result - expected)[valid] <= tolerance[valid])
    assert np.all(np.isnan(result[~valid]))
    assert np.all(np.isfinite(result[valid]))


@pytest.mark.parametrize("dtype", DTYPES)
@settings(deadline=None, max_examples=60)  # the first call may compile the kernel
@given(data=st.data())
def test_matches_float64_reference_and_keeps_shape_dtype_nan(
    dtype: type[np.floating[Any]], data: st.DataObject
) -> None:
    points = data.draw(clouds(dtype))
    T = data.draw(rigid_transforms())
    before = points.copy()

    result = transform_points(points, T)

    assert result.shape == points.shape
    assert result.dtype == points.dtype
    assert result is not points
    np.testing.assert_array_equal(points, before)  # out of place leaves the input alone
    assert_close_to_reference(result, points, T)


@pytest.mark.parametrize("dtype", DTYPES)
@settings(deadline=None, max_examples=40)
@given(data=st.data())
def test_in_place_equals_out_of_place(dtype: type[np.floating[Any]], data: st.DataObject) -> None:
    points = data.draw(clouds(dtype))
    T = data.draw(rigid_transforms())
    expected = transform_points(points, T)

    returned = transform_points(points, T, out=points)

    assert returned is points
    np.testing.assert_array_equal(points, expected)


@pytest.mark.parametrize("dtype", DTYPES)
def test_full_size_organized_cloud_with_missing_points(dtype: type[np.floating[Any]]) -> None:
    # Large enough that every worker thread gets a share of the rows.
    rng = np.random.default_rng(7)
    points = rng.uniform(-2000.0, 2000.0, (480, 640, 3)).astype(dtype)
    points[rng.random((480, 640)) < 0.2] = np.nan
    T = make_transform(Rotation.from_rotvec([0.3, -1.2, 2.0]).as_matrix(), [250.0, -40.0, 900.0])
    original = points.copy()

    transform_points(points, T, out=points)

    assert_close_to_reference(points, original, T)


@pytest.mark.parametrize("dtype", DTYPES)
@settings(deadline=None, max_examples=40)  # the first example may compile the numba kernel
@given(data=st.data())
def test_numba_kernel_gives_the_numpy_kernels_bits(
    dtype: type[np.floating[Any]], data: st.DataObject
) -> None:
    points = data.draw(clouds(dtype))
    T = data.draw(rigid_transforms())
    R, t = T[:3, :3].astype(dtype), T[:3, 3].astype(dtype)
    by_numpy, by_numba = points.copy(), points.copy()

    cloud._transform_numpy(by_numpy.reshape(-1), R, t)
    cloud._compile_kernel()(by_numba.reshape(-1), R, t)

    assert by_numpy.tobytes() == by_numba.tobytes()  # NaN payloads included


def test_a_process_loads_numba_once_it_has_transformed_jit_after_points(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(cloud, "JIT_AFTER_POINTS", 100)
    monkeypatch.setattr(cloud, "_points_without_jit", 0)
    monkeypatch.setattr(cloud, "_jit_kernel", None)
    points = np.random.default_rng(2).uniform(-500.0, 500.0, (60, 3))
    T = make_transform(Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix(), [1.0, 2.0, 3.0])

    first = transform_points(points, T)
    assert cloud._jit_kernel is None  # 60 points: numpy
    second = transform_points(points, T)
    assert cloud._jit_kernel is not None  # 120 points: numba from here on

    np.testing.assert_array_equal(first, second)
    assert_close_to_reference(second, points, T)


def test_explicit_out_array_is_filled_and_returned() -> None:
    points = np.arange(12, dtype=np.float32).reshape(4, 3)
    out = np.full_like(points, -1.0)
    T = make_transform(np.eye(3), [1.0, 2.0, 3.0])

    returned = transform_points(points, T, out=out)

    assert returned is out
    np.testing.assert_array_equal(out, points + np.array([1.0, 2.0, 3.0], dtype=np.float32))


def test_strided_view_in_place_leaves_other_channels_alone() -> None:
    # xyz as the first three channels of an (H, W, 4) array: not contiguous.
    buffer = np.arange(2 * 5 * 4, dtype=np.float32).reshape(2, 5, 4)
    xyz = buffer[..., :3]
    fourth = buffer[..., 3].copy()
    expected_input = xyz.copy()
    T = make_transform(Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix(), [10.0, 0.0, 0.0])

    transform_points(xyz, T, out=xyz)

    assert_close_to_reference(buffer[..., :3], expected_input, T)
    np.testing.assert_array_equal(buffer[..., 3], fourth)


@pytest.mark.parametrize("dtype", DTYPES)
def test_non_contiguous_input_and_output(dtype: type[np.floating[Any]]) -> None:
    rng = np.random.default_rng(3)
    points = np.asfortranarray(rng.uniform(-100.0, 100.0, (6, 4, 3)).astype(dtype))
    out = np.zeros((6, 8, 3), dtype=dtype)[:, ::2]
    T = make_transform(Rotation.from_rotvec([1.0, 2.0, 0.5]).as_matrix(), [5.0, 6.0, 7.0])

    transform_points(points, T, out=out)

    assert_close_to_reference(out, points, T)


def test_out_overlapping_the_input_by_one_point_is_still_right() -> None:
    buffer = np.arange(15, dtype=np.float64).reshape(5, 3)
    points = buffer[:-1]
    out = buffer[1:]
    original = points.copy()
    T = make_transform(Rotation.from_rotvec([0.2, 0.0, 0.0]).as_matrix(), [1.0, 1.0, 1.0])

    transform_points(points, T, out=out)

    np.testing.assert_allclose(out, reference(original, T), rtol=0, atol=1e-12)


def test_empty_cloud_is_fine() -> None:
    result = transform_points(np.empty((0, 3), dtype=np.float32), np.eye(4))
    assert result.shape == (0, 3)
    assert result.dtype == np.float32


def test_single_point_shape_is_kept() -> None:
    T = make_transform(np.eye(3), [1.0, 2.0, 3.0])
    result = transform_points(np.array([1.0, 1.0, 1.0]), T)
    np.testing.assert_array_equal(result, [2.0, 3.0, 4.0])


def test_exported_from_the_package() -> None:
    assert handeye_pick.transform_points is transform_points


@pytest.mark.parametrize(
    ("points", "message"),
    [
        ([[1.0, 2.0, 3.0]], "numpy array"),
        (np.zeros((4, 4), dtype=np.float32), r"shape \(\.\.\., 3\)"),
        (np.zeros((4, 3), dtype=np.int32), "float32 or float64"),
        (np.zeros((4, 3), dtype=np.float16), "float32 or float64"),
        (np.zeros((4, 3), dtype=">f4"), "float32 or float64"),
        (np.float32(1.0) * np.ones(()), r"shape \(\.\.\., 3\)"),
    ],
)
def test_rejects_bad_points(points: Any, message: str) -> None:
    with pytest.raises(InputError, match=message):
        transform_points(points, np.eye(4))


@pytest.mark.parametrize(
    ("out", "message"),
    [
        (np.zeros((5, 3), dtype=np.float32), "out must match"),
        (np.zeros((4, 3), dtype=np.float64), "out must match"),
        (np.zeros((4, 3), dtype=np.float32).tolist(), "numpy array"),
    ],
)
def test_rejects_mismatched_out(out: Any, message: str) -> None:
    with pytest.raises(InputError, match=message):
        transform_points(np.zeros((4, 3), dtype=np.float32), np.eye(4), out=out)


def test_rejects_read_only_out() -> None:
    points = np.zeros((4, 3), dtype=np.float32)
    points.flags.writeable = False
    with pytest.raises(InputError, match="read-only"):
        transform_points(points, np.eye(4), out=points)


@pytest.mark.parametrize(
    "T",
    [
        np.eye(3),
        np.diag([2.0, 2.0, 2.0, 1.0]),
        np.diag([1.0, 1.0, -1.0, 1.0]),
        np.full((4, 4), np.nan),
    ],
    ids=["3x3", "scaled", "reflection", "nan"],
)
def test_rejects_non_rigid_transforms(T: NDArray[np.float64]) -> None:
    with pytest.raises(TransformError, match="transform_points: T"):
        transform_points(np.zeros((2, 3), dtype=np.float32), T)


# --- pick_point ---------------------------------------------------------------------------------


def organized_cloud() -> NDArray[np.float32]:
    """A 3-row, 4-column cloud whose point at (col c, row r) is (c, r, 100 r + c)."""
    rows, cols = np.mgrid[0:3, 0:4]
    return np.stack([cols, rows, 100 * rows + cols], axis=-1).astype(np.float32)


def test_pick_point_reads_row_then_column() -> None:
    point = pick_point(organized_cloud(), col=3, row=1)
    assert point.dtype == np.float64
    np.testing.assert_array_equal(point, [3.0, 1.0, 103.0])


def test_pick_point_names_the_pixel_without_data() -> None:
    xyz = organized_cloud()
    xyz[2, 1] = np.nan
    with pytest.raises(DetectionError, match=r"no 3D data at pixel \(col 1, row 2\)"):
        pick_point(xyz, col=1, row=2)


@pytest.mark.parametrize(("col", "row"), [(4, 0), (0, 3), (-1, 0), (0, -1)])
def test_pick_point_outside_the_cloud(col: int, row: int) -> None:
    with pytest.raises(DetectionError, match="outside the cloud"):
        pick_point(organized_cloud(), col=col, row=row)


def test_pick_point_needs_an_organized_cloud() -> None:
    with pytest.raises(DetectionError, match="organized cloud"):
        pick_point(organized_cloud().reshape(-1, 3), col=0, row=0)


def test_pick_point_needs_integer_pixels() -> None:
    with pytest.raises(DetectionError, match="col must be an integer"):
        pick_point(organized_cloud(), col=1.5, row=0)  # type: ignore[arg-type]


def test_benchmark_script_runs_on_a_tiny_cloud() -> None:
    # Keeps benchmarks/cloud_transform.py working; its figures are read by people, not asserted.
    root = Path(__file__).resolve().parents[2]
    result = subprocess.run(
        [
            sys.executable,
            str(root / "benchmarks" / "cloud_transform.py"),
            "--rows",
            "4",
            "--cols",
            "5",
            "--repeats",
            "2",
            "--load-repeats",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert "float32 in place:" in result.stdout
