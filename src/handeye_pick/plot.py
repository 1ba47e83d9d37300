"""Render a pick scene to a PNG: every frame of the chain where the maths puts it.

A wrong hand-eye direction, a wrong unit or a wrong TCP is obvious in a picture and invisible in a
column of numbers. The picture shows, in the robot base frame: base, flange, current TCP, camera,
object and the approach / grasp / retreat TCP targets as labelled axis triads (x red, y green,
z blue), the straight-line TCP path through the targets, the workspace box and, when given, a
subsample of the point cloud. Three views (perspective, top, side) with equal axis scales in mm.

Rendering is headless: a bare matplotlib ``Figure`` drawn by the Agg canvas, no pyplot state.
matplotlib is imported by ``render_scene`` only: it takes about half a second, and the commands
that import this module (for ``Scene``) must start without it when they draw nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypeGuard

import numpy as np
from numpy.typing import NDArray

from handeye_pick.arm.ik import branches, wrap
from handeye_pick.arm.kinematics import link_poses
from handeye_pick.arm.models import ArmModel
from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from mpl_toolkits.mplot3d.axes3d import Axes3D

FIGURE_SIZE_IN = (18.0, 7.0)
FIGURE_DPI = 100
FIGURE_SIZE_PX = (1800, 700)
"""Width and height of every rendered PNG in pixels (FIGURE_SIZE_IN times FIGURE_DPI)."""

MAX_CLOUD_POINTS = 4000
"""Cloud points drawn at most: enough to see the surface, few enough to render in a second."""

_AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
_TRIAD_FRACTION = 0.06  # triad length as a fraction of the scene's largest extent
_M_TO_MM = 1000.0
_SAME_PLACE_MM = 5.0  # frame origins closer than this on a view share one label
# Labels on the 2D views, in axes fractions of a view about 500 px across (FIGURE_SIZE_PX).
_LABEL_FONT_PT = 8
_LABEL_CHAR_WIDTH = 0.012  # an 8 pt character is about 5.5 px wide
_LABEL_LINE = 0.03  # one 8 pt line and a little air
_LABEL_GAP = 0.01  # between an origin and its label


@dataclass(frozen=True, eq=False)
class Scene:
    """Everything one picture shows. Poses are float64 4x4 in the robot base frame, metres.

    ``tcp_path`` lists the TCP targets (``T_base_tcp``) in the order the arm visits them, e.g.
    ``(("approach", T), ("grasp", T), ("retreat", T))``; the path is drawn from ``T_base_tcp``
    (the TCP now) through them in straight lines, as moveL travels.
    """

    mode: str  # hand-eye mode, for the caption
    calibration_file: Path  # for the caption
    T_base_flange: Transform
    T_base_tcp: Transform
    T_base_cam: Transform
    T_base_obj: Transform
    tcp_path: tuple[tuple[str, Transform], ...]
    workspace_min_m: tuple[float, float, float]
    workspace_max_m: tuple[float, float, float]
    cloud_base_m: NDArray[np.float64] | None = None  # (N, 3) points in base, metres
    # The scene's boxes (bin walls and floors, fixtures) as (label, edge lengths m, T_base_box
    # of the box's centre), drawn as grey outlines (docs/scene.md)
    obstacles: tuple[tuple[str, NDArray[np.float64], Transform], ...] = ()
    # The arm's link solids at the plan's stops (``arm_at``): each solid's axis segment (2, 3)
    # in base, metres, drawn in blue; ``arm_source`` says in the caption where the joints came
    # from
    arm: tuple[NDArray[np.float64], ...] = ()
    arm_source: str = ""


ARM_HOME_RAD = (0.0, -np.pi / 2.0, np.pi / 2.0, -np.pi / 2.0, -np.pi / 2.0, 0.0)
"""A typical home of a UR arm (rad): upper arm up, forearm level, elbow up, wrist down. Drawn
offline, the arm takes the branch of the model's IK nearest it at every stop."""


def arm_at(model: ArmModel, T_base_flange: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """The axis segments (2, 3) in base, metres, of every link solid of ``model`` at each
    flange pose of ``T_base_flange`` (N, 4, 4, m), on the branch of the model's IK nearest
    ``ARM_HOME_RAD`` (elbow up, wrist down near a typical home); a pose no branch reaches is
    left out."""
    solved = branches(model, T_base_flange).q  # (N, 8, 6)
    gaps = np.abs(wrap(solved - np.array(ARM_HOME_RAD))).max(axis=2)
    reached = ~np.all(np.isnan(gaps), axis=1)
    if not reached.any():
        return ()
    nearest = np.nanargmin(np.where(np.isnan(gaps[reached]), np.inf, gaps[reached]), axis=1)
    q = solved[reached][np.arange(int(reached.sum())), nearest]
    poses = link_poses(model, q)  # (N, L, 4, 4)
    half = np.array([link.length_m / 2.0 for link in model.links])[None, :, None]
    centre, along = poses[..., :3, 3], poses[..., :3, 2]
    ends = np.stack([centre - half * along, centre + half * along], axis=2)  # (N, L, 2, 3)
    return tuple(ends.reshape(-1, 2, 3))


def scene_frames(scene: Scene) -> list[tuple[str, Transform]]:
    """The labelled frames the renderer draws, in drawing order (``T_base_<label>``, metres)."""
    frames: list[tuple[str, Transform]] = [
        ("base", np.eye(4)),
        ("flange", scene.T_base_flange),
        ("tcp", scene.T_base_tcp),
        ("camera", scene.T_base_cam),
        ("object", scene.T_base_obj),
    ]
    frames.extend(scene.tcp_path)
    return frames


def cloud_to_base_m(
    xyz_mm: NDArray[np.floating], T_base_cam: Transform, max_points: int = MAX_CLOUD_POINTS
) -> NDArray[np.float64]:
    """A subsample of a camera-frame cloud (mm, any shape (..., 3), NaN = no data) in the base
    frame, metres, shape (N, 3) with N <= ``max_points``; points without data are dropped.

    Every k-th point is taken before the missing ones are dropped (a 5 MP cloud is never scanned
    in full), so the same cloud always gives the same picture.
    """
    points = np.asarray(xyz_mm).reshape(-1, 3)
    step = max(1, -(-len(points) // max_points))  # ceil division
    sample = points[::step]
    sample_m = sample[np.all(np.isfinite(sample), axis=1)].astype(np.float64) / _M_TO_MM
    out: NDArray[np.float64] = sample_m @ T_base_cam[:3, :3].T + T_base_cam[:3, 3]
    return out


def view_cube(scene: Scene) -> tuple[NDArray[np.float64], float]:
    """The cube every view shows (centre in base mm, half its edge in mm): the frames, the TCP
    path, the scene's boxes and the cloud with a margin, at least 100 mm either way.

    The workspace box does not size the views: a 1.6 m workspace would shrink a pick's frames
    to one smear. Its edges are drawn where they fall inside the cube, and the caption gives its
    bounds."""
    points = [T[:3, 3] * _M_TO_MM for _, T in scene_frames(scene)]
    points += [corner for edges in _obstacle_edges(scene) for edge in edges for corner in edge]
    cloud = scene.cloud_base_m
    if cloud is not None and len(cloud) > 0:
        points += [cloud.min(axis=0) * _M_TO_MM, cloud.max(axis=0) * _M_TO_MM]
    lo, hi = np.min(points, axis=0), np.max(points, axis=0)
    return (lo + hi) / 2.0, max(float(np.max(hi - lo)) / 2.0 * 1.15, 100.0)


def caption(scene: Scene) -> str:
    """The line over the picture: mode, calibration, frame and units, and what each colour is."""
    lo = np.array(scene.workspace_min_m) * _M_TO_MM
    hi = np.array(scene.workspace_max_m) * _M_TO_MM
    workspace = ", ".join(f"{'xyz'[i]} {lo[i]:.0f}..{hi[i]:.0f}" for i in range(3))
    parts = [
        scene.mode,
        f"calibration: {scene.calibration_file}",
        "robot base frame, mm; axes x red, y green, z blue; dashed: TCP path; "
        f"orange: workspace ({workspace})" + ("; grey: scene" if scene.obstacles else ""),
    ]
    if scene.arm:
        parts.append(f"blue: the arm's links at the stops, {scene.arm_source}")
    return "  |  ".join(parts)


def render_scene(scene: Scene, path: Path) -> dict[str, NDArray[np.float64]]:
    """Write the scene as a PNG of ``FIGURE_SIZE_PX`` to ``path``.

    Returns the origin of every labelled frame as drawn (base frame, mm), keyed by label, so a
    caller or a test can see where the picture puts each frame. Raises InputError when the PNG
    cannot be written.
    """
    frames = scene_frames(scene)
    origins_mm = {label: T[:3, 3] * _M_TO_MM for label, T in frames}
    path_mm = np.array([scene.T_base_tcp[:3, 3]] + [T[:3, 3] for _, T in scene.tcp_path]) * _M_TO_MM
    cloud_mm = None if scene.cloud_base_m is None else scene.cloud_base_m * _M_TO_MM
    centre, half = view_cube(scene)
    cube = (centre - half, centre + half)
    workspace_edges = _box_edges(
        np.array(scene.workspace_min_m) * _M_TO_MM, np.array(scene.workspace_max_m) * _M_TO_MM
    )
    obstacle_edges = _obstacle_edges(scene)
    triad_mm = 2.0 * half * _TRIAD_FRACTION

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=FIGURE_SIZE_IN, dpi=FIGURE_DPI, layout="constrained")
    FigureCanvasAgg(fig)
    persp = fig.add_subplot(1, 3, 1, projection="3d")
    persp.set_proj_type("persp")
    persp.set_box_aspect((1.0, 1.0, 1.0))
    persp.set_zlabel("z (mm)")
    persp.set_zlim(centre[2] - half, centre[2] + half)
    # Top view looks down base z (x right, y up); side view looks along base y (x right, z up).
    views: list[tuple[Axes, tuple[int, ...], str]] = [
        (persp, (0, 1, 2), "perspective"),
        (fig.add_subplot(1, 3, 2), (0, 1), "top (x, y)"),
        (fig.add_subplot(1, 3, 3), (0, 2), "side (x, z)"),
    ]
    for ax, dims, title in views:
        ax.set_title(title)
        ax.set_xlabel(f"{'xyz'[dims[0]]} (mm)")
        ax.set_ylabel(f"{'xyz'[dims[1]]} (mm)")
        ax.set_xlim(centre[dims[0]] - half, centre[dims[0]] + half)
        ax.set_ylim(centre[dims[1]] - half, centre[dims[1]] + half)
        if len(dims) == 2:
            ax.set_aspect("equal")
            ax.grid(True, linewidth=0.3)
        d = list(dims)
        # A 2D view clips what lies outside it; the 3D view does not, so its lines are cut.
        three_d = len(dims) == 3
        for a, b in _clipped(workspace_edges, *cube) if three_d else workspace_edges:
            ax.plot(*np.stack([a[d], b[d]]).T, color="tab:orange", linewidth=0.8)
        for edges in obstacle_edges:
            for a, b in _clipped(edges, *cube) if three_d else edges:
                ax.plot(*np.stack([a[d], b[d]]).T, color="tab:gray", linewidth=0.8)
        for segment in scene.arm:
            ax.plot(*(segment * _M_TO_MM)[:, d].T, color="tab:blue", linewidth=5, alpha=0.35)
        if cloud_mm is not None:
            _scatter(ax, cloud_mm, d)
        ax.plot(*path_mm[:, d].T, "k--", linewidth=1)
        for _, T in frames:
            origin = T[:3, 3] * _M_TO_MM
            for axis, colour in enumerate(_AXIS_COLOURS):
                tip = origin + T[:3, axis] * triad_mm
                ax.plot(*np.stack([origin[d], tip[d]]).T, color=colour, linewidth=2)
        labels = _merged_labels(origins_mm, d)
        if _is_3d(ax):
            for label, origin in labels:
                ax.text(origin[0], origin[1], origin[2], f" {label}", fontsize=8)
        else:
            _spread_labels(ax, labels, d, centre, half)

    fig.suptitle(caption(scene), fontsize=10)
    try:
        fig.savefig(path, format="png")
    except OSError as exc:
        raise InputError(f"writing the scene picture {path}: {exc.strerror or exc}") from None
    return origins_mm


def label_places(anchors: NDArray[np.float64], labels: list[str]) -> list[tuple[float, float]]:
    """Where each label's text goes on a 2D view (axes fractions, 0..1 across), so that no two
    overlap: each starts just right of its anchor and, where it would cover a label already
    placed, moves below the lowest one it covers (top labels are placed first). ``anchors`` are
    (N, 2) in axes fractions; a text's box is estimated from its length at ``_LABEL_FONT_PT``."""
    placed: list[tuple[float, float, float]] = []  # left, middle height, width
    places: list[tuple[float, float]] = [(0.0, 0.0)] * len(labels)
    for index in sorted(range(len(labels)), key=lambda i: -anchors[i][1]):
        left = float(anchors[index][0]) + _LABEL_GAP
        width = len(labels[index]) * _LABEL_CHAR_WIDTH
        height = float(anchors[index][1])
        while covered := [
            other_height
            for other_left, other_height, other_width in placed
            if left < other_left + other_width
            and other_left < left + width
            # less a hair, so a label moved exactly one line down is clear of it
            and abs(height - other_height) < _LABEL_LINE - 1e-9
        ]:
            height = min(covered) - _LABEL_LINE
        placed.append((left, height, width))
        places[index] = (left, height)
    return places


def _spread_labels(
    ax: Axes,
    labels: list[tuple[str, NDArray[np.float64]]],
    dims: list[int],
    centre: NDArray[np.float64],
    half: float,
) -> None:
    """The frames' names on a 2D view, each beside its origin or, where names would cover each
    other, moved down with a thin line back to the origin."""
    low = centre[dims] - half
    anchors = np.array([(origin[dims] - low) / (2.0 * half) for _, origin in labels])
    for (label, origin), (x, y) in zip(
        labels, label_places(anchors, [n for n, _ in labels]), strict=True
    ):
        moved = abs(y - float((origin[dims[1]] - low[1]) / (2.0 * half))) > 1e-9
        ax.annotate(
            label,
            (origin[dims[0]], origin[dims[1]]),
            xytext=(x, y),
            textcoords="axes fraction",
            fontsize=_LABEL_FONT_PT,
            va="center",
            arrowprops={"arrowstyle": "-", "color": "0.5", "linewidth": 0.5} if moved else None,
        )


def _merged_labels(
    origins_mm: dict[str, NDArray[np.float64]], dims: list[int]
) -> list[tuple[str, NDArray[np.float64]]]:
    """One label per place on a view: frames whose origins coincide there (object and grasp,
    approach and retreat; flange and TCP seen from above) share a label such as "object, grasp"
    instead of printing over each other."""
    merged: list[tuple[list[str], NDArray[np.float64]]] = []
    for label, origin in origins_mm.items():
        for names, where in merged:
            if np.linalg.norm(where[dims] - origin[dims]) < _SAME_PLACE_MM:
                names.append(label)
                break
        else:
            merged.append(([label], origin))
    return [(", ".join(names), where) for names, where in merged]


def _scatter(ax: Axes, points_mm: NDArray[np.float64], dims: list[int]) -> None:
    """Cloud points on one view, shaded by height (darker is higher) so objects stand out from
    the table in the top view, and grey so the coloured triads stay readable."""
    z = points_mm[:, 2]
    # Start the grey ramp below the lowest point so the table is light grey, not white.
    low = float(z.min()) - 0.3 * max(float(np.ptp(z)), 1.0) if len(z) else 0.0
    if _is_3d(ax):
        ax.scatter(*points_mm.T, s=3, c=z, cmap="Greys", vmin=low, alpha=0.6)
    else:
        ax.scatter(
            points_mm[:, dims[0]],
            points_mm[:, dims[1]],
            s=3,
            c=z,
            cmap="Greys",
            vmin=low,
            alpha=0.6,
        )


def _is_3d(ax: Axes) -> TypeGuard[Axes3D]:
    from mpl_toolkits.mplot3d.axes3d import Axes3D  # loaded already by render_scene

    return isinstance(ax, Axes3D)


def _box_edges(
    lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The 12 edges of an axis-aligned box as pairs of corner points."""
    corners = [
        np.array([x, y, z]) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])
    ]
    # Two corners share an edge when they differ in exactly one coordinate.
    return [
        (a, b)
        for k, a in enumerate(corners)
        for b in corners[k + 1 :]
        if np.count_nonzero(a != b) == 1
    ]


def _obstacle_edges(
    scene: Scene,
) -> list[list[tuple[NDArray[np.float64], NDArray[np.float64]]]]:
    """Each scene box's 12 edges in base mm."""
    return [_oriented_box_edges(size, T) for _, size, T in scene.obstacles]


def _clipped(
    edges: list[tuple[NDArray[np.float64], NDArray[np.float64]]],
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The parts of ``edges`` inside the box ``lo``..``hi`` (mm): the 3D view does not clip
    what is drawn outside its limits, so lines are cut before they are drawn."""
    kept = []
    for a, b in edges:
        start, end = 0.0, 1.0
        step = b - a
        for axis in range(3):
            if abs(step[axis]) < 1e-12:
                if not lo[axis] <= a[axis] <= hi[axis]:
                    start, end = 1.0, 0.0
                continue
            t0, t1 = sorted(((lo[axis] - a[axis]) / step[axis], (hi[axis] - a[axis]) / step[axis]))
            start, end = max(start, t0), min(end, t1)
        if start < end:
            kept.append((a + start * step, a + end * step))
    return kept


def _oriented_box_edges(
    size_m: NDArray[np.float64], T_base_box: Transform
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The 12 edges of a box of ``size_m`` centred at ``T_base_box`` (m), in base mm."""
    half = np.asarray(size_m) / 2.0
    return [
        (
            (T_base_box[:3, :3] @ a + T_base_box[:3, 3]) * _M_TO_MM,
            (T_base_box[:3, :3] @ b + T_base_box[:3, 3]) * _M_TO_MM,
        )
        for a, b in _box_edges(-half, half)
    ]
