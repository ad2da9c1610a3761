"""`lfd-jax grasp IMAGE...`: the grasp in a photo of a hand, by the pipeline of
`experiments.grasp_recognition` (GRASP, Kjellström, Romero & Kragic 2008) run on real photos.

Database: the MuJoCo human hand in each grasp, rendered from an azimuth x elevation grid over the
upper half-sphere (`sim.grasp_views.view_database`, 128 px renders cropped to 64 px, as the study),
and the HOG pyramid of every view (B = 4, L = 3). It is stored once as an `.npz`
(`lfd_common.save_arrays`, kind `DB_KIND`: the views, their HOG features, the grasp classes) and read
on every later call; the default file is `lfd_common.cache_dir("cli") / grasp_db_<size>.npz`.

A photo: the skin model (`skin.py`) -> `hog_jax.find_hands` (skin blobs scored as hands, the
forearm cut off; its defaults were chosen on real frames) -> the skin of the best hand's box, cropped
square (`hog_jax.crop_components`) -> HOG -> exact k-nearest-neighbour vote (`hog_jax.predict`, eq. 3) and the
neighbours' mean orientation (eq. 4). Exact search, not LSH: a few queries against a few thousand
views take milliseconds, and the study found exact and LSH accuracies equal (36.0 / 35.3 %). The
class maps to a robot preshape by `sim.grasp_objects.robot_grasp_for` (MAP 2009 Fig. 2). A photo
where no blob scores as a hand is a row flagged "not found".
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

import hog_jax
from lfd_jax.cli._src.skin import skin_model
from lfd_common import markdown_table, progress
from lfd_jax.grasp._src.knn import hog_features, knn_predict
from lfd_jax.cli._src.plotting import plt
from lfd_common import cache_dir, check_int, enable_compilation_cache, load_arrays, model_path, save_arrays
from sim.grasping import GRASP_NAMES, check_grasp_class, robot_grasp_for
from sim.grasping import ViewDatabase, ViewOptions, view_database

DB_KIND = "lfd_jax.cli.GraspDatabase"
RENDER_SIZE, CROP_SIZE = 128, 64          # experiments.grasp_recognition.Config's render_size and crop_size
HOG = hog_jax.HOGConfig(n_bins=4, n_levels=3)
ROBOT_HANDS = ("barrett", "karlsruhe")
NEIGHBOURS_SHOWN = 6
HAND_OPTIONS = hog_jax.HandOptions(max_hands=1)


class GraspDatabase(NamedTuple):
    """The rendered views (labels index `grasps`), their HOG features (N, D), the grasp classes."""

    views: ViewDatabase
    features: np.ndarray
    grasps: tuple[int, ...]


class GraspResult(NamedTuple):
    """One photo: found (a hand), grasp (Cutkosky number, -1 if not found), euler (3,) radians
    (azimuth, -elevation, roll of the view, NaN if not found), the crop (S, S), the box
    (top, left, bottom, right), the neighbours' database indices and distances (k,)."""

    found: bool
    grasp: int
    euler: np.ndarray
    crop: np.ndarray
    box: np.ndarray
    neighbours: np.ndarray
    distances: np.ndarray


def view_grid(views_per_grasp: int) -> tuple[int, int]:
    """(n_azimuth, n_elevation) with about `views_per_grasp` views in a 4:1 grid (900 -> 60 x 15)."""
    size = check_int(views_per_grasp, "db_size", min_value=1)
    n_elevation = max(1, round(math.sqrt(size / 4)))
    return max(1, round(size / n_elevation)), n_elevation


def parse_grasps(text: str) -> tuple[int, ...]:
    """'1,2,9' -> (1, 2, 9); ValueError naming `grasps` for anything but known Cutkosky numbers."""
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError as err:
        raise ValueError(f"grasps: expected comma-separated grasp numbers, got {text!r}") from err
    if not values:
        raise ValueError("grasps: expected at least one grasp class")
    return tuple(check_grasp_class(v, "grasps") for v in values)


def _settings() -> dict:
    """What a stored database's features depend on besides its grid: the crop and HOG settings."""
    return {"crop_size": CROP_SIZE, "render_size": RENDER_SIZE, "hog": HOG._asdict()}


def build_database(path: Path, grasps: tuple[int, ...], views_per_grasp: int) -> GraspDatabase:
    """Render the views of `grasps`, compute their HOG and write the database to `path`."""
    n_azimuth, n_elevation = view_grid(views_per_grasp)
    views = view_database(grasps, n_azimuth, n_elevation, ViewOptions(render_size=RENDER_SIZE, out_size=CROP_SIZE),
                          cache=False,
                          progress=lambda it, total, desc: progress(it, desc=desc, total=total))
    features = hog_features(views.images, views.masks, np.ones(len(views.labels), bool), HOG)
    save_arrays(path, DB_KIND, {**views._asdict(), "features": features},
                config={"grasps": list(grasps), "n_azimuth": n_azimuth, "n_elevation": n_elevation, **_settings()})
    return GraspDatabase(views, features, grasps)


def load_database(path: Path) -> GraspDatabase:
    """Read a database written by `build_database`.

    Raises:
        ValueError: naming the file when it lacks an array or the `grasps` entry of its config, lists
            grasp classes that are not Cutkosky numbers of `GRASP_NAMES`, or was built with other crop
            or HOG settings than this version uses.
    """
    arrays, config, _ = load_arrays(path, DB_KIND)
    missing = [f"array {name!r}" for name in (*ViewDatabase._fields, "features") if name not in arrays]
    missing += [] if "grasps" in config else ["config entry 'grasps'"]
    if missing:
        raise ValueError(f"db: {path} lacks the {', '.join(missing)} of a grasp database; rebuild it with --build-db")
    grasps = config["grasps"]
    if not isinstance(grasps, list) or not grasps or not all(type(g) is int and g in GRASP_NAMES for g in grasps):
        raise ValueError(f"db: {path} lists grasps {grasps!r}, expected grasp classes among {sorted(GRASP_NAMES)}")
    if {key: config.get(key) for key in _settings()} != _settings():
        raise ValueError(f"db: {path} was built with other crop/HOG settings; rebuild it with --build-db")
    views = ViewDatabase(**{field: arrays[field] for field in ViewDatabase._fields})
    return GraspDatabase(views, arrays["features"], tuple(grasps))


def read_photo(path: Path, max_side: int) -> np.ndarray:
    """(H, W, 3) uint8 RGB, scaled down so that its longer side is at most `max_side`."""
    if not path.is_file():
        raise ValueError(f"image: {path} is not a file")
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"image: OpenCV cannot read {path} as an image")
    scale = max_side / max(bgr.shape[:2])
    if scale < 1.0:
        bgr = cv2.resize(bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def recognise(db: GraspDatabase, knn: hog_jax.KNNModel, skin: hog_jax.SkinModel, photo: np.ndarray,
              k: int) -> GraspResult:
    """Find the hand, describe and classify one photo (H, W, 3)."""
    hands = hog_jax.find_hands(skin, photo[None], HAND_OPTIONS)
    top, left, bottom, right = np.asarray(hands.boxes)[0, 0]
    inside = np.zeros(photo.shape[:2], bool)
    inside[max(top, 0):max(bottom, 0), max(left, 0):max(right, 0)] = bool(np.asarray(hands.found)[0, 0])
    skin_mask = np.asarray(hog_jax.segment(skin, photo[None], threshold=HAND_OPTIONS.threshold).skin)[0]
    gray = (photo.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32))[None] / 255.0
    seg = hog_jax.crop_components(gray, (skin_mask & inside)[None], out_size=CROP_SIZE)
    images, masks, found = np.asarray(seg.images), np.asarray(seg.masks), np.asarray(seg.found)
    labels, euler, _, neighbours, distances = knn_predict(knn, hog_features(images, masks, found, HOG), found, k)
    grasp = db.grasps[labels[0]] if labels[0] >= 0 else -1
    return GraspResult(bool(found[0]), grasp, euler[0], images[0], np.asarray(seg.boxes)[0], neighbours[0],
                       distances[0])


def orientation_text(euler: np.ndarray) -> str:
    """'az A, el E, roll R' in degrees from the view's (azimuth, -elevation, roll) in radians."""
    azimuth, minus_elevation, roll = np.rint(np.degrees(euler)).astype(int)
    return f"az {azimuth % 360}, el {-minus_elevation}, roll {roll}"


def table_row(name: str, result: GraspResult) -> tuple[str, ...]:
    """(image, grasp, Barrett and Karlsruhe preshapes under MAP 2009, orientation, found or not)."""
    if not result.found:
        return (name, "-", "-", "-", "-", "not found (no hand)")
    preshapes = tuple(robot_grasp_for(result.grasp, hand) for hand in ROBOT_HANDS)
    return (name, f"{result.grasp} {GRASP_NAMES[result.grasp]}", *preshapes, orientation_text(result.euler), "found")


def neighbours_figure(name: str, photo: np.ndarray, result: GraspResult, db: GraspDatabase):
    """The photo (the hand's box drawn), its crop and its nearest database views."""
    shown = [j for j in result.neighbours[:NEIGHBOURS_SHOWN] if j >= 0]
    fig, axes = plt.subplots(1, 2 + NEIGHBOURS_SHOWN, figsize=(2.0 * (3 + NEIGHBOURS_SHOWN), 2.8),
                             gridspec_kw={"width_ratios": [2] + [1] * (1 + NEIGHBOURS_SHOWN)})
    for ax in axes:
        ax.axis("off")
    axes[0].imshow(photo)
    if result.found:
        height, width = photo.shape[:2]
        top, bottom = np.clip(result.box[[0, 2]], 0, height - 1)  # the crop's square may reach outside
        left, right = np.clip(result.box[[1, 3]], 0, width - 1)
        axes[0].add_patch(plt.Rectangle((left, top), right - left, bottom - top, fill=False, color="lime", lw=1.5))
    axes[0].set_title(name, fontsize=8)
    axes[1].imshow(result.crop, cmap="gray")
    axes[1].set_title(f"hand crop: grasp {result.grasp}" if result.found else "no hand found", fontsize=8)
    for ax, j, d in zip(axes[2:], shown, result.distances):
        ax.imshow(db.views.images[j], cmap="gray")
        ax.set_title(f"grasp {db.grasps[db.views.labels[j]]}, d={d:.2f}\n{orientation_text(db.views.euler[j])}",
                     fontsize=7)
    fig.tight_layout()
    return fig


def run(args) -> int:
    """The `grasp` subcommand: every photo's row of the table, and its PNG in args.out."""
    photos = [read_photo(path, check_int(args.max_side, "max_side", min_value=16)) for path in args.images]
    grasps = parse_grasps(args.grasps)
    enable_compilation_cache()
    path = model_path(args.db or cache_dir("cli") / f"grasp_db_{check_int(args.db_size, 'db_size', min_value=1)}")
    if args.build_db or not path.exists():
        n_azimuth, n_elevation = view_grid(args.db_size)
        print(f"building the grasp database: {len(grasps)} grasps x {n_azimuth} x {n_elevation} views -> {path}")
        db = build_database(path, grasps, args.db_size)
    else:
        db = load_database(path)
    knn = hog_jax.fit(db.features, db.views.labels, db.views.euler, n_classes=len(db.grasps), seed=0)
    skin = skin_model(args.skin_model, args.skin_data)
    args.out.mkdir(parents=True, exist_ok=True)
    k = check_int(args.k, "k", min_value=1, max_value=len(db.features))
    rows = []
    for image, photo in progress(list(zip(args.images, photos)), desc="photos"):
        result = recognise(db, knn, skin, photo, k)
        rows.append(table_row(image.name, result))
        figure = neighbours_figure(image.name, photo, result, db)
        figure.savefig(args.out / f"{image.stem}_grasp.png", dpi=100)
        plt.close(figure)
    print(f"database: {path} ({len(db.features)} views of grasps {', '.join(map(str, db.grasps))})")
    print(markdown_table(("image", "grasp", "Barrett preshape", "Karlsruhe preshape", "hand orientation (deg)",
                          "hand"), rows))
    print(f"wrote {len(rows)} PNG file(s) to {args.out}/")
    return 0
