"""Cloud files: PLY laid out as Open3D and Zivid write it, our own PLY and .npy round trips."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray
from plyfile import PlyData, PlyElement

from handeye_pick.cloud import files as cloud_files
from handeye_pick.cloud.files import (
    CloudLayout,
    CloudWriter,
    PointCloud,
    open_cloud,
    read_cloud,
    write_cloud,
)
from handeye_pick.errors import DetectionError, InputError


def random_xyz(n: int, dtype: type[np.floating[Any]], seed: int = 0) -> NDArray[Any]:
    rng = np.random.default_rng(seed)
    xyz = rng.uniform(-1500.0, 1500.0, (n, 3)).astype(dtype)
    xyz[rng.random(n) < 0.25] = np.nan
    return xyz


def random_rgb(n: int, seed: int = 1) -> NDArray[np.uint8]:
    return np.random.default_rng(seed).integers(0, 256, (n, 3), dtype=np.uint8)


def write_ply_like(
    path: Path,
    xyz: NDArray[Any],
    *,
    coord_type: str,
    extra: dict[str, tuple[str, NDArray[Any]]],
    text: bool,
    byte_order: str = "<",
    comments: tuple[str, ...] = (),
    obj_info: tuple[str, ...] = (),
) -> None:
    """Write a vertex-only PLY with plyfile: x y z of ``coord_type`` then ``extra`` properties."""
    fields = [(name, coord_type) for name in "xyz"] + [(n, t) for n, (t, _) in extra.items()]
    vertices = np.empty(len(xyz), dtype=fields)
    for column, name in enumerate("xyz"):
        vertices[name] = xyz[:, column]
    for name, (_, values) in extra.items():
        vertices[name] = values
    element = PlyElement.describe(vertices, "vertex")
    PlyData(
        [element],
        text=text,
        byte_order=byte_order,
        comments=list(comments),
        obj_info=list(obj_info),
    ).write(str(path))


def colour_properties(rgb: NDArray[np.uint8]) -> dict[str, tuple[str, NDArray[Any]]]:
    return {name: ("u1", rgb[:, k]) for k, name in enumerate(("red", "green", "blue"))}


@pytest.mark.parametrize("text", [False, True], ids=["binary", "ascii"])
@pytest.mark.parametrize("with_colours", [False, True], ids=["xyz", "xyz-rgb"])
@pytest.mark.parametrize("with_normals", [False, True], ids=["", "normals"])
def test_reads_open3d_layout(
    tmp_path: Path, text: bool, with_colours: bool, with_normals: bool
) -> None:
    # Open3D's WritePointCloudToPLY: "comment Created by Open3D", double x y z, then double
    # nx ny nz when it has normals, then uchar red green blue when it has colours.
    xyz = random_xyz(50, np.float64)
    rgb = random_rgb(50)
    extra: dict[str, tuple[str, NDArray[Any]]] = {}
    if with_normals:
        extra |= {name: ("f8", np.full(50, 0.5)) for name in ("nx", "ny", "nz")}
    if with_colours:
        extra |= colour_properties(rgb)
    path = tmp_path / "open3d.ply"
    write_ply_like(
        path, xyz, coord_type="f8", extra=extra, text=text, comments=("Created by Open3D",)
    )
    header = path.read_bytes().split(b"end_header")[0].decode()
    assert header.startswith(
        f"ply\nformat {'ascii' if text else 'binary_little_endian'} 1.0\n"
        "comment Created by Open3D\nelement vertex 50\nproperty double x\n"
    )

    cloud = read_cloud(path)

    assert cloud.xyz.dtype == np.float64
    np.testing.assert_array_equal(cloud.xyz, xyz)  # NaN compares equal to NaN here
    if with_colours:
        assert cloud.rgb is not None
        np.testing.assert_array_equal(cloud.rgb, rgb)
    else:
        assert cloud.rgb is None


@pytest.mark.parametrize("text", [False, True], ids=["binary", "ascii"])
def test_reads_zivid_layout_keeping_nan_rows_and_float32(tmp_path: Path, text: bool) -> None:
    # Zivid writes an organized cloud as a float vertex list with NaN points, uchar colours with
    # alpha; the obj_info lines are ignored and the pixel order is kept.
    xyz = random_xyz(4 * 6, np.float32, seed=5)
    rgb = random_rgb(4 * 6, seed=6)
    extra = colour_properties(rgb) | {"alpha": ("u1", np.full(24, 255, dtype=np.uint8))}
    path = tmp_path / "zivid.ply"
    write_ply_like(
        path, xyz, coord_type="f4", extra=extra, text=text, obj_info=("width 6", "height 4")
    )

    cloud = read_cloud(path)

    assert cloud.xyz.dtype == np.float32
    assert cloud.xyz.shape == (24, 3)
    np.testing.assert_array_equal(cloud.xyz, xyz)
    np.testing.assert_array_equal(np.isnan(cloud.xyz), np.isnan(xyz))
    assert cloud.rgb is not None
    np.testing.assert_array_equal(cloud.rgb, rgb)


def test_big_endian_ply_comes_back_in_native_order(tmp_path: Path) -> None:
    xyz = random_xyz(10, np.float32)
    path = tmp_path / "big.ply"
    write_ply_like(path, xyz, coord_type="f4", extra={}, text=False, byte_order=">")

    cloud = read_cloud(path)

    assert cloud.xyz.dtype == np.dtype(np.float32)
    np.testing.assert_array_equal(cloud.xyz, xyz)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("with_colours", [False, True], ids=["xyz", "xyz-rgb"])
def test_own_ply_round_trip_flattens_row_major(
    tmp_path: Path, dtype: type[np.floating[Any]], with_colours: bool
) -> None:
    xyz = random_xyz(3 * 5, dtype).reshape(3, 5, 3)
    rgb = random_rgb(3 * 5).reshape(3, 5, 3) if with_colours else None
    path = tmp_path / "out.ply"

    write_cloud(path, PointCloud(xyz=xyz, rgb=rgb))
    cloud = read_cloud(path)

    assert path.read_bytes().startswith(b"ply\nformat binary_little_endian 1.0\n")
    assert cloud.xyz.dtype == dtype
    np.testing.assert_array_equal(cloud.xyz, xyz.reshape(-1, 3))
    if rgb is None:
        assert cloud.rgb is None
    else:
        assert cloud.rgb is not None
        np.testing.assert_array_equal(cloud.rgb, rgb.reshape(-1, 3))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_npy_round_trip_keeps_organized_shape(
    tmp_path: Path, dtype: type[np.floating[Any]]
) -> None:
    xyz = random_xyz(4 * 7, dtype).reshape(4, 7, 3)
    path = tmp_path / "cloud.npy"

    write_cloud(path, PointCloud(xyz=xyz))
    cloud = read_cloud(path)

    assert cloud.xyz.dtype == dtype
    np.testing.assert_array_equal(cloud.xyz, xyz)
    assert cloud.rgb is None


def test_npy_write_drops_colours_with_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "cloud.NPY"
    with caplog.at_level(logging.WARNING):
        write_cloud(path, PointCloud(xyz=random_xyz(5, np.float32), rgb=random_rgb(5)))

    assert "colours not written" in caplog.text
    assert path.is_file()  # np.save would have appended ".npy" to this name
    assert read_cloud(path).rgb is None


def test_big_endian_npy_comes_back_in_native_order(tmp_path: Path) -> None:
    xyz = random_xyz(6, np.float64)
    path = tmp_path / "big.npy"
    np.save(path, xyz.astype(">f8"))

    cloud = read_cloud(path)

    assert cloud.xyz.dtype == np.dtype(np.float64)
    np.testing.assert_array_equal(cloud.xyz, xyz)


# --- bad files ----------------------------------------------------------------------------------


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DetectionError, match="file not found"):
        read_cloud(tmp_path / "nothing.ply")


def test_unsupported_suffix(tmp_path: Path) -> None:
    path = tmp_path / "cloud.pcd"
    path.write_text("# .PCD v0.7\n")
    with pytest.raises(DetectionError, match=r"unsupported file type '\.pcd'"):
        read_cloud(path)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "not a readable PLY"),
        (b"solid cube\nfacet normal 0 0 1\n", "not a readable PLY"),
        (
            b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\n"
            b"property float y\nproperty float z\nend_header\n" + bytes(20),
            "not a readable PLY",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            b"end_header\n1 2\n",
            "lack z",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty int y\n"
            b"property int z\nend_header\n1 2 3\n",
            "float or double",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            b"property float z\nproperty uchar red\nend_header\n1 2 3 4\n",
            "not all of",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            b"property float z\nproperty float red\nproperty float green\nproperty float blue\n"
            b"end_header\n1 2 3 0.5 0.5 0.5\n",
            "must be uchar",
        ),
        (
            b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\n"
            b"end_header\n",
            "no 'vertex' element",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            b"property float z\nproperty list uchar int ids\nend_header\n1 2 3 2 7 8\n",
            "vertices with list properties are not read",
        ),
        (
            b"ply\nformat binary_little_endian 1.0\nelement face 1\n"
            b"property list uchar int vertex_indices\nelement vertex 1\nproperty float x\n"
            b"property float y\nproperty float z\nend_header\n" + bytes(1 + 12),
            "list properties before the vertices is not read",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            b"property float z\nproperty float x\nend_header\n1 2 3 4\n",
            "repeats property 'x'",
        ),
    ],
    ids=[
        "empty",
        "not-ply",
        "truncated",
        "no-z",
        "int-xyz",
        "partial-colour",
        "float-colour",
        "no-vertex",
        "vertex-list",
        "binary-list-before-vertices",
        "repeated-property",
    ],
)
def test_bad_ply(tmp_path: Path, content: bytes, message: str) -> None:
    path = tmp_path / "bad.ply"
    path.write_bytes(content)
    with pytest.raises(DetectionError, match=message) as info:
        read_cloud(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("array", "message"),
    [
        (np.zeros((5, 4), dtype=np.float32), r"shape \(H, W, 3\) or \(N, 3\)"),
        (np.zeros(3, dtype=np.float32), r"shape \(H, W, 3\) or \(N, 3\)"),
        (np.zeros((5, 3), dtype=np.int16), "float32 or float64"),
    ],
)
def test_bad_npy_array(tmp_path: Path, array: NDArray[Any], message: str) -> None:
    path = tmp_path / "bad.npy"
    np.save(path, array)
    with pytest.raises(DetectionError, match=message):
        read_cloud(path)


@pytest.mark.parametrize(
    ("write", "message"),
    [
        # Refused from the header, before anything is unpickled.
        (
            lambda path: np.save(path, np.array([{"x": 1}], dtype=object), allow_pickle=True),
            "float32 or float64 xyz, got object",
        ),
        (lambda path: path.write_text("1 2 3\n"), r"not a readable \.npy"),
    ],
    ids=["pickled", "text"],
)
def test_unreadable_npy(tmp_path: Path, write: Any, message: str) -> None:
    path = tmp_path / "bad.npy"
    write(path)
    with pytest.raises(DetectionError, match=message):
        read_cloud(path)


def test_write_into_missing_directory(tmp_path: Path) -> None:
    cloud = PointCloud(xyz=random_xyz(3, np.float32))
    for name in ("cloud.ply", "cloud.npy"):
        with pytest.raises(InputError, match="cannot write"):
            write_cloud(tmp_path / "missing" / name, cloud)


def test_write_unsupported_suffix(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="unsupported file type"):
        write_cloud(tmp_path / "cloud.xyz", PointCloud(xyz=random_xyz(3, np.float32)))


@pytest.mark.parametrize(
    ("xyz", "rgb", "message"),
    [
        (np.zeros((4, 2)), None, "xyz must have shape"),
        (np.zeros((4, 3), dtype=np.int32), None, "float32 or float64"),
        (np.zeros((4, 3)), np.zeros((5, 3), dtype=np.uint8), "rgb must be uint8"),
        (np.zeros((4, 3)), np.zeros((4, 3)), "rgb must be uint8"),
    ],
)
def test_point_cloud_checks_its_arrays(xyz: Any, rgb: Any, message: str) -> None:
    with pytest.raises(InputError, match=message):
        PointCloud(xyz=xyz, rgb=rgb)


# --- streaming in chunks ------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["cloud.npy", "cloud.ply"])
@pytest.mark.parametrize("with_colours", [False, True], ids=["xyz", "xyz-rgb"])
def test_chunks_cover_the_file_in_order_across_boundaries(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, with_colours: bool
) -> None:
    monkeypatch.setattr(cloud_files, "CHUNK_POINTS", 7)  # buffers of the readers and the writer
    xyz = random_xyz(5 * 9, np.float32).reshape(5, 9, 3)
    rgb = random_rgb(5 * 9).reshape(5, 9, 3) if with_colours else None
    write_cloud(tmp_path / name, PointCloud(xyz=xyz, rgb=rgb))

    with open_cloud(tmp_path / name) as reader:
        chunks = [(x.copy(), None if c is None else c.copy()) for x, c in reader.chunks(10)]

    assert [len(x) for x, _ in chunks] == [10, 10, 10, 10, 5]
    np.testing.assert_array_equal(np.concatenate([x for x, _ in chunks]), xyz.reshape(-1, 3))
    if rgb is not None and name.endswith(".ply"):
        np.testing.assert_array_equal(np.concatenate([c for _, c in chunks]), rgb.reshape(-1, 3))
    else:
        assert all(c is None for _, c in chunks)
    np.testing.assert_array_equal(
        read_cloud(tmp_path / name).xyz.reshape(-1, 3), xyz.reshape(-1, 3)
    )


def test_fortran_ordered_npy_comes_back_in_point_order(tmp_path: Path) -> None:
    xyz = np.asfortranarray(random_xyz(4 * 6, np.float64).reshape(4, 6, 3))
    np.save(tmp_path / "f.npy", xyz)
    assert b"'fortran_order': True" in (tmp_path / "f.npy").read_bytes()[:128]

    np.testing.assert_array_equal(read_cloud(tmp_path / "f.npy").xyz, xyz)


@pytest.mark.parametrize("text", [False, True], ids=["binary", "ascii"])
def test_ply_elements_before_and_after_the_vertices_are_skipped(tmp_path: Path, text: bool) -> None:
    xyz = random_xyz(6, np.float64)
    vertices = np.empty(6, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    for column, name in enumerate("xyz"):
        vertices[name] = xyz[:, column]
    camera = np.array([(1.5, 7)], dtype=[("focal", "f4"), ("id", "i2")])
    faces = np.array([([0, 1, 2],), ([3, 4, 5],)], dtype=[("vertex_indices", "O")])
    path = tmp_path / "mesh.ply"
    PlyData(
        [
            PlyElement.describe(camera, "camera"),
            PlyElement.describe(vertices, "vertex"),
            PlyElement.describe(faces, "face"),
        ],
        text=text,
    ).write(str(path))

    np.testing.assert_array_equal(read_cloud(path).xyz, xyz)


def test_writing_goes_through_a_temporary_file_that_never_stays(tmp_path: Path) -> None:
    cloud = PointCloud(xyz=random_xyz(5, np.float32))
    path = tmp_path / "cloud.ply"
    with CloudWriter(path, CloudLayout((5, 3), np.dtype(np.float32), has_rgb=False)) as writer:
        writer.write(cloud.xyz[:2], None)
    assert list(tmp_path.iterdir()) == []  # left without commit: nothing, not half a file

    write_cloud(path, cloud)
    assert [p.name for p in tmp_path.iterdir()] == ["cloud.ply"]


# --- hostile headers: refused from the header and the file size, before any allocation ---------


def npy_claiming(path: Path, shape: tuple[int, ...], payload: bytes = bytes(48)) -> Path:
    """A .npy whose header declares ``shape`` (float32) but which holds only ``payload``."""
    with path.open("wb") as file:
        np.lib.format.write_array_header_1_0(
            file, {"descr": "<f4", "fortran_order": False, "shape": shape}
        )
        file.write(payload)
    return path


def ply_claiming(path: Path, fmt: str, count: int, body: bytes, extra: str = "") -> Path:
    header = (
        f"ply\nformat {fmt} 1.0\nelement vertex {count}\nproperty float x\nproperty float y\n"
        f"property float z\n{extra}end_header\n"
    )
    path.write_bytes(header.encode() + body)
    return path


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda d: npy_claiming(d / "huge.npy", (10**6, 10**6, 3)),  # 3e12 floats
            r"declares shape \(1000000, 1000000, 3\), 12000000000000 bytes, but only 48 bytes",
        ),
        (lambda d: npy_claiming(d / "short.npy", (5, 3)), "60 bytes, but only 48 bytes"),
        (lambda d: npy_claiming(d / "negative.npy", (-4, 3)), r"got \(-4, 3\)"),
        (
            lambda d: ply_claiming(d / "huge.ply", "binary_little_endian", 10**10, bytes(36)),
            "declares 10000000000 vertex records, which need at least 120000000000 bytes",
        ),
        (
            lambda d: ply_claiming(d / "huge-ascii.ply", "ascii", 10**10, b"1 2 3\n4 5 6\n"),
            "declares 10000000000 vertex records",
        ),
        (
            lambda d: ply_claiming(
                d / "faces.ply",
                "binary_little_endian",
                1,
                bytes(12),
                "element face 10000000000\nproperty list uchar int vertex_indices\n",
            ),
            "declares 10000000000 face records",
        ),
        (
            lambda d: ply_claiming(d / "endless.ply", "ascii", 1, b"", "comment " + "x" * 70_000),
            "no end_header line in its first 65536 bytes",
        ),
    ],
    ids=[
        "npy-1e12",
        "npy-short",
        "npy-negative",
        "ply-1e10",
        "ascii-ply-1e10",
        "ply-1e10-faces",
        "no-end-header",
    ],
)
def test_hostile_header_is_refused_before_anything_is_allocated(
    tmp_path: Path, make: Any, message: str
) -> None:
    path = make(tmp_path)
    with pytest.raises(DetectionError, match=message) as info:
        read_cloud(path)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_ascii_ply_with_fewer_lines_than_declared(tmp_path: Path) -> None:
    # Long enough lines to pass the size check, one line short of the header.
    path = ply_claiming(tmp_path / "short.ply", "ascii", 3, b"1.000 2.000 3.000\n" * 2)
    with pytest.raises(DetectionError, match="declares 3 vertices, the file holds 2"):
        read_cloud(path)
