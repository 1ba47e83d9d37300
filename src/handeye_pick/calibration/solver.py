"""Hand-eye calibration: OpenCV's closed-form starts, a weighted least-squares fit over every
pair, residuals per pair, and suspect pairs.

The model. Pair N holds the robot pose ``T_base_flange_N`` and the calibration object's pose in
the camera frame ``T_cam_obj_N``. One rigid chain closes for every pair:

- eye-in-hand (camera on the flange, object fixed in the cell):
  ``T_base_flange_N @ T_flange_cam @ T_cam_obj_N = T_base_obj``
- eye-to-hand (camera fixed in the cell, object on the flange):
  ``inv(T_base_flange_N) @ T_base_cam @ T_cam_obj_N = T_flange_obj``

Both read ``A_N @ X @ B_N = Y``: ``X`` is the result (``T_flange_cam`` or ``T_base_cam``), ``Y``
the object's pose where it is fixed (``T_base_obj`` or ``T_flange_obj``), ``A_N`` the robot side
and ``B_N = T_cam_obj_N``. OpenCV's ``calibrateHandEye`` takes the same ``A_N`` as
"gripper2base" (for eye-to-hand the inverted robot pose, "base2gripper", as its documentation
says), ``B_N`` as "target2cam", and returns ``X`` as "cam2gripper".

The fit. Every OpenCV method gives a start (``OPENCV_METHODS``); the start whose chains close
best (least weighted cost below) is refined by nonlinear least squares over ``X`` and ``Y``
jointly, over every pair. Each pair contributes six residuals of ``A_N X B_N`` against ``Y``,
weighted by the errors the stated ``MeasurementNoise`` predicts for them:

- rotation (3, rad): the rotation vector of ``R_Y^T R_N``, in the object's frame;
- translation (3, m): the object's origin through the chain minus ``Y``'s.

The six are whitened together by the 6x6 covariance the noise model predicts for that pair
(``_Problem._whitening``): the robot's translation and rotation errors, the latter acting
through the object's distance from the flange, and the camera's lateral, depth and rotation
errors, propagated through the chain. One robot rotation error moves both the rotation and the
translation residual, and the covariance keeps that correlation.

A fit over every pair, rather than OpenCV's differences between poses, weighs each measurement
once and does not depend on the order of the pairs. The residual reported for a pair is the
same comparison in edge units: the angle (deg) and distance (mm) between the object's pose
through that pair's chain and the consensus ``Y``.

Suspects. A pair is a suspect when its residual stands out against a robust refit (scipy's
Cauchy loss, scale ``ROBUST_SCALE`` times the noise level the plain fit shows, so that one wrong
pair cannot drag the consensus toward itself). The noise level is the median absolute weighted
residual of the plain fit over 0.6745 (1 when the data match the stated noise, never less).
A pair stands out when its rotation or its translation residual (the length of the whitened
rotation part, or of the whitened translation part, which is what the rotation does not
explain) exceeds both ``median + SUSPECT_MADS * 1.4826 * MAD`` of that quantity over all pairs
and ``SUSPECT_FLOOR`` times the noise level. Suspects are named and what excluding them would
give is computed; nothing is excluded unless the caller asks.

Units: metres and radians inside; millimetres and degrees only in ``PairResidual`` and
``MeasurementNoise`` (the edges). cv2 and scipy.optimize are imported where they are used.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from handeye_pick.calibration.dataset import HandEyePair
from handeye_pick.calibration.rotation_spread import check_motion, motion_spread
from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import Transform, invert, make_transform, rotation_angle_between
from handeye_pick.hand_eye.files import HandEyeMode

MIN_PAIRS = 4
"""Fewest pairs accepted: 3 determine the transform, a 4th is the least that shows an error."""
RECOMMENDED_PAIRS = 10
"""Warn below this (OpenCV and Zivid recommend 10 to 20 poses)."""
OPENCV_METHODS = ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")
"""calibrateHandEye's methods, as named by cv2.CALIB_HAND_EYE_<NAME>."""
SUSPECT_MADS = 5.0
"""Robust z-score above which a residual stands out (Iglewicz and Hoaglin suggest 3.5; 5 keeps
false flags near zero on clean data even when the stated noise is 3 times too small)."""
SUSPECT_FLOOR = 5.0
"""A residual of at most this many standard deviations (of the noise level the data shows) is
never a suspect: without it, data whose residuals are all tiny would flag the largest."""
ROBUST_SCALE = 3.0
"""Cauchy loss scale of the suspect search, in units of the plain fit's noise level."""

Stack = NDArray[np.float64]
"""N x 4 x 4 transforms, one per pair, metres."""
_STEP = 1e-6
"""Finite-difference step (m, rad) for propagating the measurement errors."""


def _Rotation() -> Any:  # scipy has no type information
    """scipy's Rotation, imported on first use: the CLI must start without scipy."""
    from scipy.spatial.transform import Rotation

    return Rotation


@dataclass(frozen=True)
class MeasurementNoise:
    """Standard deviation per axis of the pose errors the fit expects (edge units: mm, deg).

    ``camera_*``: the detector's error in ``T_cam_obj``: the object's origin across the view
    (camera x and y), along the optical axis (camera z; 3D cameras measure depth less precisely
    than position across the image), and its rotation about that origin. ``robot_*``: the error
    of ``T_base_flange`` as the controller reports it (the flange's origin, and its rotation about
    it). The defaults are assumed figures for a Zivid-class 3D camera measuring its calibration
    board at 0.3 to 1 m and a UR e-Series arm (pose error of its calibrated kinematics about
    0.1 mm and 0.01 deg; its repeatability is 0.03 mm). Give a cell's own figures where known.
    """

    camera_lateral_mm: float = 0.1
    camera_depth_mm: float = 0.3
    camera_rotation_deg: float = 0.02
    robot_translation_mm: float = 0.1
    robot_rotation_deg: float = 0.01

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value > 0.0):
                raise CalibrationError(f"measurement noise {name} must be > 0, got {value}")


@dataclass(frozen=True)
class PairResidual:
    """How far pair ``number``'s chain puts the object from the consensus (mm, deg)."""

    number: int
    translation_mm: float
    rotation_deg: float


@dataclass(frozen=True, eq=False)
class HandEyeFit:
    """A weighted least-squares fit over the pairs in ``residuals`` (metres)."""

    T_cal: Transform  # X: T_flange_cam (eye-in-hand) or T_base_cam (eye-to-hand)
    T_fixed_obj: Transform  # Y: T_base_obj (eye-in-hand) or T_flange_obj (eye-to-hand)
    residuals: tuple[PairResidual, ...]

    @property
    def translation_mean_mm(self) -> float:
        return float(np.mean([r.translation_mm for r in self.residuals]))

    @property
    def translation_max_mm(self) -> float:
        return max(r.translation_mm for r in self.residuals)

    @property
    def rotation_mean_deg(self) -> float:
        return float(np.mean([r.rotation_deg for r in self.residuals]))

    @property
    def rotation_max_deg(self) -> float:
        return max(r.rotation_deg for r in self.residuals)


@dataclass(frozen=True, eq=False)
class HandEyeResult:
    """What ``solve_hand_eye`` found, with everything needed to judge it."""

    mode: HandEyeMode
    fit: HandEyeFit  # the result: every pair except ``excluded``
    start_method: str  # the OpenCV method whose result started the refinement
    excluded: tuple[int, ...]  # pair numbers the caller excluded
    suspects: tuple[int, ...]  # pair numbers whose residual stands out
    without_suspects: HandEyeFit | None  # the fit without the suspects, when it can be made
    without_suspects_refusal: str | None  # why it cannot, when there are suspects
    warnings: tuple[str, ...]
    noise: MeasurementNoise


def robot_side(T_base_flange: Stack, mode: HandEyeMode) -> Stack:
    """``A_N`` of the chain: ``T_base_flange`` eye-in-hand, ``T_flange_base`` eye-to-hand."""
    if mode is HandEyeMode.EYE_IN_HAND:
        return T_base_flange
    return np.stack([invert(T) for T in T_base_flange])


def solve_hand_eye(
    pairs: Sequence[HandEyePair],
    mode: HandEyeMode,
    *,
    exclude: Collection[int] = (),
    noise: MeasurementNoise | None = None,
) -> HandEyeResult:
    """Calibrate from ``pairs`` without the pair numbers in ``exclude``.

    Raises ``CalibrationError`` (exit 2) for an unknown number in ``exclude``, fewer than
    ``MIN_PAIRS`` pairs, degenerate motion (``rotation_spread.check_motion``), or when no OpenCV
    method gives a start.
    """
    noise = noise if noise is not None else MeasurementNoise()
    known = {pair.number for pair in pairs}
    unknown = sorted(set(exclude) - known)
    if unknown:
        raise CalibrationError(
            f"cannot exclude pair(s) {_numbers_text(unknown)}: the dataset has "
            f"{_numbers_text(sorted(known))}"
        )
    problem = _Problem.of(pairs, mode, set(exclude))
    start_method, fit = problem.solve(noise)
    suspects = problem.suspects(fit, noise)
    without: HandEyeFit | None = None
    refusal: str | None = None
    if suspects:
        try:
            _, without = _Problem.of(pairs, mode, set(exclude) | set(suspects)).solve(noise)
        except CalibrationError as exc:
            refusal = str(exc)
    return HandEyeResult(
        mode=mode,
        fit=fit,
        start_method=start_method,
        excluded=tuple(sorted(exclude)),
        suspects=suspects,
        without_suspects=without,
        without_suspects_refusal=refusal,
        warnings=problem.warnings,
        noise=noise,
    )


def opencv_hand_eye(A: Stack, B: Stack, method: str) -> Transform:
    """``X`` from OpenCV's ``calibrateHandEye`` with one method (a name of OPENCV_METHODS).

    ``A`` goes in as gripper2base, ``B`` as target2cam (see the module docstring). ``method``
    is passed by keyword: a fifth positional argument is an output array, which would silently
    run TSAI. The rotation is returned as OpenCV gives it (some methods' are not quite
    orthonormal). Raises ``CalibrationError`` when OpenCV fails or returns a non-finite matrix
    or a reflection.
    """
    import cv2  # heavy; only calibrate needs it

    try:
        R, t = cv2.calibrateHandEye(
            R_gripper2base=list(A[:, :3, :3]),
            t_gripper2base=list(A[:, :3, 3:]),
            R_target2cam=list(B[:, :3, :3]),
            t_target2cam=list(B[:, :3, 3:]),
            method=getattr(cv2, f"CALIB_HAND_EYE_{method}"),
        )
    except cv2.error as exc:
        raise CalibrationError(f"OpenCV {method} failed: {' '.join(str(exc).split())}") from None
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64).reshape(3)
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
        raise CalibrationError(f"OpenCV {method} returned a non-finite transform")
    # On bad data some methods return a reflection, which no rotation is near.
    det = float(np.linalg.det(R))
    if det <= 0.0:
        raise CalibrationError(f"OpenCV {method} returned no rotation (determinant {det:.3g})")
    return make_transform(R, t)


# --- the problem ----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Problem:
    """The chains ``A_N @ X @ B_N = Y`` of the pairs in use, checked for enough motion."""

    mode: HandEyeMode
    numbers: tuple[int, ...]
    A: Stack  # robot side per pair (robot_side)
    B: Stack  # T_cam_obj per pair
    warnings: tuple[str, ...]  # weak data: few pairs, small or near-parallel rotations

    @classmethod
    def of(cls, pairs: Sequence[HandEyePair], mode: HandEyeMode, exclude: set[int]) -> _Problem:
        """The pairs not in ``exclude``; refuses too few pairs and degenerate motion."""
        used = [pair for pair in pairs if pair.number not in exclude]
        after = f" after excluding {len(exclude)}" if exclude else ""
        if len(used) < MIN_PAIRS:
            raise CalibrationError(
                f"a hand-eye calibration needs at least {MIN_PAIRS} pairs, {len(used)} left{after}"
            )
        warnings = []
        if len(used) < RECOMMENDED_PAIRS:
            warnings.append(
                f"only {len(used)} pairs{after}: {RECOMMENDED_PAIRS} to 20 make the result and "
                "the suspect search reliable"
            )
        numbers = tuple(pair.number for pair in used)
        A = robot_side(np.stack([pair.T_base_flange for pair in used]), mode)
        warnings += check_motion(motion_spread(A[:, :3, :3], numbers))
        B = np.stack([pair.T_cam_obj for pair in used])
        return cls(mode, numbers, A, B, tuple(warnings))

    def solve(self, noise: MeasurementNoise) -> tuple[str, HandEyeFit]:
        """The plain least-squares fit from the best OpenCV start, and that start's method."""
        start_method, X0 = self._best_start(noise)
        return start_method, self._fit(X0, noise)

    def suspects(self, fit: HandEyeFit, noise: MeasurementNoise) -> tuple[int, ...]:
        """Pair numbers whose residual stands out against a robust refit (module docstring)."""
        plain = self._weighted(fit.T_cal, fit.T_fixed_obj, noise)
        # The noise level the data shows, in units of the stated noise (the median absolute
        # value of a normal variable is 0.6745 sigma), never below the stated noise.
        level = max(1.0, float(np.median(np.abs(plain))) / 0.6745)
        robust = self._fit(fit.T_cal, noise, robust_scale=ROBUST_SCALE * level)
        scores = self._weighted(robust.T_cal, robust.T_fixed_obj, noise).reshape(-1, 2, 3)
        floor = SUSPECT_FLOOR * level
        rotation = _stands_out(np.linalg.norm(scores[:, 0], axis=1), floor)
        translation = _stands_out(np.linalg.norm(scores[:, 1], axis=1), floor)
        flagged = rotation | translation
        return tuple(n for n, bad in zip(self.numbers, flagged, strict=True) if bad)

    def _best_start(self, noise: MeasurementNoise) -> tuple[str, Transform]:
        """The OpenCV start whose chain closes best (least weighted cost), and its method."""
        costs: dict[str, tuple[float, Transform]] = {}
        failures = []
        for method in OPENCV_METHODS:
            try:
                X = _nearest_rigid(opencv_hand_eye(self.A, self.B, method))
            except CalibrationError as exc:
                failures.append(str(exc))
                continue
            residuals = self._weighted(X, self._consensus(X), noise)
            costs[method] = (float(residuals @ residuals), X)
        if not costs:
            raise CalibrationError("no closed-form start: " + "; ".join(failures))
        best = min(costs, key=lambda name: costs[name][0])
        return best, costs[best][1]

    def _fit(
        self, X0: Transform, noise: MeasurementNoise, robust_scale: float | None = None
    ) -> HandEyeFit:
        """Least squares over X and Y from ``X0``; Cauchy loss with ``robust_scale`` if given."""
        from scipy.optimize import least_squares  # heavy; only calibrate needs it

        Y0 = self._consensus(X0)
        fun = self._residual_function(X0, Y0, noise)
        loss, scale = ("linear", 1.0) if robust_scale is None else ("cauchy", robust_scale)
        solution = least_squares(fun, np.zeros(12), x_scale="jac", loss=loss, f_scale=scale)
        X, Y = _apply(solution.x, X0, Y0)
        return HandEyeFit(T_cal=X, T_fixed_obj=Y, residuals=self._pair_residuals(X, Y))

    def _residual_function(
        self, X0: Transform, Y0: Transform, noise: MeasurementNoise
    ) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
        """Whitened residuals (6 per pair) as a function of the 12 corrections to ``X0`` and
        ``Y0``. The weights come from ``X0`` and stay fixed, so the cost is one function to
        minimise."""
        whiten = self._whitening(X0, noise)
        A, B = self.A, self.B

        def residuals(params: NDArray[np.float64]) -> NDArray[np.float64]:
            X, Y = _apply(params, X0, Y0)
            whitened: NDArray[np.float64] = np.einsum(
                "nij,nj->ni", whiten, _raw_residuals(A, X, B, Y)
            )
            return whitened.ravel()

        return residuals

    def _whitening(self, X: Transform, noise: MeasurementNoise) -> Stack:
        """Per pair, the 6x6 ``W`` with ``W @ C @ W.T = I`` for the covariance ``C`` of the
        pair's raw residuals (rotation, then translation) that the noise model predicts.

        ``C`` propagates each error source through the chain to first order (central
        differences): the robot's translation and rotation errors of ``T_base_flange`` (in the
        flange frame, where they act through the object's distance from the flange) and the
        camera's lateral, depth and rotation errors of ``T_cam_obj`` (position in the camera
        frame, rotation about the object's origin). One robot rotation error moves both the
        rotation and the translation residual; ``C`` keeps that correlation. ``W`` is lower
        triangular, so a whitened pair's first three numbers depend on its rotation residual only.
        The errors are propagated around each pair's own chain, where its residual is zero, so
        the weights do not depend on how far a (possibly wrong) pair is from the consensus.
        """
        at_chain = self.A @ X @ self.B
        robot_m, robot_rad = (
            noise.robot_translation_mm * 1e-3,
            math.radians(noise.robot_rotation_deg),
        )
        lateral_m, depth_m = noise.camera_lateral_mm * 1e-3, noise.camera_depth_mm * 1e-3
        camera_rad = math.radians(noise.camera_rotation_deg)
        sources = (
            (self._perturb_robot, [robot_m] * 3 + [robot_rad] * 3),
            (self._perturb_camera, [lateral_m, lateral_m, depth_m] + [camera_rad] * 3),
        )
        columns = []
        for perturb, sigmas in sources:
            for k, sigma in enumerate(sigmas):
                step = np.zeros(6)
                step[k] = _STEP
                (A_plus, B_plus), (A_minus, B_minus) = perturb(step), perturb(-step)
                plus = _raw_residuals(A_plus, X, B_plus, at_chain)
                minus = _raw_residuals(A_minus, X, B_minus, at_chain)
                columns.append((plus - minus) / (2 * _STEP) * sigma)
        J = np.stack(columns, axis=2)  # N x 6 residuals x 12 error sources, each 1 sigma
        C = J @ J.transpose(0, 2, 1)
        return np.asarray(np.linalg.inv(np.linalg.cholesky(C)))

    def _perturb_robot(self, error: NDArray[np.float64]) -> tuple[Stack, Stack]:
        """``A`` and ``B`` with ``T_base_flange`` moved by ``error`` (m, rad), flange frame."""
        E = make_transform(_Rotation().from_rotvec(error[3:]).as_matrix(), error[:3])
        if self.mode is HandEyeMode.EYE_IN_HAND:
            return self.A @ E, self.B  # A = T_base_flange
        return invert(E) @ self.A, self.B  # A = inv(T_base_flange)

    def _perturb_camera(self, error: NDArray[np.float64]) -> tuple[Stack, Stack]:
        """``A`` and ``B`` with ``T_cam_obj`` moved by ``error``: its position in the camera frame
        (m), its rotation about the object's origin (rad)."""
        B = self.B.copy()
        B[:, :3, 3] += error[:3]
        B[:, :3, :3] = B[:, :3, :3] @ _Rotation().from_rotvec(error[3:]).as_matrix()
        return self.A, B

    def _weighted(self, X: Transform, Y: Transform, noise: MeasurementNoise) -> NDArray[np.float64]:
        """The whitened residuals at ``X`` and ``Y`` (weights from ``X``)."""
        return self._residual_function(X, Y, noise)(np.zeros(12))

    def _consensus(self, X: Transform) -> Transform:
        """Mean of the object's poses through every chain: the start for ``Y``."""
        chain = self.A @ X @ self.B
        R = _Rotation().from_matrix(chain[:, :3, :3]).mean().as_matrix()
        return make_transform(R, chain[:, :3, 3].mean(axis=0))

    def _pair_residuals(self, X: Transform, Y: Transform) -> tuple[PairResidual, ...]:
        chain = self.A @ X @ self.B
        return tuple(
            PairResidual(
                number=number,
                translation_mm=float(np.linalg.norm(chain[i, :3, 3] - Y[:3, 3])) * 1e3,
                rotation_deg=math.degrees(rotation_angle_between(Y[:3, :3], chain[i, :3, :3])),
            )
            for i, number in enumerate(self.numbers)
        )


def _raw_residuals(A: Stack, X: Transform, B: Stack, Y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per pair, the object's pose through the chain against ``Y`` (one 4x4, or one per pair):
    the rotation vector of ``R_Y^T R_chain`` (rad, object frame), then the translation
    difference (m, Y's frame)."""
    chain = A @ X @ B
    R_Y_T = np.swapaxes(Y[..., :3, :3], -1, -2)
    rotation = _Rotation().from_matrix(R_Y_T @ chain[:, :3, :3]).as_rotvec()
    return np.concatenate([rotation, chain[:, :3, 3] - Y[..., :3, 3]], axis=1)


def _apply(
    params: NDArray[np.float64], X0: Transform, Y0: Transform
) -> tuple[Transform, Transform]:
    """X and Y corrected by ``params``: rotation vectors applied on the right, translations
    added (m)."""
    dX = _Rotation().from_rotvec(params[0:3]).as_matrix()
    dY = _Rotation().from_rotvec(params[6:9]).as_matrix()
    return (
        make_transform(X0[:3, :3] @ dX, X0[:3, 3] + params[3:6]),
        make_transform(Y0[:3, :3] @ dY, Y0[:3, 3] + params[9:12]),
    )


def _nearest_rigid(T: Transform) -> Transform:
    """``T`` with its rotation replaced by the nearest rotation (a start need not be exact)."""
    return make_transform(_Rotation().from_matrix(T[:3, :3]).as_matrix(), T[:3, 3])


def _stands_out(scores: NDArray[np.float64], floor: float) -> NDArray[np.bool_]:
    """Scores above the median by more than SUSPECT_MADS scaled MADs, and above ``floor``."""
    median = float(np.median(scores))
    mad = float(np.median(np.abs(scores - median)))
    return np.asarray(scores > max(median + SUSPECT_MADS * 1.4826 * mad, floor))


def _numbers_text(numbers: Sequence[int]) -> str:
    return ", ".join(str(n) for n in numbers)
