"""The `lfd-jax` argument parser and its error handling.

The parser is built from argparse alone: each subcommand's work lives in its own module
(`grasp`, `phmm`, `video`), imported only once that subcommand runs, so that `lfd-jax --help`
answers without loading JAX, MuJoCo or OpenCV. Bad input (a missing file, a file of the wrong
format, an unknown grasp class, a bad config) ends in one line on stderr, `lfd-jax: error: ...`,
and exit status 2, the status argparse gives to a bad command line.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from pathlib import Path

PROG = "lfd-jax"
DEFAULT_DATA = "../shared/data"  # the project's real data, relative to the project root (../shared/data/README.md)
USAGE_ERROR = 2


def existing_path(text: str) -> Path:
    """An argparse type: the path, which must exist (checked before any subcommand loads JAX)."""
    path = Path(text)
    if not path.exists():
        raise argparse.ArgumentTypeError(f"no such file or folder {path}")
    return path


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (argparse's own print the usage first)."""

    def error(self, message: str):
        self.exit(USAGE_ERROR, f"{PROG}: error: {message} (see {self.prog} --help)\n")


def _add_skin_data(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--skin-data", type=Path, default=Path(DEFAULT_DATA), metavar="DIR",
                        help=f"folder holding skin_nonskin_uci.tsv (UCI Skin Segmentation: 'B G R label' per line, "
                             f"label 1 skin, 2 not), from which {what} is fitted (default {DEFAULT_DATA})")


def _grasp_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "grasp", help="grasp class, robot preshape and hand orientation of photos of a hand",
        description="Skin segmentation -> HOG pyramid -> k nearest views of a rendered grasp database "
                    "(GRASP, Kjellstrom et al. 2008) -> the grasp class (Cutkosky number), the orientation of the "
                    "hand relative to the camera (the matched views' azimuth, elevation and roll) and the preshape "
                    "the class maps to on the Barrett and the Karlsruhe hand (MAP 2009 Fig. 2). Prints a table and "
                    "writes DIR/<image>_grasp.png: the photo, its hand crop and its nearest database views. A photo "
                    "without a skin blob is reported 'not found', never given a default grasp.")
    p.add_argument("images", nargs="+", type=existing_path, metavar="IMAGE", help="photos (any format OpenCV reads)")
    p.add_argument("--db", type=Path, default=None, metavar="PATH",
                   help="the grasp database file (.npz); default: lfd_common.cache_dir('cli')/grasp_db_<size>.npz. "
                        "Built there on first use, read afterwards")
    p.add_argument("--build-db", action="store_true", help="(re)build the database even if the file exists")
    p.add_argument("--db-size", type=int, default=900, metavar="N",
                   help="views per grasp: an azimuth x elevation grid over the upper half-sphere, about 4:1 "
                        "(900 = 60 x 15, the paper's 6-degree steps; 20 = 10 x 2 renders in seconds). The default "
                        "--db file is one per size; an existing --db file keeps the size it was built with")
    p.add_argument("--grasps", default="1,2,4,9,10,12", metavar="LIST",
                   help="grasp classes of a database being built (Cutkosky numbers, default all six: 1,2,4,9,10,12)")
    p.add_argument("-k", type=int, default=10, help="neighbours that vote (default 10)")
    p.add_argument("--max-side", type=int, default=640, metavar="PX",
                   help="photos larger than this are scaled down to it first (default 640)")
    p.add_argument("--skin-model", type=existing_path, default=None, metavar="PATH",
                   help="a skin model saved by hog_jax.save_skin_model (its threshold is used); "
                        "default: fitted from --skin-data")
    _add_skin_data(p, "the skin model (with the HGR hand photos when the folder holds hgr_hands/)")
    p.add_argument("--out", type=Path, default=Path("runs/cli_grasp"), metavar="DIR",
                   help="where the PNGs go (default runs/cli_grasp)")
    p.set_defaults(command="grasp")


def _phmm_parsers(subparsers) -> None:
    phmm = subparsers.add_parser(
        "phmm", help="fit HMMs of movement classes on marker files or 2-D keypoint tracks, and recognise "
                     "movements with them",
        description="Marker files in any format lfd_jax.load_markers reads (Vicon Nexus .csv, "
                    ".trc, .c3d; .csv.xz / .trc.xz), or 2-D keypoint tracks: a folder of OpenPose "
                    "*_keypoints.json files (one video), a reach-to-grasp CSV or the reach npz "
                    "(lfd_jax.load_reach_npz) -> per input the chosen markers' positions in metres (keypoints: "
                    "pixels), short gaps filled, resampled to a fixed length -> one explicit-duration HMM of "
                    "phmm_jax per class.")
    actions = phmm.add_subparsers(dest="action", required=True, metavar="{fit,recognize}", parser_class=OneLineParser)
    label_help = ("a regular expression whose first group, searched in each file name (OpenPose folder name, "
                  "reach movement name), is its class; with it DIR is searched recursively and inputs it does not "
                  "match are skipped")
    movements_help = ("with a reach .npz: a regular expression searched in the movement names (e.g. '^P[1-3]_'); "
                      "only those movements are read (default all)")
    fit = actions.add_parser(
        "fit", help="fit one HMM per class",
        description="Fit one HMM per class. Classes: DIR/<class>/<marker files or OpenPose folders> (one "
                    "folder per class), or the --label expression; DIR may be a reach .npz file (one input per "
                    "movement, its class the object size S/M/L unless --label). Writes the model folder OUT: "
                    "one phmm_jax.save file per class "
                    "(<class>.npz; a phmm_jax file holds one model) and model.json (the classes, the markers "
                    "and the preprocessing that recognize repeats). Settings: defaults < --config JSON < flags.")
    fit.add_argument("dir", type=existing_path, metavar="DIR",
                     help="the training inputs (see --label), or a reach .npz")
    fit.add_argument("--out", type=Path, required=True, metavar="OUT", help="the model folder to write")
    fit.add_argument("--label", default=None, metavar="REGEX", help=label_help)
    fit.add_argument("--config", type=existing_path, default=None, metavar="JSON",
                     help="a JSON object with any of the settings below (snake_case keys, e.g. "
                          '{"n_states": 10, "max_duration": null, "markers": ["RFTP"]})')
    fit.add_argument("--n-states", type=int, help="HMM states (default 20)")
    fit.add_argument("--min-duration", type=int, help="frames a path stays in a state at least (default 4)")
    fit.add_argument("--max-duration", type=int,
                     help="frames a path stays in a state at most (default 6; 0: the classical HMM with self-loops)")
    fit.add_argument("--covariance-type", choices=("full", "diag"), help="state covariances (default diag)")
    fit.add_argument("--max-iter", type=int, help="EM iterations at most (default 50)")
    fit.add_argument("--reg-covar", type=float,
                     help="added to every variance, in m^2 (px^2 for keypoints) (default 1e-4)")
    fit.add_argument("--n-frames", type=int, help="every file resampled to this many frames (default 100; 0: as recorded)")
    fit.add_argument("--max-gap-s", type=float,
                     help="gaps up to this long are filled by linear interpolation, longer ones are an error "
                          "(default 0.2 s; 0: no gap allowed)")
    fit.add_argument("--markers", help="comma-separated marker names (default: every marker seen in all files)")
    fit.add_argument("--relative-to", metavar="MARKER",
                     help="subtract this marker's position frame by frame (e.g. a sternum marker, or Neck)")
    fit.add_argument("--rate-hz", type=float,
                     help="frame rate of OpenPose folders, whose JSON does not hold one (default 30)")
    fit.add_argument("--person", type=int,
                     help="OpenPose folders: take the k-th entry of 'people' in every frame (default: follow the "
                          "most confident person of the first frame, then the one nearest its last pose)")
    fit.add_argument("--min-confidence", type=float,
                     help="keypoints with a confidence at or below this are misses (default 0: only c = 0)")
    fit.add_argument("--reach-phase", action="store_true", default=None,
                     help="reach npz: keep only each movement's annotated reach-to-grasp phase (onset to contact)")
    fit.add_argument("--movements", default=None, metavar="REGEX", help=movements_help)
    fit.set_defaults(command="phmm", run="fit")
    recognize = actions.add_parser(
        "recognize", help="the class of each marker file or keypoint track under fitted HMMs",
        description="Print, per file, the most likely class and the log-likelihood under each class's HMM "
                    "(inputs read and preprocessed as at fit time). With --label, or for reach npz movements, "
                    "also the true class and the accuracy.")
    recognize.add_argument("model", type=existing_path, metavar="MODEL", help="a model folder written by 'lfd-jax phmm fit'")
    recognize.add_argument("files", nargs="+", type=existing_path, metavar="FILE",
                           help="marker files, OpenPose folders, reach CSVs or a reach .npz")
    recognize.add_argument("--movements", default=None, metavar="REGEX", help=movements_help)
    recognize.add_argument("--label", default=None, metavar="REGEX",
                           help="a regular expression whose first group, searched in each file name, is its true class")
    recognize.set_defaults(command="phmm", run="recognize")


def _video_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "video", help="skin / person / object segmentation and hand and face tracking of a video",
        description="The vision pipeline of hog_jax.video (LEVELSET TR) on a recording, read and processed in "
                    "chunks (memory holds one chunk): a background model (for real camera video by default: "
                    "Stauffer-Grimson with a warm-up, shadows and a 3 x 3 median, chosen on real sequences), "
                    "person and background colour models from the 10 frames before --start (what moves there "
                    "is the person), the skin model fitted on real skin pixels (--skin-data or --skin-model), "
                    "competing level sets, and alpha-beta tracking of the skin blobs as face, hand and other "
                    "hand, the hands placed at the far end of bare-forearm blobs. Writes OUT/overlay.mp4 "
                    "(labels tinted: person orange, skin red, object blue; face and hands marked), "
                    "OUT/sheet.png and OUT/tracks.csv.")
    p.add_argument("video", type=existing_path, metavar="VIDEO",
                   help="a video file OpenCV reads (an animated GIF too), or a folder of images")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--right", type=existing_path, default=None, metavar="VIDEO",
                   help="the right view of a rectified stereo pair (then also the 3-D hand-minus-face position)")
    p.add_argument("--focal-px", type=float, default=None, help="focal length in pixels (with --right)")
    p.add_argument("--baseline-m", type=float, default=None, help="stereo baseline in metres (with --right)")
    p.add_argument("--start", type=int, default=None,
                   help="the first segmented frame (default: a third of the clip, at least 11, at most 250)")
    p.add_argument("--max-frames", type=int, default=None, help="read at most this many frames")
    p.add_argument("--width", type=int, default=None, help="scale the frames to this width first (keeps the aspect)")
    p.add_argument("--fps", type=float, default=None, help="frame rate of the overlay (default: the video's, else 25)")
    p.add_argument("--chunk", type=int, default=32, help="frames read and segmented at a time (default 32)")
    p.add_argument("--tr-background", action="store_true",
                   help="the TR's Stauffer-Grimson background model (alpha 0.05, K = 3) instead of the one for real "
                        "camera video (for rendered recordings with an empty-scene start)")
    p.add_argument("--skin-model", type=existing_path, default=None, metavar="PATH",
                   help="a skin model saved by hog_jax.save_skin_model; default: fitted from --skin-data")
    _add_skin_data(p, "the skin model (with the HGR hand photos when the folder holds hgr_hands/)")
    p.set_defaults(command="video")


def build_parser() -> argparse.ArgumentParser:
    """The `lfd-jax` argument parser.

    Returns:
        The parser with its subcommands grasp, phmm {fit, recognize} and video; its errors are one
        line and exit status 2.
    """
    parser = OneLineParser(prog=PROG, description="lfd-jax on one's own data: grasps in photos, HMMs of "
                                                  "marker recordings, segmentation and tracking in video.")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="{grasp,phmm,video}",
                                       parser_class=OneLineParser)
    _grasp_parser(subparsers)
    _phmm_parsers(subparsers)
    _video_parser(subparsers)
    return parser


def _one_line(err: BaseException) -> str:
    lines = str(err).strip().splitlines()
    return lines[0] if lines else type(err).__name__


def main(argv: Sequence[str] | None = None) -> int:
    """Run `lfd-jax`.

    Args:
        argv: the arguments after the program name (None: the command line).

    Returns:
        The exit status: 0 on success, 2 for bad input (one line on stderr: `lfd-jax: error: ...`).
    """
    args = build_parser().parse_args(argv)
    try:
        module = importlib.import_module(f"lfd_jax.cli._src.{args.command}")
        return int(module.run(args) or 0)
    except (ValueError, OSError) as err:
        print(f"{PROG}: error: {_one_line(err)}", file=sys.stderr)
        return USAGE_ERROR
