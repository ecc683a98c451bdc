"""The ``sfm`` lifter: cameras and 3D points from plain RGB images, with no weights.

Structure from motion with COLMAP (extra ``sfm`` = ``pycolmap``, CPU):
SIFT features with a low ``peak_threshold`` (renders and low-texture tabletop
images give too few keypoints with COLMAP's default), exhaustive matching and
incremental mapping with a low minimum triangulation angle (narrow wrist-camera
sweeps and 3 - 20 views). Known intrinsics are used, and held fixed, when
every view has ``K``. Everything runs in a temporary folder.

Per-view depth then comes from :mod:`graphseg.backends.lifters.stereo`: dense
semi-global matching on pairs rectified with the SfM poses wherever a
neighbour view is close enough, and the triangulated SfM points elsewhere.

Scale
-----
SfM recovers the scene only up to a similarity. When every view has ``K``
and a pose, the cameras are taken as given (option ``use_poses``): the
features are triangulated with them held fixed, and the result is metric.
When every view has a pose but the cameras are estimated (no ``K``, or
``use_poses`` off), the SfM camera centres are aligned to the poses
(:func:`graphseg.backends.lifters.align.umeyama`) and the result is metric
(with 3 or more registered views). Otherwise the reconstruction is scaled so that the
median camera-to-point distance equals :data:`NOMINAL_DISTANCE` (0.6 m, a
tabletop / wrist-camera working distance), so the metre thresholds of the
config apply at about the right size. ``scene.meta["scale"]`` records
``{"metric": bool, "factor": float, "method": str}``.

Examples
--------
>>> SfmLifter().name, NOMINAL_DISTANCE
('sfm', 0.6)
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from ...parallel import parallel_map
from ...registry import require
from ...scene import Scene, SceneError
from ..options import Backend
from .align import NOMINAL_WORKING_DISTANCE, umeyama

__all__ = [
    "SfmLifter",
    "SfmReconstruction",
    "run_sfm",
    "SfmRun",
    "registration_warning",
    "NOMINAL_DISTANCE",
    "CAMERA_MODELS",
    "not_registered_message",
    "field_of_view",
    "focal_length",
    "focal_plausible",
    "prior_intrinsics",
    "focal_check_warning",
    "stereo_outliers",
    "stereo_check_warning",
    "choose_start",
    "STEREO_CHECK",
    "STEREO_CHECK_FLOOR",
    "FOCAL_STARTS",
    "START_MIN_OBSERVATIONS",
    "MIN_SPAN",
    "camera_span",
    "short_baseline_warning",
    "short_baseline_refusal",
]

#: Default share of the other views' median dense-stereo coverage below which a view's pose is taken as wrong.
STEREO_CHECK = 0.2

#: Fields of view (degrees across the larger image side) worth trying as focal-length starts beside
#: COLMAP's prior (1.2 x the larger side, about 45 degrees) for a wider camera (:func:`run_sfm`'s and
#: the ``sfm`` lifter's ``focal_starts``, off by default: measured in ``docs/results.md``, round 25).
FOCAL_STARTS = (60.0, 70.0)

#: A start's model is a candidate only if it holds at least this share of the most observations
#: (2D points in a track) among the models with the most views (:func:`choose_start`).
START_MIN_OBSERVATIONS = 0.8

#: The other views' median coverage below which the stereo check says nothing (stereo fails everywhere).
STEREO_CHECK_FLOOR = 0.05

#: Degrees: cameras spread over less than this, as seen from the scene, give stereo and
#: triangulation too little parallax (YCB-Video's 1 cm at 1.2 m is 0.5): the lifter refuses
#: such views (option ``min_span``; with ``min_span`` 0 it only warns).
MIN_SPAN = 2.0

#: COLMAP camera models the ``sfm`` lifter may estimate (one camera shared by all views).
CAMERA_MODELS = ("SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV")

#: Median camera-to-point distance (m) a reconstruction of unknown scale is scaled to.
NOMINAL_DISTANCE = NOMINAL_WORKING_DISTANCE  # the one documented normalisation of every lifter (align.py)


@dataclass
class SfmReconstruction:
    """What :func:`run_sfm` recovered, in graphseg conventions (OpenCV axes, pixel centres at integers).

    Attributes
    ----------
    registered : bool ``[N]``
    K : list of float64 ``[3, 3]`` (None where not registered)
    dist : list of float64 ``[k]`` OpenCV distortion coefficients (None where not registered)
    cam_to_world : list of float64 ``[4, 4]`` (None where not registered)
    points : float64 ``[P, 3]`` triangulated points
    observations : list of (float64 ``[M, 2]`` pixel xy, int64 ``[M]`` index into ``points``) per view
    reprojection_error : float
        Mean reprojection error in pixels.
    """

    registered: np.ndarray
    K: list[np.ndarray | None]
    dist: list[np.ndarray | None]
    cam_to_world: list[np.ndarray | None]
    points: np.ndarray
    observations: list[tuple[np.ndarray, np.ndarray]]
    reprojection_error: float = float("nan")
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def num_registered(self) -> int:
        return int(np.count_nonzero(self.registered))

    def select(self, indices: Any) -> SfmReconstruction:
        """The reconstruction of the views ``indices`` only (same points; a new object)."""
        idx = [int(i) for i in indices]
        return SfmReconstruction(
            self.registered[idx].copy(),
            [self.K[i] for i in idx],
            [self.dist[i] for i in idx],
            [self.cam_to_world[i] for i in idx],
            self.points,
            [self.observations[i] for i in idx],
            self.reprojection_error,
            dict(self.info),
        )

    def transformed(self, s: float, R: np.ndarray, t: np.ndarray) -> SfmReconstruction:
        """The reconstruction moved by the similarity ``x -> s R x + t`` (a new object)."""
        R = np.asarray(R, np.float64)
        poses: list[np.ndarray | None] = []
        for T in self.cam_to_world:
            if T is None:
                poses.append(None)
                continue
            U = np.eye(4)
            U[:3, :3] = R @ T[:3, :3]
            U[:3, 3] = s * R @ T[:3, 3] + t
            poses.append(U)
        pts = s * self.points @ R.T + t if len(self.points) else self.points
        return SfmReconstruction(self.registered.copy(), list(self.K), list(self.dist), poses, pts, list(self.observations), self.reprojection_error, dict(self.info))


def not_registered_message(registered: int, total: int) -> str:
    """The one-line advice when SfM registers too few views.

    Examples
    --------
    >>> "registered 1 of 4 views; " in not_registered_message(1, 4)
    True
    """
    return (
        f"structure from motion registered {registered} of {total} views; every view must share texture with "
        "a neighbour: take more views with more overlap (about 10-20 degrees apart), or provide depth with "
        "intrinsics and poses (lifter rgbd)"
    )


def _colmap_options(pycolmap: Any, peak_threshold: float, min_tri_angle: float, seed: int, known_K: bool, pooling: bool = False) -> tuple[Any, Any, Any]:
    """COLMAP's options: matching and mapping single-threaded (reproducible), guided matching and low inlier minimums.

    Guided matching (matches re-searched along the epipolar lines of the
    first two-view geometry) with the minimums lowered (10 matches, 25 inliers
    for the initial pair, 10 for a new view) registered every view of the five
    tuning-half scenes of ``bench_rgb_only.py`` where COLMAP's settings here
    registered 0-7 of 3-10 (repeated stripes, checker and photo textures,
    10-view rings; ``docs/results.md``). ``pooling`` turns on SIFT's
    domain-size pooling (descriptors pooled over several patch sizes).
    """
    ext = pycolmap.FeatureExtractionOptions()
    ext.sift.peak_threshold = peak_threshold
    ext.sift.max_num_features = 8192
    ext.sift.domain_size_pooling = pooling
    ext.num_threads = 1  # :func:`_extract` raises it once the images are in the database (their ids then no longer depend on it)
    ext.use_gpu = False
    match = pycolmap.FeatureMatchingOptions()
    match.num_threads = 1  # two-view RANSAC draws from per-thread generators: one thread keeps it reproducible
    match.use_gpu = False
    match.guided_matching = True
    inc = pycolmap.IncrementalPipelineOptions()
    inc.num_threads = 1  # multi-threaded bundle adjustment changes the result from run to run
    inc.random_seed = seed
    inc.min_model_size = 2
    inc.multiple_models = False
    inc.extract_colors = False
    inc.min_num_matches = 10
    inc.mapper.init_min_tri_angle = min_tri_angle
    inc.mapper.init_min_num_inliers = 25
    inc.mapper.abs_pose_min_num_inliers = 10
    inc.mapper.abs_pose_min_inlier_ratio = 0.15
    inc.mapper.filter_min_tri_angle = min_tri_angle / 4
    inc.mapper.ba_local_min_tri_angle = min_tri_angle / 4
    inc.triangulation.min_angle = min_tri_angle / 4
    if known_K:
        inc.ba_refine_focal_length = False
        inc.ba_refine_principal_point = False
        inc.ba_refine_extra_params = False
    return ext, match, inc


def _write_images(cv2: Any, root: Path, names: list[str], images: list[np.ndarray]) -> None:
    """The RGB ``images`` as ``root/images/<name>`` (COLMAP reads files)."""
    (root / "images").mkdir()
    for name, img in zip(names, images):
        cv2.imwrite(str(root / "images" / name), cv2.cvtColor(np.ascontiguousarray(img), cv2.COLOR_RGB2BGR))


def _match(pycolmap: Any, db: Path, match: Any, ransac_seed: int | None, num_threads: int) -> None:
    """Exhaustive matching and two-view verification of the features in ``db`` (:func:`_verification_options`)."""
    verify = _verification_options(pycolmap, ransac_seed)
    if ransac_seed is not None:  # every pair's RANSAC seeded on its own: the thread count no longer matters
        match.num_threads = max(1, int(num_threads))
    pycolmap.match_exhaustive(db, matching_options=match, verification_options=verify, device=pycolmap.Device.cpu)


def _verification_options(pycolmap: Any, ransac_seed: int | None) -> Any:
    """COLMAP's two-view verification options; ``ransac_seed`` seeds every pair's RANSAC (None: COLMAP's default, -1)."""
    verify = pycolmap.TwoViewGeometryOptions()
    if ransac_seed is not None:
        if not 0 <= int(ransac_seed) < 2**31 - 1:
            raise ValueError(f"expected ransac_seed in 0..{2**31 - 2} (got {ransac_seed})")
        verify.ransac.random_seed = int(ransac_seed)
    return verify


@dataclass(frozen=True)
class SfmRun:
    """The options :func:`run_sfm` reads; :meth:`SfmLifter.Options.run_sfm_kwargs` gives them (its defaults are the lifter's).

    The fields are :func:`run_sfm`'s parameters of the same names.
    """

    peak_threshold: float
    min_tri_angle: float
    seed: int
    camera_model: str
    attempts: int = 3
    num_threads: int = 1
    ransac_seed: int | None = None
    fov_range: tuple[float, float] | None = None
    redraws: int = 0
    focal_starts: tuple[float, ...] = ()
    prior_fov: float | None = None


def run_sfm(
    images: list[np.ndarray],
    K: list[np.ndarray] | None = None,
    options: SfmRun | Mapping[str, Any] | None = None,
    *,
    poses: list[np.ndarray] | None = None,
) -> SfmReconstruction:
    """Incremental SfM (COLMAP) on uint8 RGB images ``[H, W, 3]`` of one size.

    ``peak_threshold``, ``min_tri_angle``, ``seed`` and ``camera_model`` are
    required; their defaults are those of :class:`SfmLifter.Options`
    (``run_sfm(images, options=SfmLifter.Options().run_sfm_kwargs())``).

    Parameters
    ----------
    images : list of uint8 ``[H, W, 3]``
    K : list of ``[3, 3]``, optional
        Known intrinsics (graphseg convention: pixel centres at integers),
        held fixed. Without them one shared camera of ``camera_model`` is
        estimated, starting from COLMAP's focal-length guess (1.2 x the larger side).
    options : SfmRun or dict, optional
        The run's options, as :meth:`SfmLifter.Options.run_sfm_kwargs` gives
        them (the default; a dict is read as :class:`SfmRun`'s fields):

    peak_threshold : float
        SIFT detector threshold (COLMAP's default 0.0067 finds too few
        keypoints on renders).
    min_tri_angle : float
        Degrees; the initial pair needs this triangulation angle, and new points
        a quarter of it (COLMAP's defaults 16 and 1.5 build nothing on a 2 cm
        sweep at 1.2 m).
    seed : int
        Seeds COLMAP's incremental mapper (``random_seed``; it runs on one
        thread). The two-view RANSAC of the matching draws from the generator
        of COLMAP's one matching thread, which COLMAP seeds with its own fixed
        default: the same images give the same reconstruction, but ``seed``
        does not change those draws (``ransac_seed`` does; ``docs/results.md``,
        round 21).
    attempts : int
        Incremental mapping is randomised: when a view
        stays unregistered it is rerun from the same matches with the next
        seed, up to this many times; the model with the most views is kept.
    camera_model : str
        COLMAP camera model estimated when ``K`` is not given (one camera shared
        by all views). ``"SIMPLE_PINHOLE"`` (default: one focal length, principal
        point at the image centre, no distortion): a few views of a tabletop
        constrain a radial distortion term poorly, and ``"SIMPLE_RADIAL"``
        (COLMAP's default) let it absorb wrong matches on the tuning half of
        ``bench_rgb_only.py`` (focal lengths off by up to 2.2x and k1 up to 0.94;
        ``docs/results.md``, round 6). Use ``"SIMPLE_RADIAL"``, ``"RADIAL"`` or
        ``"OPENCV"`` for photos with visible lens distortion.
    num_threads : int
        Threads for SIFT feature extraction. The images enter COLMAP's
        database in name order before any feature is extracted, so their ids
        and the features (computed per image) do not depend on it: the
        reconstruction is the same for any count. Matching runs on one thread
        unless its RANSAC is seeded (``ransac_seed``, and every redraw of the
        focal-length check), and mapping always does (its bundle adjustment
        changes with the thread count).
    ransac_seed : int, optional
        Seed every two-view RANSAC of the matching with this value
        (COLMAP's ``RANSACOptions.random_seed``): the verified matches of a
        pair then depend neither on which thread matched it nor on what was
        drawn before, so matching runs on ``num_threads`` threads with the
        same result, and different values give different draws. None (the
        default) keeps COLMAP's own fixed seed on one matching thread. On few
        views with few matches the draw changes the model (3 weakly textured
        views gave 34, 28, 6 or 13 triangulated points for four draws;
        ``docs/results.md``, round 21).
    fov_range : (float, float), optional
        Fields of view across the larger image side (degrees,
        :func:`field_of_view`) typical of cameras. Only without ``K``: a focal
        length outside this range is suspect (:func:`focal_plausible`), and up
        to ``redraws`` more draws of the matching's RANSAC are tried, each
        mapped from a database of its own (the features are reused). Redraws
        are tried in turn; the first that registers at least as many views as
        the first model and whose focal length is typical, or agrees with the
        first model's (a ratio within 1 + :data:`FOCAL_AGREEMENT`, and a field
        of view within :data:`FOCAL_POSSIBLE`), decides.
        A typical one is kept. An agreeing one keeps the first model (or
        itself, when it registers more views): an unusual lens that two draws
        reproduce. When no redraw decides, the first draw's matches are mapped
        again with the focal length held at ``prior_fov`` (``camera_model``'s
        distortion terms are still estimated; for a variant that the first
        draw did not run, that draw is matched afresh), and that model is kept
        if it registers as many views; otherwise the first model is. None: no check.
    prior_fov : float, optional
        The field of view (degrees across the larger side) a suspect focal
        length is held at (see ``fov_range``); None: COLMAP's prior, 1.2 x
        the larger side (:func:`prior_intrinsics`, 45.2 degrees).
    redraws : int
        RANSAC seeds tried after a suspect focal length: ``ransac_seed`` (0
        when None) plus 1, 2, ... ``redraws`` (modulo 2**31 - 1). Their matching
        runs on ``num_threads`` threads (a seeded RANSAC does not depend on it).
    focal_starts : tuple of float
        Only without ``K``: fields of view (degrees across the larger side)
        from which the shared focal length also starts. Every draw's matches
        are mapped again from each start (the focal length still refined), and
        :func:`choose_start` keeps one model among these and the one from
        COLMAP's prior (the prior's, unless another start reached a focal
        length more than 10% away with a lower reprojection error). On a few views over a narrow arc bundle adjustment
        stops in a local minimum near its start, so a single start from the
        prior (about 45 degrees) biases the focal length of a wider camera
        towards it (``docs/results.md``, round 25). ``()``: the prior only.
    poses : list of float64 ``[4, 4]``, optional
        Known camera-to-world poses (OpenCV axes), one per view; only with
        ``K``. The cameras are then not estimated: the matched features are
        triangulated with every camera held fixed
        (COLMAP's point triangulator; features seen in two views count), and every view counts as registered.
        ``fov_range``, ``redraws`` and ``focal_starts`` do not apply. The result
        then has ``info["poses"] == "given"``, the given ``K`` and poses
        (copies) and no distortion.

    Returns
    -------
    SfmReconstruction
        The largest model (with ``fov_range``: the one the focal-length check
        keeps); views it does not contain are marked unregistered. With
        ``focal_starts``, ``info["focal_starts"]`` records the kept draw's
        starts: ``fov`` (the start, degrees; the first is the prior), ``views``,
        ``observations``, ``error`` (mean reprojection error, pixels) and
        ``result`` (the estimated field of view) per start that built a model,
        ``kept`` (its index in those lists) and, where starts built none,
        ``failed`` (their fields of view).
        With ``fov_range`` and no ``K``, once a model is built,
        ``info["focal_check"]`` records the check: ``range``; ``fov`` and
        ``views``, the field of view (degrees; None: no model) and registered
        views of the first model and of each redraw; ``plausible`` (the first
        focal length lies in the range); ``kept`` (``"first"``, ``"redraw k"``
        or ``"prior"``); where they apply, ``confirmed`` (the redraw that agreed
        with the first focal length), ``prior_views`` (views of the model with
        the focal length held; 0: none built) and ``prior_fov`` (its field of
        view). :func:`focal_check_warning` words it as one line.

    Notes
    -----
    SIFT with domain-size pooling first; when that leaves views unregistered,
    plain SIFT as well, and the model with more views is kept; when both
    register fewer than half the views, plain SIFT once more without guided
    matching (``info["registration"]`` records the variants tried, their
    registered views and the one kept; :func:`registration_warning`). (Pooled
    descriptors tell the squares of a checkered table apart; plain ones
    register more on weakly textured views). Exhaustive matching: O(N^2)
    image pairs. 5-30 s for 8 renders of 640 x 480 on two CPU cores (mapping,
    and unseeded matching, run single-threaded for reproducibility;
    ``bench_rgb_only.py``). A suspect focal length costs up to ``redraws + 1``
    more draws, each a matching (none for the held prior when the first draw's
    matches are reused) and a mapping of up to ``attempts`` runs, for pooled
    and, when views are missing, plain SIFT.
    """
    run = options if isinstance(options, SfmRun) else SfmRun(**(options if options is not None else SfmLifter.Options().run_sfm_kwargs()))
    pycolmap = require("pycolmap", "sfm")
    import cv2

    level = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = max(level, 3)  # COLMAP logs progress and "no model" errors; we report our own
    try:
        if poses is not None:
            if K is None or len(K) != len(images) or any(k is None for k in K):
                raise ValueError("known poses need the intrinsics K of every view")
            return _triangulate_known(pycolmap, cv2, images, K, poses, peak_threshold=run.peak_threshold, min_tri_angle=run.min_tri_angle, num_threads=run.num_threads, ransac_seed=run.ransac_seed)
        return _run_sfm(pycolmap, cv2, images, K, run)
    finally:
        pycolmap.logging.minloglevel = level


def field_of_view(K: np.ndarray, size: tuple[int, int]) -> float:
    """The field of view (degrees) of intrinsics ``K`` ``[3, 3]`` across the larger side of an image of ``size`` ``(width, height)``.

    Across the larger side, so that portrait and landscape photos of one camera give the same value.

    Examples
    --------
    >>> landscape = np.array([[320.0, 0, 320], [0, 320, 240], [0, 0, 1]])
    >>> portrait = np.array([[320.0, 0, 240], [0, 320, 320], [0, 0, 1]])
    >>> round(field_of_view(landscape, (640, 480)), 1), round(field_of_view(portrait, (480, 640)), 1)
    (90.0, 90.0)
    """
    K = np.asarray(K, np.float64)
    w, h = int(size[0]), int(size[1])
    side, f = (w, K[0, 0]) if w >= h else (h, K[1, 1])
    return float(np.degrees(2.0 * np.arctan2(0.5 * side, float(f))))


def focal_length(fov: float, size: tuple[int, int]) -> float:
    """The focal length (pixels) of a field of view ``fov`` (degrees) across the larger side of ``size`` ``(width, height)``: :func:`field_of_view` inverted.

    Examples
    --------
    >>> round(focal_length(90.0, (640, 480)), 6)
    320.0
    """
    return float((max(int(size[0]), int(size[1])) / 2) / np.tan(np.radians(fov) / 2))


def focal_plausible(K: np.ndarray, size: tuple[int, int], fov_range: tuple[float, float]) -> bool:
    """Whether ``K`` implies a field of view (:func:`field_of_view`) within ``fov_range`` (degrees, inclusive).

    Self-calibration from a few views on a narrow arc constrains the focal
    length poorly: bundle adjustment can drift to a focal length two or three
    times too long (or too short), with poses many degrees wrong and a
    reprojection error as low as a right model's (``docs/results.md``, rounds
    18, 21 and 23). The range is a prior on cameras, not on scenes: 35-110
    degrees across the larger side (the default of :class:`SfmLifter`) holds
    phone main cameras, webcams, wrist and RGB-D colour cameras (about 55-90
    degrees), and COLMAP's own starting guess (45.2 degrees). Longer lenses
    exist (YCB-Video's frames have 33.4 degrees), so :func:`run_sfm` keeps a
    focal length outside the range when a second RANSAC draw agrees with it.

    Examples
    --------
    >>> K = np.array([[1200.0, 0, 320], [0, 1200, 240], [0, 0, 1]])     # 29.9 degrees
    >>> focal_plausible(K, (640, 480), (35.0, 110.0)), focal_plausible(K, (640, 480), (20.0, 110.0))
    (False, True)
    """
    lo, hi = fov_range
    return bool(lo <= field_of_view(K, size) <= hi)


def prior_intrinsics(width: int, height: int) -> np.ndarray:
    """COLMAP's starting intrinsics for an unknown camera (graphseg convention: pixel centres at integers).

    Focal length 1.2 x the larger side, principal point at the image centre.

    Examples
    --------
    >>> prior_intrinsics(640, 480)[0].tolist()
    [768.0, 0.0, 319.5]
    """
    f = 1.2 * max(width, height)
    return np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def stereo_outliers(fractions: Any, tested: Any, ratio: float = STEREO_CHECK, *, floor: float = STEREO_CHECK_FLOOR) -> np.ndarray:
    """Views whose dense stereo covers far less than the other views': their poses are likely wrong.

    Dense stereo (:func:`graphseg.backends.lifters.stereo.stereo_depths`)
    matches each view along the epipolar lines its pose implies; a wrongly
    posed view finds few consistent depths while its neighbours find many.
    View ``i`` is an outlier when its covered fraction is below ``ratio``
    times the median of the other tested views'. Only views with a stereo
    neighbour are tested (``tested``), at least four of them, and at least
    three views are always kept (no view is an outlier otherwise): with three
    views, a view's stereo pairs are the other two, whose poses may be the
    wrong ones (on a tune scene with three views, all three were 9-21 degrees
    off and dropping the least covered one left no stereo at all). Nor is a
    view an outlier when the others' median is below ``floor``: where stereo
    covers little of every view (a short baseline, a wrong model as a whole),
    one view's low coverage says nothing about its pose.

    Parameters
    ----------
    fractions : float ``[N]``
        Per view, the share of pixels dense stereo gave a depth.
    tested : bool ``[N]``
        Views that had a stereo neighbour.
    ratio : float
        Share of the others' median below which a view is an outlier (0: none).
    floor : float, keyword-only
        The others' median coverage below which no view is an outlier.

    Returns
    -------
    int64 ``[k]``
        Indices of the outlier views, ascending.

    Notes
    -----
    A view posed so wrongly that no other view lies within the stereo's pair
    angle has no stereo neighbour; it is not tested, so it is never an outlier.
    O(N^2). On the tune half of ``bench_rgb_only.py`` (cached lifts of two
    RANSAC draws, 15 scenes each) the wrongly posed views (rotation errors of
    89-180 degrees) lay at 0.01-0.17 of the others' median, and the views at
    most 10 degrees off, in scenes of four or more views, at 0.26 or more
    (docs/results.md, round 24).

    Examples
    --------
    >>> stereo_outliers([0.016, 0.017, 0.09, 0.2, 0.36, 0.24], [True] * 6).tolist()
    [0, 1]
    >>> stereo_outliers([0.0, 0.3, 0.3, 0.3, 0.3], [False, True, True, True, True]).tolist()  # view 0 had no neighbour
    []
    >>> stereo_outliers([0.001, 0.02, 0.02, 0.03], [True] * 4).tolist()  # stereo covers 2% of the others: no verdict
    []
    """
    f = np.asarray(fractions, np.float64).ravel()
    t = np.asarray(tested, bool).ravel()
    if f.shape != t.shape:
        raise ValueError(f"expected fractions and tested of one length (got {f.size} and {t.size})")
    if not np.isfinite(f).all():
        raise ValueError(f"expected finite fractions (got {f.tolist()})")
    idx = np.flatnonzero(t)
    if ratio <= 0 or idx.size < 4:
        return np.zeros(0, np.int64)
    medians = {int(i): float(np.median(f[idx[idx != i]])) for i in idx}
    out = [i for i in idx if medians[int(i)] >= floor and f[i] < ratio * medians[int(i)]]
    if len(f) - len(out) < 3:
        return np.zeros(0, np.int64)
    return np.asarray(out, np.int64)


def camera_span(cam_to_world: Any, distance: float) -> tuple[float, float]:
    """How far apart the cameras are as seen from the scene: the largest angle two camera centres subtend at ``distance``.

    Parameters
    ----------
    cam_to_world : sequence of ``[4, 4]`` (None entries are skipped)
    distance : float
        The camera-to-scene distance, in the poses' units (the lifter uses
        the median camera-to-point distance of the triangulated points).

    Returns
    -------
    (float, float)
        The angle in degrees, ``2 atan(b / (2 distance))`` for the longest
        baseline ``b``, and ``b`` itself. O(N^2) for N cameras.

    Examples
    --------
    >>> T = [np.eye(4), np.eye(4)]
    >>> T[1][0, 3] = 0.01                       # 1 cm apart, 1.2 m from the scene
    >>> tuple(round(x, 3) for x in camera_span(T, 1.2))
    (0.477, 0.01)
    """
    c = np.array([np.asarray(T, np.float64)[:3, 3] for T in cam_to_world if T is not None]).reshape(-1, 3)
    if len(c) < 2 or not np.isfinite(distance) or distance <= 0:
        return float("nan"), float("nan")
    b = float(np.max(np.linalg.norm(c[:, None] - c[None], axis=-1)))
    return float(np.degrees(2.0 * np.arctan2(0.5 * b, float(distance)))), b


def short_baseline_warning(span: float, baseline: float, distance: float) -> str:
    """The one warning line for cameras closer together than :data:`MIN_SPAN` (see :func:`camera_span`).

    Examples
    --------
    >>> short_baseline_warning(0.477, 0.01, 1.2)
    'the cameras are at most 0.48 degrees apart as seen from the scene (0.01 apart at 1.2 from it): stereo and triangulation need a few degrees, so depth is unreliable; take the views 5-20 degrees apart'
    """
    return (
        f"the cameras are at most {span:.2f} degrees apart as seen from the scene ({baseline:.3g} apart at {distance:.3g} from it): "
        "stereo and triangulation need a few degrees, so depth is unreliable; take the views 5-20 degrees apart"
    )


def short_baseline_refusal(span: float, baseline: float, distance: float) -> str:
    """The one-line error for cameras closer together than the ``min_span`` option (see :func:`camera_span`).

    Examples
    --------
    >>> short_baseline_refusal(0.477, 0.01, 1.2)
    'the cameras are at most 0.48 degrees apart as seen from the scene (0.01 apart at 1.2 from it): stereo and triangulation need a few degrees, so depth from these photos is unreliable and no 3D object would be trustworthy; give depth (with intrinsics and poses, lifter rgbd), or take the views 5-20 degrees apart (--backend-option sfm.min_span=0 runs anyway)'
    """
    return (
        f"the cameras are at most {span:.2f} degrees apart as seen from the scene ({baseline:.3g} apart at {distance:.3g} from it): "
        "stereo and triangulation need a few degrees, so depth from these photos is unreliable and no 3D object would be trustworthy; "
        "give depth (with intrinsics and poses, lifter rgbd), or take the views 5-20 degrees apart (--backend-option sfm.min_span=0 runs anyway)"
    )


def stereo_check_warning(check: dict[str, Any]) -> str:
    """The one warning line of a stereo check that left views out (``meta["sfm"]["stereo_check"]``).

    Examples
    --------
    >>> stereo_check_warning({"fractions": {"a": 0.016, "b": 0.2}, "median": 0.2, "dropped": ["a"]})
    'dense stereo covers 1.6% of view a (median of the views kept 20.0%): its pose from structure from motion is likely wrong, so it is left out'
    """
    views = ", ".join(f"{100 * check['fractions'][n]:.1f}% of view {n}" for n in check["dropped"])
    one = len(check["dropped"]) == 1
    return (
        f"dense stereo covers {views} (median of the views kept {100 * check['median']:.1f}%): "
        + ("its pose" if one else "their poses")
        + " from structure from motion "
        + ("is" if one else "are")
        + " likely wrong, so "
        + ("it is" if one else "they are")
        + " left out"
    )


def _run_sfm(
    pycolmap: Any,
    cv2: Any,
    images: list[np.ndarray],
    K: list[np.ndarray] | None,
    run: SfmRun,
) -> SfmReconstruction:
    ransac_seed = run.ransac_seed
    n = len(images)
    known = K is not None and all(k is not None for k in K)
    names = [f"{i:04d}.png" for i in range(n)]
    size = (int(images[0].shape[1]), int(images[0].shape[0]))
    base_seed = 0 if ransac_seed is None else int(ransac_seed)
    with tempfile.TemporaryDirectory(prefix="graphseg-sfm-") as tmp:
        root = Path(tmp)
        _write_images(cv2, root, names, images)

        records: dict[int, tuple[Any, dict[str, Any]]] = {}  # each model built with its focal-length starts, by id
        registration: dict[str, Any] = {}  # the first draw's descriptor and matching variants and the views each registered

        def model(draw: int | None, tag: str, Kd: list[np.ndarray] | None, hold: bool = False) -> Any:
            # Domain-size pooling first: its descriptors tell the squares of a checkered
            # table apart where plain SIFT's match the wrong square and give a wrong model
            # (docs/results.md, round 5). On weakly textured views it finds fewer matches
            # and can leave views unregistered; then plain SIFT runs too and the model
            # with more registered views is kept (ties keep the pooled one).
            # Fewer than half the views registered by both: plain SIFT again without guided
            # matching (its epipolar re-search follows a first two-view geometry that may be wrong).
            best, best_record = None, {}
            tried = []
            for variant in VARIANTS:
                have = 0 if best is None else int(best.num_reg_images())
                if have == n or (variant == "sift-unguided" and 2 * have >= n):
                    break
                record: dict[str, Any] = {}
                rec = _map(pycolmap, root, names, Kd, run, variant=variant, ransac_seed=draw, tag=tag, hold_focal=hold, record=record)
                tried.append({"variant": variant, "views": 0 if rec is None else int(rec.num_reg_images())})
                if rec is not None and (best is None or rec.num_reg_images() > best.num_reg_images()):
                    best, best_record = rec, record
            if tag == "":
                registration.update(tried=tried, kept=max(tried, key=lambda t: t["views"])["variant"] if best is not None else None)
            if best is not None and best_record:
                records[id(best)] = (best, best_record)  # the model is held, so its id stays its own
            return best

        best = model(ransac_seed, "", K)
        check: dict[str, Any] | None = None
        if run.fov_range is not None and not known and best is not None:
            best, check = _check_focal(
                best,
                lambda k: model((base_seed + k) % _SEED_LIMIT, f"-r{k}", None),
                lambda: model(ransac_seed, "-prior", None, hold=True),
                size,
                run.fov_range,
                run.redraws,
            )
        if best is None:
            empty = SfmReconstruction(np.zeros(n, bool), [None] * n, [None] * n, [None] * n, np.zeros((0, 3)), [(np.zeros((0, 2)), np.zeros(0, np.int64))] * n)
            empty.info["registration"] = registration
            return empty
        out = _convert(best, names)
        out.info["registration"] = registration
        if check is not None:
            out.info["focal_check"] = check
        if id(best) in records:
            out.info["focal_starts"] = records[id(best)][1]
        return out


def _triangulate_known(
    pycolmap: Any, cv2: Any, images: list[np.ndarray], K: list[np.ndarray], poses: list[np.ndarray], *, peak_threshold: float, min_tri_angle: float, num_threads: int, ransac_seed: int | None
) -> SfmReconstruction:
    """Features, exhaustive matches and COLMAP's point triangulator with every camera held at its given ``K`` and pose (see :func:`run_sfm`'s ``poses``).

    Pooled SIFT (domain-size pooling, as the first draw of :func:`run_sfm`);
    the two-view verification still filters the matches, and the
    triangulator's own reprojection and angle checks drop matches that do not
    fit the given cameras. A feature seen in two views only is triangulated
    too (COLMAP's mapper ignores such tracks; here the cameras need no
    support from them, and a 2-view scene has no others). Bundle adjustment
    refines the points only: the poses and intrinsics stay exactly as given.
    O(N^2) image pairs for N views.
    """
    n = len(images)
    if len(poses) != n or any(T is None or np.asarray(T).shape != (4, 4) for T in poses):
        raise ValueError(f"expected a [4, 4] pose for each of the {n} views")
    bad = [i for i in range(n) if not (np.isfinite(np.asarray(poses[i], np.float64)).all() and np.isfinite(np.asarray(K[i], np.float64)).all())]
    if bad:
        raise ValueError(f"view {bad[0]}: expected a finite K and pose (got NaN or inf)")
    names = [f"{i:04d}.png" for i in range(n)]
    with tempfile.TemporaryDirectory(prefix="graphseg-sfm-") as tmp:
        root = Path(tmp)
        _write_images(cv2, root, names, images)
        ext, match, inc = _colmap_options(pycolmap, peak_threshold, min_tri_angle, 0, True, pooling=True)
        inc.triangulation.ignore_two_view_tracks = False
        db = root / "database.db"
        _extract(pycolmap, root, db, names, K, True, "PINHOLE", ext, num_threads)
        _match(pycolmap, db, match, ransac_seed, num_threads)
        given = pycolmap.Reconstruction()
        view_of = {name: i for i, name in enumerate(names)}
        with pycolmap.Database.open(db) as d:
            for cam in d.read_all_cameras():
                given.add_camera_with_trivial_rig(cam)
            for image in d.read_all_images():
                w2c = np.linalg.inv(np.asarray(poses[view_of[image.name]], np.float64))
                given.add_image_with_trivial_frame(pycolmap.Image(name=image.name, camera_id=image.camera_id, image_id=image.image_id), pycolmap.Rigid3d(w2c[:3, :4]))
        out = root / "triangulated"
        out.mkdir()
        rec = pycolmap.triangulate_points(given, db, root / "images", out, options=inc, refine_intrinsics=False)
        result = _convert(rec, names)
    result.cam_to_world = [np.asarray(T, np.float64).copy() for T in poses]  # exactly as given (not through COLMAP's quaternions)
    result.K = [np.asarray(k, np.float64).copy() for k in K]
    result.dist = [np.zeros(5) for _ in range(n)]
    result.registered = np.ones(n, bool)
    result.info["poses"] = "given"
    return result


#: Seeds of COLMAP's RANSAC lie in 0 .. 2**31 - 2.
_SEED_LIMIT = 2**31 - 1

#: Two focal lengths within this relative difference agree (:func:`run_sfm`'s focal-length check).
FOCAL_AGREEMENT = 0.1

#: Fields of view (degrees across the larger side) an agreeing redraw may confirm as an unusual
#: lens. Outside them no lens is believed, however many draws agree (a 3.5 degree field of view
#: that two draws reproduced kept a 3-of-8-view model; issue 54): the prior is tried instead.
FOCAL_POSSIBLE = (10.0, 150.0)

#: The descriptor and matching variants of a draw, in order: SIFT with domain-size pooling; plain
#: SIFT when views are left out; plain SIFT without guided matching when fewer than half register.
VARIANTS = ("dsp", "sift", "sift-unguided")


def _check_focal(
    first: Any, redraw: Any, hold: Any, size: tuple[int, int], fov_range: tuple[float, float], redraws: int
) -> tuple[Any, dict[str, Any]]:
    """The model :func:`run_sfm` keeps after its focal-length check, and the record of the check.

    ``first`` is the first COLMAP model; ``redraw(k)`` builds the model of
    redraw ``k`` (or None) and ``hold()`` the model with the focal length held
    at the prior (or None). A replacement must register at least as many views
    as ``first``.
    """
    K0 = _model_K(first)
    f0 = float(K0[0, 0])
    v0 = int(first.num_reg_images())
    fovs: list[float | None] = [round(field_of_view(K0, size), 2)]
    views = [v0]
    check: dict[str, Any] = {"range": [float(fov_range[0]), float(fov_range[1])], "fov": fovs, "views": views}
    if focal_plausible(K0, size, fov_range):
        return first, {**check, "plausible": True, "kept": "first"}
    check["plausible"] = False
    for k in range(1, max(0, int(redraws)) + 1):
        again = redraw(k)
        if again is None:
            fovs.append(None)
            views.append(0)
            continue
        Kk = _model_K(again)
        fovs.append(round(field_of_view(Kk, size), 2))
        views.append(int(again.num_reg_images()))
        if views[-1] >= v0:
            if focal_plausible(Kk, size, fov_range):
                return again, {**check, "kept": f"redraw {k}"}
            possible = FOCAL_POSSIBLE[0] <= fovs[-1] <= FOCAL_POSSIBLE[1]  # type: ignore[operator]
            if possible and abs(np.log(float(Kk[0, 0]) / f0)) <= np.log1p(FOCAL_AGREEMENT):  # an unusual lens, reproduced
                return (again, {**check, "kept": f"redraw {k}", "confirmed": k}) if views[-1] > v0 else (first, {**check, "kept": "first", "confirmed": k})
        del again  # one model at a time
    held = hold()
    check["prior_views"] = 0 if held is None else int(held.num_reg_images())
    if held is not None:
        check["prior_fov"] = round(field_of_view(_model_K(held), size), 2)
        if check["prior_views"] >= v0:
            return held, {**check, "kept": "prior"}
    return first, {**check, "kept": "first"}


def registration_warning(registration: dict[str, Any] | None, num_views: int) -> str | None:
    """The one warning line when fewer than half the views registered with SIFT (pooled, then plain) and plain SIFT without guided matching was tried (:func:`run_sfm`'s ``info["registration"]``); None otherwise.

    Examples
    --------
    >>> tried = [{"variant": "dsp", "views": 3}, {"variant": "sift", "views": 2}, {"variant": "sift-unguided", "views": 6}]
    >>> registration_warning({"tried": tried, "kept": "sift-unguided"}, 8)
    'structure from motion registered 3 of 8 views (plain SIFT: 2); plain SIFT without guided matching registered 6 and was kept'
    >>> registration_warning({"tried": tried[:2], "kept": "dsp"}, 8) is None
    True
    """
    tried = {t["variant"]: t["views"] for t in (registration or {}).get("tried", [])}
    if "sift-unguided" not in tried:
        return None
    head = f"structure from motion registered {tried.get('dsp', 0)} of {num_views} views (plain SIFT: {tried.get('sift', 0)})"
    if registration.get("kept") == "sift-unguided":  # type: ignore[union-attr]
        return f"{head}; plain SIFT without guided matching registered {tried['sift-unguided']} and was kept"
    return f"{head}; plain SIFT without guided matching registered {tried['sift-unguided']}, no more"


def focal_check_warning(check: dict[str, Any] | None) -> str | None:
    """The one warning line for a focal-length check of :func:`run_sfm` (None when the first focal length was typical).

    Examples
    --------
    >>> base = {"range": [35.0, 110.0], "plausible": False}
    >>> focal_check_warning({**base, "fov": [29.9, 61.0], "views": [3, 3], "kept": "redraw 1"})
    'structure from motion: the focal length implied a 29.9 degree field of view, outside 35-110; RANSAC redraw 1 gave 61.0 degrees and was kept'
    >>> focal_check_warning({**base, "fov": [33.4, 33.2], "views": [9, 9], "kept": "first", "confirmed": 1})
    'structure from motion: the focal length implied a 33.4 degree field of view, outside 35-110; RANSAC redraw 1 gave the same (33.2), so the first model was kept; give the intrinsics (K) if they are known'
    >>> focal_check_warning({**base, "fov": [22.6, 70.1, None], "views": [5, 4, 0], "prior_views": 5, "prior_fov": 45.2, "kept": "prior"})
    'structure from motion: the focal length implied a 22.6 degree field of view, outside 35-110 (redraws: 70.1 on 4 of 5 views, no model); the focal length was held at the prior field of view (45.2 degrees, sfm.prior_fov); give the intrinsics (K) if they are known'
    >>> focal_check_warning({"range": [35.0, 110.0], "fov": [61.0], "views": [3], "plausible": True, "kept": "first"}) is None
    True
    """
    if not check or check.get("plausible", True):
        return None
    lo, hi = check["range"]
    fov, views = check["fov"], check["views"]
    head = f"structure from motion: the focal length implied a {fov[0]:.1f} degree field of view, outside {lo:g}-{hi:g}"
    hint = "give the intrinsics (K) if they are known"
    kept = check["kept"]
    if "confirmed" in check:
        k = int(check["confirmed"])
        which = "the first model" if kept == "first" else f"redraw {k}, with {views[k]} views,"
        return f"{head}; RANSAC redraw {k} gave the same ({fov[k]:.1f}), so {which} was kept; {hint}"
    if kept.startswith("redraw"):
        return f"{head}; RANSAC {kept} gave {fov[int(kept.split()[1])]:.1f} degrees and was kept"
    n = views[0]
    tried = ", ".join("no model" if f is None else f"{f:.1f}" + (f" on {v} of {n} views" if v < n else "") for f, v in zip(fov[1:], views[1:]))
    tried = f" (redraws: {tried})" if tried else ""
    if kept == "prior":
        return f"{head}{tried}; the focal length was held at the prior field of view ({check['prior_fov']:.1f} degrees, sfm.prior_fov); {hint}"
    held = "built no model" if not check.get("prior_views") else f"registered {check['prior_views']} of {n} views"
    return f"{head}{tried}; no redraw gave a typical or agreeing focal length and the focal length held at the prior {held}, so the first model was kept; {hint}"


def _model_K(rec: Any) -> np.ndarray:
    """The intrinsics ``[3, 3]`` of a COLMAP model's first registered camera (one camera is shared)."""
    cam = next(rec.cameras[img.camera_id] for img in rec.images.values() if img.has_pose)
    return np.asarray(cam.calibration_matrix(), np.float64)


def _map(
    pycolmap: Any,
    root: Path,
    names: list[str],
    K: list[np.ndarray] | None,
    run: SfmRun,
    *,
    variant: str,
    ransac_seed: int | None = None,
    tag: str = "",
    hold_focal: bool = False,
    record: dict[str, Any] | None = None,
) -> Any:
    """Features, exhaustive matches and incremental mapping in ``root``; the model with the most views, or None.

    ``tag`` names this draw's database and models: every draw maps from a
    database of its own. The first draw of each descriptor kind (pooled or
    plain SIFT) keeps a copy of its database before matching
    (``features-<kind>.db``), and later draws (the redraws of the
    focal-length check) match from a copy of it: features do not depend on
    the RANSAC seed (whichever draw first extracts a kind writes the copy;
    only without ``K``). ``hold_focal``: the first draw's matches are mapped
    again (``database-<kind>.db``, copied) with the camera of
    ``camera_model`` held at COLMAP's prior focal length
    (:func:`prior_intrinsics`); its distortion terms are estimated as usual.
    Where the first draw did not run that kind, the draw is matched afresh
    with the focal length held. ``run.focal_starts`` (fields of view, degrees; not with
    ``K`` or ``hold_focal``): the same matches are mapped again from each of
    these focal lengths (a copy of the database each), and
    :func:`choose_start` picks among those models and the prior's; ``record``
    then receives the starts (:func:`run_sfm`'s ``info["focal_starts"]``).
    """
    n = len(names)
    known = K is not None and all(k is not None for k in K)
    peak_threshold, min_tri_angle, seed, attempts, camera_model, num_threads = run.peak_threshold, run.min_tri_angle, run.seed, run.attempts, run.camera_model, run.num_threads
    starts = () if hold_focal else run.focal_starts
    if hasattr(pycolmap, "set_random_seed"):
        pycolmap.set_random_seed(seed)  # this thread's generator only: the matching thread keeps COLMAP's default seed
    pooling = variant == "dsp"
    ext, match, inc = _colmap_options(pycolmap, peak_threshold, min_tri_angle, seed, known, pooling)
    match.guided_matching = variant != "sift-unguided"
    kind = "dsp" if pooling else "sift"  # the features: plain SIFT's serve both plain variants
    db = root / f"database-{variant}{tag}.db"
    features, matched = root / f"features-{kind}.db", root / f"database-{variant}.db"
    tag = variant + tag
    hold = hold_focal and not known
    if hold and matched.exists():
        shutil.copyfile(matched, db)
        _hold_prior_focal(pycolmap, db, inc, run.prior_fov)
    else:
        if not known and features.exists():
            shutil.copyfile(features, db)  # same images, same features: only the matching is drawn again
        else:
            _extract(pycolmap, root, db, names, K, known, camera_model, ext, num_threads)
            if not known:
                shutil.copyfile(db, features)
        if hold:  # no matched database to reuse: the whole draw, held
            _hold_prior_focal(pycolmap, db, inc, run.prior_fov)
        _match(pycolmap, db, match, ransac_seed, num_threads)
    best = _incremental(pycolmap, root, db, tag, inc, seed, attempts, n)
    if not starts or known or hold or best is None:
        return best
    cam = next(iter(best.cameras.values()))  # one camera shared by every view
    size = (int(cam.width), int(cam.height))
    cands = [(field_of_view(prior_intrinsics(*size), size), best)]  # the first start: COLMAP's prior
    for fov in starts:
        db_s = root / f"database-{tag}-fov{fov:g}.db"
        shutil.copyfile(db, db_s)
        _set_focal(pycolmap, db_s, float(fov))
        _, _, inc_s = _colmap_options(pycolmap, peak_threshold, min_tri_angle, seed, known, pooling)
        rec = _incremental(pycolmap, root, db_s, f"{tag}-fov{fov:g}", inc_s, seed, attempts, n)
        if rec is not None and rec.num_reg_images() > 0:
            cands.append((float(fov), rec))
        elif record is not None:
            record.setdefault("failed", []).append(float(fov))
    views = [int(r.num_reg_images()) for _, r in cands]
    obs = [int(r.compute_num_observations()) for _, r in cands]
    err = [float(r.compute_mean_reprojection_error()) for _, r in cands]
    k = choose_start(views, obs, err, [float(_model_K(r)[0, 0]) for _, r in cands])
    if record is not None:
        record.update(
            fov=[round(f, 2) for f, _ in cands],
            views=views,
            observations=obs,
            error=[round(e, 4) for e in err],
            result=[round(field_of_view(_model_K(r), size), 2) for _, r in cands],
            kept=k,
        )
    return cands[k][1]


def _incremental(pycolmap: Any, root: Path, db: Path, tag: str, inc: Any, seed: int, attempts: int, n: int) -> Any:
    """COLMAP's incremental mapping of the matches in ``db``, up to ``attempts`` mapper seeds; the model with the most views, or None."""
    best = None
    for attempt in range(max(1, attempts)):  # the mapper is randomised: retry from the same matches
        out = root / f"sparse-{tag}-{attempt}"
        out.mkdir()
        inc.random_seed = seed + attempt
        models = pycolmap.incremental_mapping(db, root / "images", out, options=inc)
        if models:
            rec = max(models.values(), key=lambda r: r.num_reg_images())
            if best is None or rec.num_reg_images() > best.num_reg_images():
                best = rec
        if best is not None and best.num_reg_images() == n:
            break
    return best


def choose_start(views: Any, observations: Any, errors: Any, focals: Any = None, *, min_share: float = START_MIN_OBSERVATIONS, agreement: float = FOCAL_AGREEMENT) -> int:
    """Which of several bundle adjustments (one per focal-length start; the first from COLMAP's prior) to keep.

    Among the models that register the most views, those holding at least
    ``min_share`` of the most observations compete, and the one with the
    lowest mean reprojection error wins (ties: the first, i.e. the prior's).
    On a few views over a narrow arc the reprojection error alone can prefer
    a degenerate model that keeps only its few best points; the share of
    observations rules those out. With ``focals``, the first model, when it
    competes, stays unless the winner's focal length differs from its own by more than
    ``agreement`` (relative): starts that reach the same focal length found
    the same minimum, and their slightly different poses are no reason to
    change the model (the segmentation downstream is sensitive to them).

    Parameters
    ----------
    views, observations : int ``[S]``
        Registered views and observations (2D points in a track) per model.
    errors : float ``[S]``
        Mean reprojection error per model (pixels).
    focals : float ``[S]``, optional
        Estimated focal length per model (pixels).
    min_share : float
        In ``(0, 1]``.
    agreement : float
        Relative difference of focal lengths that still agree (:data:`FOCAL_AGREEMENT`).

    Returns
    -------
    int
        The index of the model to keep.

    Notes
    -----
    O(S).

    Examples
    --------
    >>> choose_start([8, 8, 8], [2800, 2500, 2980], [0.99, 0.86, 0.94])
    1
    >>> choose_start([3, 3, 3], [78, 17, 73], [0.84, 0.26, 0.83])  # 17 observations: degenerate
    2
    >>> choose_start([5, 4], [100, 900], [0.9, 0.1])  # more views first
    0
    >>> choose_start([8, 8, 8], [2800, 2500, 2980], [0.99, 0.86, 0.94], [590, 585, 588])  # one focal length: the prior's model stays
    0
    """
    v = np.asarray(views, np.int64).reshape(-1)
    o = np.asarray(observations, np.float64).reshape(-1)
    e = np.asarray(errors, np.float64).reshape(-1)
    if not (v.shape == o.shape == e.shape) or v.size == 0:
        raise ValueError(f"expected views, observations and errors of one shape [S], S >= 1 (got {list(v.shape)}, {list(o.shape)}, {list(e.shape)})")
    if not 0 < min_share <= 1:
        raise ValueError(f"expected min_share in (0, 1] (got {min_share})")
    if not np.isfinite(e).all():
        raise ValueError(f"expected finite errors (got {e.tolist()})")
    top = v == v.max()
    ok = top & (o >= min_share * o[top].max())
    cand = np.flatnonzero(ok)
    k = int(cand[np.argmin(e[cand])])
    if focals is not None and k != 0 and ok[0]:  # the prior's model competes and reached the same focal length
        f = np.asarray(focals, np.float64).reshape(-1)
        if f.shape != v.shape or not (np.isfinite(f).all() and (f > 0).all()):
            raise ValueError(f"expected positive finite focals of shape [{v.size}] (got {f.tolist()})")
        if abs(np.log(f[k] / f[0])) <= np.log1p(agreement):
            k = 0
    return k


def _set_focal(pycolmap: Any, db_path: Path, fov: float) -> None:
    """Start every camera of a database at the focal length of a field of view (degrees across the larger side); it is still refined."""
    with pycolmap.Database.open(db_path) as db:
        for cam in db.read_all_cameras():
            w, h = int(cam.width), int(cam.height)
            params = np.array(cam.params, np.float64)
            params[cam.focal_length_idxs()] = focal_length(fov, (w, h))
            cam.params = params
            db.update_camera(cam)


def _extract(pycolmap: Any, root: Path, db: Path, names: list[str], K: list[np.ndarray] | None, known: bool, camera_model: str, ext: Any, num_threads: int) -> None:
    """Import the images (in name order) and extract their features into a new database ``db``."""
    reader = pycolmap.ImageReaderOptions()
    mode = pycolmap.CameraMode.SINGLE
    Ks: list[np.ndarray] = []
    if known:
        assert K is not None
        Ks = [np.asarray(k, np.float64) for k in K]
        same = all(np.allclose(k, Ks[0]) for k in Ks)
        mode = pycolmap.CameraMode.SINGLE if same else pycolmap.CameraMode.PER_IMAGE
        k0 = Ks[0]
        reader.camera_model = "PINHOLE"
        reader.camera_params = f"{k0[0, 0]},{k0[1, 1]},{k0[0, 2] + 0.5},{k0[1, 2] + 0.5}"
    else:
        reader.camera_model = camera_model
    # the images enter the database in name order first: with several extraction threads
    # COLMAP would otherwise number them in the order they finish, and the ids steer the mapper
    with pycolmap.Database.open(db):
        pass
    pycolmap.import_images(db, root / "images", camera_mode=mode, image_names=names, options=reader)
    ext.num_threads = max(1, int(num_threads))
    pycolmap.extract_features(db, root / "images", image_names=names, camera_mode=mode, reader_options=reader, extraction_options=ext, device=pycolmap.Device.cpu)
    if known and mode == pycolmap.CameraMode.PER_IMAGE:
        _set_per_image_cameras(pycolmap, db, names, Ks)


def _hold_prior_focal(pycolmap: Any, db_path: Path, inc: Any, fov: float | None = None) -> None:
    """Set every camera of a database to the focal length of ``fov`` (degrees across the larger side; None: COLMAP's starting parameters, :func:`prior_intrinsics`), mark its focal length as known and keep the mapper ``inc`` from refining it."""
    inc.ba_refine_focal_length = False
    inc.mapper.abs_pose_refine_focal_length = False
    with pycolmap.Database.open(db_path) as db:
        for cam in db.read_all_cameras():
            w, h = int(cam.width), int(cam.height)
            f = float(prior_intrinsics(w, h)[0, 0]) if fov is None else focal_length(fov, (w, h))
            prior = pycolmap.Camera.create_from_model_id(cam.camera_id, cam.model, f, w, h)
            cam.params = prior.params
            cam.has_prior_focal_length = True
            db.update_camera(cam)


def _set_per_image_cameras(pycolmap: Any, db_path: Path, names: list[str], Ks: list[np.ndarray]) -> None:
    """Give every image its own known PINHOLE camera (views with different K)."""
    with pycolmap.Database.open(db_path) as db:
        for img in db.read_all_images():
            k = Ks[names.index(img.name)]
            cam = db.read_camera(img.camera_id)
            cam.params = [k[0, 0], k[1, 1], k[0, 2] + 0.5, k[1, 2] + 0.5]
            cam.has_prior_focal_length = True
            db.update_camera(cam)


def _convert(rec: Any, names: list[str]) -> SfmReconstruction:
    n = len(names)
    registered = np.zeros(n, bool)
    Ks: list[np.ndarray | None] = [None] * n
    dists: list[np.ndarray | None] = [None] * n
    poses: list[np.ndarray | None] = [None] * n
    obs: list[tuple[np.ndarray, np.ndarray]] = [(np.zeros((0, 2)), np.zeros(0, np.int64))] * n
    ids = sorted(rec.points3D.keys())
    index = {pid: k for k, pid in enumerate(ids)}
    pts = np.array([rec.points3D[pid].xyz for pid in ids], np.float64).reshape(-1, 3)
    for image in rec.images.values():
        if not image.has_pose or image.name not in names:
            continue
        i = names.index(image.name)
        registered[i] = True
        cam = rec.cameras[image.camera_id]
        K = np.asarray(cam.calibration_matrix(), np.float64).copy()
        K[0, 2] -= 0.5  # COLMAP puts pixel centres at +0.5
        K[1, 2] -= 0.5
        Ks[i] = K
        d = np.zeros(5)
        if cam.model.name in ("SIMPLE_RADIAL", "RADIAL"):
            d[0] = cam.params[3]
            if cam.model.name == "RADIAL":
                d[1] = cam.params[4]
        elif cam.model.name == "OPENCV":  # fx, fy, cx, cy, k1, k2, p1, p2 -> OpenCV's (k1, k2, p1, p2, k3)
            d[:4] = cam.params[4:8]
        dists[i] = d
        w2c = np.eye(4)
        w2c[:3, :] = np.asarray(image.cam_from_world().matrix(), np.float64)
        poses[i] = np.linalg.inv(w2c)
        xy, pid = [], []
        for p2d in image.points2D:
            if p2d.has_point3D():
                xy.append(np.asarray(p2d.xy, np.float64) - 0.5)
                pid.append(index[p2d.point3D_id])
        obs[i] = (np.array(xy, np.float64).reshape(-1, 2), np.array(pid, np.int64))
    err = float(rec.compute_mean_reprojection_error()) if len(ids) else float("nan")
    return SfmReconstruction(registered, Ks, dists, poses, pts, obs, err, {"num_points": len(ids)})


def _median_distance(rec: SfmReconstruction) -> float:
    d = []
    for T, (_, pid) in zip(rec.cam_to_world, rec.observations):
        if T is not None and pid.size:
            d.append(np.linalg.norm(rec.points[pid] - T[:3, 3], axis=1))
    return float(np.median(np.concatenate(d))) if d else float("nan")


def _depth_ranges(rec: SfmReconstruction) -> list[tuple[float, float] | None]:
    """Per view, the 2nd and 98th percentile depth of its triangulated points (None without points)."""
    out: list[tuple[float, float] | None] = []
    for T, (_, pid) in zip(rec.cam_to_world, rec.observations):
        if T is None or pid.size < 5:
            out.append(None)
            continue
        z = ((rec.points[pid] - T[:3, 3]) @ T[:3, :3])[:, 2]
        z = z[z > 0]
        out.append((float(np.percentile(z, 2)), float(np.percentile(z, 98))) if z.size >= 5 else None)
    return out


def scale_reconstruction(rec: SfmReconstruction, scene: Scene) -> tuple[SfmReconstruction, dict[str, Any]]:
    """Metric by similarity alignment when every view has a pose, else the nominal-distance normalisation.

    Returns the moved reconstruction and ``{"metric", "factor", "method"}``
    (plus ``"residual"``, the RMS camera-centre error in metres, when aligned).
    """
    given = [v.cam_to_world for v in scene.views]
    idx = [i for i in range(len(given)) if rec.registered[i] and given[i] is not None]
    if all(g is not None for g in given) and len(idx) >= 3:
        src = np.array([rec.cam_to_world[i][:3, 3] for i in idx])  # type: ignore[index]
        dst = np.array([np.asarray(given[i], np.float64)[:3, 3] for i in idx])
        spread = np.linalg.norm(dst - dst.mean(0), axis=1).max()
        if spread > 1e-6:
            s, R, t = umeyama(src, dst)
            out = rec.transformed(s, R, t)
            res = float(np.sqrt(np.mean(np.sum((np.array([out.cam_to_world[i][:3, 3] for i in idx]) - dst) ** 2, axis=1))))  # type: ignore[index]
            return out, {"metric": True, "factor": float(s), "method": "similarity alignment of SfM camera centres to the given poses", "residual": res}
    med = _median_distance(rec)
    s = NOMINAL_DISTANCE / med if np.isfinite(med) and med > 0 else 1.0
    first = next(T for T in rec.cam_to_world if T is not None)
    Rw = first[:3, :3].T  # world frame = the first registered camera
    out = rec.transformed(s, Rw, -s * Rw @ first[:3, 3])
    return out, {"metric": False, "factor": float(s), "method": f"median camera-to-point distance scaled to {NOMINAL_DISTANCE} m (NOMINAL_DISTANCE)"}


def _fill_view(points: np.ndarray, conf: np.ndarray, rgb: np.ndarray, T: np.ndarray, K: np.ndarray, confidence: float, replace: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Fill a world point map's holes per colour region (camera-frame depth, then back to the world)."""
    from ...scene import backproject
    from .densify import color_regions, fill_depth_by_regions

    cam = ((points.astype(np.float64) - T[:3, 3]) @ T[:3, :3])[..., 2]
    z = fill_depth_by_regions(cam, color_regions(rgb), replace=replace)
    new = (np.ones(z.shape, bool) if replace else ~np.isfinite(points).all(-1)) & np.isfinite(z) & (z > 0)
    filled = backproject(np.where(new, z, 0).astype(np.float32), K, T)
    p = points.copy()
    c = conf.copy()
    c[new & ~np.isfinite(points).all(-1)] = confidence
    p[new] = filled[new]
    return p, c


def _consistent(
    pts: list[np.ndarray], conf: list[np.ndarray], rgb: list[np.ndarray], Ks: list[np.ndarray], poses: list[np.ndarray], neighbours: list[list[int]]
) -> tuple[list[np.ndarray], list[np.ndarray], list[float]]:
    """Stereo points checked against the other views (:func:`graphseg.backends.lifters.stereo.view_consistency`).

    A point that no checking neighbour confirms is dropped (the fill then
    decides that pixel); the confidence of the others is the fused stereo
    agreement times the share of checking neighbours that confirm them.
    Returns the new points, confidences and the dropped fraction per view.
    """
    from .stereo import view_consistency

    agree, checked = view_consistency(pts, Ks, poses, neighbours, images=rgb)
    out_p, out_c, dropped = [], [], []
    for p, c, a, k in zip(pts, conf, agree, checked):
        bad = (k > 0) & (a == 0)
        p = p.copy()
        p[bad] = np.nan
        share = np.where(k > 0, a / np.maximum(k, 1), 0.5).astype(np.float32)  # unchecked: half confidence
        out_p.append(p)
        out_c.append(np.where(np.isfinite(p).all(-1), c * share, 0).astype(np.float32))
        dropped.append(float(bad.mean()))
    return out_p, out_c, dropped


class SfmLifter(Backend):
    """The ``sfm`` lifter: SfM cameras + stereo / triangulated depth for RGB-only scenes.

    Parameters
    ----------
    options : SfmLifter.Options, optional
        Or the options below as keywords (the defaults live in ``Options``).
    peak_threshold, min_tri_angle :
        See :func:`run_sfm`.
    num_threads : int
        Threads for SIFT feature extraction, and for matching when its RANSAC
        is seeded (``ransac_seed``, and the redraws of the focal-length check;
        :func:`run_sfm`; the result does not depend on it). Mapping runs on one
        thread so that the same photos give the same result.
    ransac_seed : int or None
        Seeds every two-view RANSAC of the matching (:func:`run_sfm`); None
        keeps COLMAP's fixed default on one matching thread.
    stereo : bool
        Dense stereo where a neighbour is close (:func:`graphseg.backends.lifters.stereo.stereo_depths`).
    max_pair_angle : float
        Degrees; neighbours whose viewing directions differ more are not used for stereo.
    max_neighbours : int
        Stereo pairs fused per view.
    sparse_radius : int
        A triangulated point fills a ``(2 r + 1)^2`` pixel block where nothing
        else gave a point (r = 1: every 2-pixel stride of the 3D stage still sees it).
    fill : "planes", True or False
        ``"planes"``: every colour superpixel with enough stereo or
        triangulated points becomes one plane in inverse depth (holes filled,
        known pixels replaced; depth edges then follow colour edges, which the
        geometric segmenter needs: stereo blurs depth edges). True: fill holes
        only. False: no filling.
        (:func:`graphseg.backends.lifters.densify.fill_depth_by_regions`.)
    fill_confidence : float
        Confidence of pixels that only the fill gave a point.
    consistency : bool
        Check every stereo point against the neighbour views (forward-backward
        reprojection at the same depth and colour,
        :func:`graphseg.backends.lifters.stereo.view_consistency`): points no neighbour
        confirms are dropped before the fill, and the share that confirm
        becomes part of the confidence. Off by default: on the tuning half of
        ``bench_rgb_only.py`` it left the mean IoU unchanged (0.582) and cost
        2-15 s per scene (``docs/results.md``).
    transfer : bool
        A pixel its own stereo left empty takes the nearest point another view
        measured there, when that surface faces this camera and the colours
        agree (:func:`graphseg.backends.lifters.transfer.transfer_points`;
        confidence 0.5). It runs before the triangulated points and the fill,
        so the fill's planes fit these measured points too. On by default:
        measured on the tuning half of ``bench_rgb_only.py`` (``docs/results.md``,
        round 12).
    transfer_min_confidence : float
        Stereo confidence a point needs to be transferred.
    transfer_color_distance : float, optional
        CIE Lab distance (OpenCV's 8-bit scaling, after a 2-pixel blur) above
        which the nearest point is refused, so a point hidden behind a surface
        without depth is not taken (None: no colour test).
    camera_model : str
        The camera estimated when the views have no intrinsics (see :func:`run_sfm`).
    fov_range : (float, float) or None
        Degrees, default 35-110: the fields of view across the larger image
        side typical of cameras. A focal length outside is suspect: RANSAC
        redraws with as many views are tried in turn, and the first typical
        one replaces it, or the first agreeing one keeps it; failing both,
        the prior replaces it if that model registers as many views
        (:func:`run_sfm`). The warnings of the lifted scene say so in one line,
        and ``meta["sfm"]["focal_check"]`` records the check.
    redraws : int
        RANSAC draws the check may try (:func:`run_sfm`).
    focal_starts : tuple of float
        Fields of view (degrees across the larger side) from which bundle
        adjustment also starts the focal length when the photos come without
        intrinsics, beside COLMAP's prior (1.2 x the larger side, about 45
        degrees); the model with the most views, at least 80% of the most
        observations and the lowest reprojection error is kept when its focal
        length differs from the prior's model's by more than 10%
        (:func:`choose_start`; ``meta["sfm"]["focal_starts"]`` records them).
        Off by default (``()``: the prior only). :data:`FOCAL_STARTS` (60 and 70
        degrees) brought the focal length of every scene it changed much
        closer to the truth, but the IoU moved both ways (+0.049, -0.003 and
        0.313 -> 0.000 on the tuning pools; ``docs/results.md``, round 25).
    stereo_check : float
        A registered view whose dense stereo covers less than this share of
        the other views' median (:func:`stereo_outliers`; that median must be
        at least 5%) is taken as wrongly posed: it is left out, like a view structure from motion did not
        register, and the other views' stereo is computed again without it
        (the scale stays the one found with every registered view). When views
        are left out, a warning line names them and
        ``meta["sfm"]["stereo_check"]`` records the coverage of every tested
        view; ``meta["sfm"]["registered"]`` still counts what structure from
        motion registered. Needs ``stereo``; 0 turns it off.
    use_poses : bool
        When every view has ``K`` and ``cam_to_world`` (a robot's or a
        tracker's cameras, depth missing), the cameras are taken as given:
        structure from motion only triangulates the matched features with
        them held fixed (:func:`run_sfm`'s ``poses``), stereo runs on the
        given poses, the result is metric, and the stereo check does not run
        (``meta["sfm"]["poses"]`` is ``"given"``). False estimates the poses
        by structure from motion (the given ``K`` still held fixed) and then
        aligns the camera centres to the given poses by a similarity
        (:func:`scale_reconstruction`; metric with 3 or more registered
        views, the nominal scale otherwise).
    seed : int
        Seed of COLMAP's incremental mapper (None: 0; :func:`run_sfm`).
    min_span : float
        Degrees, default :data:`MIN_SPAN` (2): when the cameras (given, or
        as structure from motion placed them) are spread over less than this
        as seen from the scene (:func:`camera_span`), stereo and triangulation
        have too little parallax and every depth is a guess; the lifter then
        raises :class:`SceneError` with one line
        (:func:`short_baseline_refusal`: give depth, or take the views further
        apart) before any stereo runs, instead of segmenting phantom objects
        (10 frames of YCB-Video 0001, 0.75 degrees apart with the given
        cameras, gave 47 objects for 4). 0 runs anyway, with a warning line
        below :data:`MIN_SPAN`.
    """

    name = "sfm"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        peak_threshold: float = Field(0.002, gt=0, description="SIFT detector threshold (COLMAP's default 0.0067 finds too few keypoints on renders)")
        min_tri_angle: float = Field(2.0, gt=0, description="degrees: the initial pair's triangulation angle (new points: a quarter of it)")
        num_threads: int = Field(2, ge=1, description="threads for SIFT feature extraction and seeded matching (the result does not depend on it; mapping runs on one thread)")
        stereo: bool = Field(True, description="dense stereo where a neighbour view is close")
        max_pair_angle: float = Field(45.0, gt=0, description="degrees: neighbours whose viewing directions differ more are not used for stereo")
        max_neighbours: int = Field(4, ge=1, description="stereo pairs fused per view")
        sparse_radius: int = Field(1, ge=0, description="a triangulated point fills a (2 r + 1)^2 pixel block")
        fill: bool | Literal["planes"] = Field("planes", description="'planes': one plane per colour region; True: fill holes only; False: no filling")
        fill_confidence: float = Field(0.25, ge=0, description="confidence of pixels only the fill gave a point")
        seed: int | None = Field(0, ge=0, description="seed of COLMAP's mapper (None: 0); the matching's two-view RANSAC keeps COLMAP's fixed default seed unless ransac_seed is set")
        ransac_seed: int | None = Field(
            None, ge=0, lt=2**31 - 1, description="seed every two-view RANSAC of the matching with this (None: COLMAP's fixed default, matching on one thread); with a seed, matching runs on num_threads threads with the same result"
        )
        consistency: bool = Field(False, description="check every stereo point against the neighbour views")
        transfer: bool = Field(True, description="give a pixel its own stereo left empty the point another view measured there")
        transfer_min_confidence: float = Field(0.5, ge=0, description="stereo confidence a point needs to be transferred")
        transfer_color_distance: float | None = Field(30.0, gt=0, description="CIE Lab distance above which a transferred point is refused (None: no colour test)")
        camera_model: str = Field("SIMPLE_PINHOLE", description="the COLMAP camera estimated without intrinsics: " + ", ".join(CAMERA_MODELS))
        fov_range: tuple[float, float] | None = Field(
            (35.0, 110.0), description="degrees across the larger image side, typical of cameras; outside, RANSAC redraws with as many views are tried in turn: the first typical one replaces the model, or the first agreeing one keeps it; else COLMAP's prior replaces it if it registers as many views (None: no check)"
        )
        redraws: int = Field(2, ge=0, le=10, description="RANSAC redraws of the matching after a suspect focal length")
        focal_starts: tuple[float, ...] = Field(
            (), max_length=6, description="fields of view (degrees across the larger side) the focal length also starts from without intrinsics; the model with the most views and observations and the lowest reprojection error replaces the prior's when its focal length differs by more than 10% (): COLMAP's prior only"
        )
        prior_fov: float | None = Field(
            65.0,
            gt=0,
            lt=180,
            description="degrees across the larger image side at which a suspect focal length is held when no redraw decides (a typical camera: this benchmark's 64, phones' main cameras 65-70, a RealSense D435's colour camera 69); None: COLMAP's prior, 1.2 x the larger side (45.2)",
        )
        use_poses: bool = Field(True, description="with K and a pose for every view, triangulate with those cameras held fixed instead of estimating them")
        min_span: float = Field(
            MIN_SPAN,
            ge=0,
            lt=180,
            description="degrees: cameras spread over less than this, as seen from the scene, are refused (depth from them is unreliable); 0: run anyway (a warning below 2 degrees)",
        )
        stereo_check: float = Field(
            STEREO_CHECK, ge=0, lt=1, description="a view whose dense stereo covers less than this share of the other views' median is taken as wrongly posed and left out (4 or more views with a stereo neighbour, 3 always kept, the others' median at least 5%; 0: no check)"
        )

        @field_validator("fov_range")
        @classmethod
        def _valid_range(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
            if v is not None and not 0 < v[0] < v[1] < 180:
                raise ValueError(f"expected fov_range (low, high) with 0 < low < high < 180 degrees (got {list(v)})")
            return v

        @field_validator("focal_starts")
        @classmethod
        def _valid_starts(cls, v: tuple[float, ...]) -> tuple[float, ...]:
            if any(not 0 < x < 180 for x in v) or len({f"{x:g}" for x in v}) != len(v):
                raise ValueError(f"expected distinct focal_starts between 0 and 180 degrees (got {list(v)})")
            return v

        @field_validator("camera_model")
        @classmethod
        def _known_model(cls, v: str) -> str:
            if v not in CAMERA_MODELS:
                raise ValueError(f"unknown camera_model {v!r}; choose one of {', '.join(CAMERA_MODELS)}")
            return v

        def run_sfm_kwargs(self) -> dict[str, Any]:
            """The keywords :func:`run_sfm` takes from these options.

            Examples
            --------
            >>> SfmLifter.Options().run_sfm_kwargs()["camera_model"]
            'SIMPLE_PINHOLE'
            """
            seed = 0 if self.seed is None else int(self.seed)
            return {
                "peak_threshold": self.peak_threshold,
                "min_tri_angle": self.min_tri_angle,
                "seed": seed,
                "camera_model": self.camera_model,
                "num_threads": self.num_threads,
                "ransac_seed": self.ransac_seed,
                "fov_range": self.fov_range,
                "redraws": self.redraws,
                "focal_starts": tuple(self.focal_starts),
                "prior_fov": self.prior_fov,
            }

    def reconstruct(self, scene: Scene) -> tuple[SfmReconstruction, dict[str, Any]]:
        """SfM plus scale; raises :class:`SceneError` when fewer than 2 views register (with given cameras: when no point is triangulated)."""
        n = len(scene)
        given = [v.K for v in scene.views]
        Ks = [np.asarray(k) for k in given if k is not None]
        if self.uses_given_poses(scene):
            rec = run_sfm([v.rgb for v in scene.views], Ks, self.options.run_sfm_kwargs(), poses=[np.asarray(v.cam_to_world, np.float64) for v in scene.views])
            if not len(rec.points):
                raise SceneError(
                    "structure from motion triangulated no point with the given cameras (too little texture or overlap, or wrong poses); give depth, or sfm.use_poses=false to estimate the cameras",
                    where=scene.name,
                    field="views",
                )
            return rec, {"metric": True, "factor": 1.0, "method": "the given poses and intrinsics, held fixed (use_poses)"}
        rec = run_sfm([v.rgb for v in scene.views], Ks if len(Ks) == len(given) else None, self.options.run_sfm_kwargs())
        if rec.num_registered < 2 or n < 2:
            missing = [scene.views[i].name for i in range(n) if not rec.registered[i]]
            raise SceneError(not_registered_message(rec.num_registered, n) + (f" (not registered: {', '.join(missing[:6])})" if missing else ""), where=scene.name, field="views")
        return scale_reconstruction(rec, scene)

    def uses_given_poses(self, scene: Scene) -> bool:
        """Whether the cameras of ``scene`` are taken as given (``use_poses`` and every view with ``K`` and ``cam_to_world``)."""
        return bool(self.options.use_poses) and len(scene) >= 2 and all(v.K is not None and v.cam_to_world is not None for v in scene.views)

    def __call__(self, scene: Scene) -> Scene:
        """The lifted scene of the registered views.

        When structure from motion registers only ``k`` of ``n`` views (``k >= 2``),
        the scene keeps the ``k`` registered views; ``meta["dropped_views"]`` names
        the others and ``meta["warnings"]`` holds one line saying so. Registered
        views the stereo check takes as wrongly posed (``stereo_check``) are
        left out too, named in ``meta["dropped_views"]`` and in a line of their own.
        """
        rec, scale = self.reconstruct(scene)
        self._check_span(rec, scene.name)
        names = [v.name for v in scene.views]
        keep = np.flatnonzero(rec.registered)
        unregistered = np.flatnonzero(~rec.registered)
        if unregistered.size:
            scene, rec = scene.select(keep.tolist()), rec.select(keep)
        lifted = self.point_maps(scene, rec, scale)
        bad, check = self._stereo_check(lifted, rec)
        if check is not None:  # the other views' stereo again, without the wrongly posed views as neighbours
            kept = np.setdiff1d(np.arange(len(scene)), bad)
            scene, rec = scene.select(kept.tolist()), rec.select(kept)
            lifted = self.point_maps(scene, rec, scale)
            lifted.meta["sfm"]["registered"] = len(keep)  # what structure from motion registered; the views kept are the scene's
            lifted.meta["sfm"]["stereo_check"] = check
        notes = [registration_warning(rec.info.get("registration"), len(names)), focal_check_warning(rec.info.get("focal_check"))]
        distance = _median_distance(rec)
        span, baseline = camera_span(rec.cam_to_world, distance)
        if span < MIN_SPAN:
            notes.append(short_baseline_warning(span, baseline, distance))
        if unregistered.size:
            notes.append(
                f"structure from motion registered {len(keep)} of {len(names)} views; "
                + (f"segmenting those {len(keep)}" if check is None else f"segmenting {len(scene)} of those (see below)")
                + f", without: {', '.join(names[i] for i in unregistered)}"
            )
        if check is not None:
            notes.append(stereo_check_warning(check))
        dropped = np.union1d(unregistered, keep[bad])  # in the scene's order
        if dropped.size:
            lifted.meta["dropped_views"] = [names[i] for i in dropped]
        if any(notes):
            lifted.meta["warnings"] = [*lifted.meta.get("warnings", []), *(n for n in notes if n)]
        return lifted

    def _check_span(self, rec: SfmReconstruction, where: str) -> None:
        """Raise :class:`SceneError` when the cameras of ``rec`` are spread over less than ``min_span`` degrees (before any stereo)."""
        if not self.options.min_span:
            return
        distance = _median_distance(rec)
        span, baseline = camera_span(rec.cam_to_world, distance)
        if np.isfinite(span) and span < self.options.min_span:
            raise SceneError(short_baseline_refusal(span, baseline, distance), where=where, field="views")

    def _stereo_check(self, lifted: Scene, rec: SfmReconstruction) -> tuple[np.ndarray, dict[str, Any] | None]:
        """The views :func:`stereo_outliers` takes as wrongly posed (indices into ``lifted``'s views) and the record of the check (None when there are none).

        The record's ``median`` is that of the tested views kept, which the warning line reports.
        """
        from .stereo import select_neighbours

        o = self.options
        frac = lifted.meta["sfm"].get("dense_fraction")
        none = np.zeros(0, np.int64)
        if not o.stereo or not o.stereo_check or frac is None or rec.info.get("poses") == "given":  # given poses are not estimates to check
            return none, None
        tested = np.array([len(nb) > 0 for nb in select_neighbours(rec.cam_to_world, max_angle=o.max_pair_angle, max_neighbours=o.max_neighbours)])
        bad = stereo_outliers(frac, tested, o.stereo_check)
        if not bad.size:
            return none, None
        frac = np.asarray(frac, np.float64)
        names = [v.name for v in lifted.views]
        kept = tested.copy()
        kept[bad] = False
        fractions = {names[i]: round(float(frac[i]), 4) for i in np.flatnonzero(tested)}
        return bad, {"ratio": o.stereo_check, "fractions": fractions, "median": round(float(np.median(frac[kept])), 4), "dropped": [names[i] for i in bad]}

    def point_maps(self, scene: Scene, rec: SfmReconstruction, scale: dict[str, Any]) -> Scene:
        """The lifted scene from a (scaled) reconstruction: stereo, triangulated points and fill per view."""
        from .stereo import select_neighbours, sparse_point_maps, stereo_depths

        rgb = [v.rgb for v in scene.views]
        Ks = [np.asarray(k) for k in rec.K]
        poses = [np.asarray(T) for T in rec.cam_to_world]
        dists = [np.asarray(d) for d in rec.dist]
        o = self.options
        h, w = scene.views[0].shape
        if o.stereo:
            ranges = _depth_ranges(rec)
            pts, conf, info = stereo_depths(rgb, Ks, dists, poses, max_pair_angle=o.max_pair_angle, max_neighbours=o.max_neighbours, depth_ranges=ranges)
            if o.consistency:
                pts, conf, info["inconsistent"] = _consistent(pts, conf, rgb, Ks, poses, select_neighbours(poses, max_angle=o.max_pair_angle, max_neighbours=o.max_neighbours))
            if o.transfer:
                from .transfer import transfer_points

                pts, conf, added = transfer_points(
                    pts, conf, rgb, Ks, poses, min_confidence=o.transfer_min_confidence, max_color_distance=o.transfer_color_distance, color_blur=2.0, confidence_out=0.5
                )
                info["transferred_fraction"] = [round(a, 4) for a in added]
        else:
            pts = [np.full((h, w, 3), np.nan, np.float32) for _ in rgb]
            conf = [np.zeros((h, w), np.float32) for _ in rgb]
            info = {}
        seeds = sparse_point_maps(rec.points, rec.observations, (h, w), radius=0)
        sparse = sparse_point_maps(rec.points, rec.observations, (h, w), radius=o.sparse_radius)

        def one_view(i: int) -> tuple[np.ndarray, np.ndarray, float]:
            p = pts[i].copy()
            c = conf[i].copy()
            dense = np.isfinite(p).all(-1)
            seed = ~dense & np.isfinite(seeds[i]).all(-1)
            p[seed] = seeds[i][seed]
            c[seed] = 0.5
            if o.fill:
                p, c = _fill_view(p, c, rgb[i], poses[i], Ks[i], o.fill_confidence, o.fill == "planes")
            rest = ~np.isfinite(p).all(-1) & np.isfinite(sparse[i]).all(-1)
            p[rest] = sparse[i][rest]
            c[rest] = 0.5
            return p, c, float(dense.mean())

        views = []
        extra = {"fill_confidence": float(o.fill_confidence)} if o.fill else {}  # what nothing measured gets (objects.min_measured)
        for i, (v, (p, c, dense_fraction)) in enumerate(zip(scene.views, parallel_map(one_view, range(len(scene))))):  # each view on its own
            views.append(v.replace(points=p, confidence=c, K=Ks[i], cam_to_world=poses[i], meta={**v.meta, "dense_fraction": dense_fraction, **extra}))
        meta = {
            **scene.meta,
            "scale": scale,
            "sfm": {
                "registered": rec.num_registered,
                "views": len(scene),
                "points": int(len(rec.points)),
                "reprojection_error": rec.reprojection_error,
                "poses": rec.info.get("poses", "estimated"),
                **({"focal_check": rec.info["focal_check"]} if "focal_check" in rec.info else {}),
                **({"focal_starts": rec.info["focal_starts"]} if "focal_starts" in rec.info else {}),
                **({"registration": rec.info["registration"]} if rec.info.get("registration") else {}),
                **info,
            },
        }
        return Scene(views, dict(scene.objects), scene.name, meta)
