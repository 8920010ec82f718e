"""`odms-data import odms`, `import odmd`, `import recording`, `import detections` and `import synthia`."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from ..errors import InputError
from ..importers.association import DEFAULT_MIN_IOU
from ..importers.odmd import ODMD_SETS
from ..importers.plan import DEFAULT_THRESHOLD
from ..importers.poses import DEFAULT_MAX_ROTATION, DEFAULT_TIME_TOLERANCE, DIRECTIONS
from ..importers.result import ImportResult
from ..importers.synthia_protocol import (
    CAMERAS,
    PAPER_SELECTION,
    SYNTHIA_POSES,
    PoseConvention,
    Selection,
    parse_classes,
)
from ..protocol import OFFICIAL_SPLITS
from . import echo_json, echo_text, one_line
from .progress import Bars


def _report_skipped(result: ImportResult, what: str) -> None:
    if result.skipped:
        echo_text(f"skipped {len(result.skipped)} {what}:")
        for detail in result.skipped:
            echo_text(f"  {one_line(detail)}")


def _counts(option: str, text: str | None) -> list[int] | None:
    if text is None:
        return None
    try:
        values = [int(t) for t in text.split(",")]
    except ValueError:
        raise InputError(f"{option} '{text}': expected frame counts separated by commas, "
                         "e.g. 10,15,20,25,30") from None
    return values


def _options(*options: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """The options, in this order, as one decorator (those two imports of one's own data share)."""
    def apply(f: Any) -> Any:
        for option in reversed(options):
            f = option(f)
        return f
    return apply


_window_options = _options(
    click.option("--windows", default=None, metavar="N,N,...",
                 help="Windowed examples of these frame counts (robot protocol: 10,15,20,25,30); "
                      "default: one example over all frames."),
    click.option("--n-obs", type=click.IntRange(min=2), default=None,
                 help="Observations per windowed example (default 10)."))
_pose_option = click.option(
    "--pose", type=click.Choice(DIRECTIONS), default="camera-to-world", show_default=True,
    help="What the --poses matrices map (TUM's and KITTI's map the camera to the world).")
_store_options = _options(
    click.option("--d1", type=float, default=None,
                 help="Known depth (m) at the closest frame of a static object; labels every example."),
    click.option("--name", default=None, help="Name used in the store and its example ids "
                 "(default: the output's name)."),
    click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default=None,
                 help="Store backend (default: from the output suffix, else zarr)."),
    click.option("--overwrite", is_flag=True, help="Replace an existing store."))


@click.group("import")
def import_group() -> None:
    """Import real data: the official ODMS release, ODMD's sets, your own recording, SYNTHIA.

    \b
    Examples:
      odms-data import odms ODMS/data -o stores/
      odms-data import odmd ODMD/data -o odmd-stores/
      odms-data import recording masks/ --positions positions.csv -o cup.zarr
      odms-data import detections tracks.txt --track 3 --image-size 640x480 --poses traj.txt
      odms-data import synthia SYNTHIA-SEQS-01-DAWN SYNTHIA-SEQS-02-FOG -o driving.zarr
    """


@import_group.command("odms")
@click.argument("data_dir", type=click.Path())
@click.option("-o", "--output", "out_dir", type=click.Path(), required=True,
              help="Folder for the stores <split>.zarr (or .h5).")
@click.option("--split", "splits", multiple=True, type=click.Choice(OFFICIAL_SPLITS),
              help="Import only this split (repeatable; default: all eight).")
@click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default="zarr", show_default=True,
              help="Store backend.")
@click.option("--overwrite", is_flag=True, help="Replace existing stores.")
@click.option("--skip-bad", is_flag=True,
              help="Leave out bad folders, import the rest and report what was skipped.")
@click.option("--no-verify", is_flag=True,
              help="Accept content that differs from splits/<split>.json (stored as <split>-modified).")
@click.option("--workers", type=click.IntRange(1, 1024), default=None,
              show_default="all cores", help="Decoding processes.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def odms(data_dir, out_dir, splits, fmt, overwrite, skip_bad, no_verify, workers, as_json):
    """Import the official ODMS release into one verified store per split.

    DATA_DIR is the release's data/ folder (val/ and test/ inside), as in the authors'
    repository griffbr/ODMS. Each store is checked against its manifest in splits/. Run again
    after an interruption, it keeps the stores already complete and imports the rest.

    \b
    Example:
      odms-data import odms ODMS/data -o stores/
    """
    from ..importers.release import import_release

    with Bars("importing {}") as bars:
        results = import_release(
            data_dir, out_dir, splits=list(splits) or None, fmt=fmt, overwrite=overwrite,
            progress=bars, skip_bad=skip_bad, verify=not no_verify, workers=workers,
        )
    if as_json:
        echo_json({"stores": [
            {"split": r.attrs.split, "path": r.path, "examples": r.attrs.counts["examples"],
             "frames": r.attrs.counts["frames"], "oddities": len(r.attrs.oddities),
             "matches_manifest": r.matches_manifest, "digest": r.attrs.digest, "skipped": r.skipped,
             "kept": r.kept}
            for r in results]})
        return
    for r in results:
        if r.kept:
            echo_text(f"kept {r.path}: already complete, matches splits/{r.name}.json")
            continue
        verdict = (f"matches splits/{r.name}.json" if r.matches_manifest
                   else f"differs from splits/{r.name}.json, stored as split {r.attrs.split}")
        counts = r.attrs.counts
        echo_text(f"wrote {r.path}: {counts['examples']} examples, {counts['frames']} frames, "
                   f"{len(r.attrs.oddities)} oddities recorded; {verdict}")
        _report_skipped(r, f"folder(s) of {r.name}")


@import_group.command("odmd")
@click.argument("data_dir", type=click.Path())
@click.option("-o", "--output", "out_dir", type=click.Path(), required=True,
              help="Folder for the stores <set>.zarr (or .h5).")
@click.option("--set", "sets", multiple=True, type=click.Choice(list(ODMD_SETS)),
              help="Import only this set (repeatable; default: all sixteen).")
@click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default="zarr", show_default=True,
              help="Store backend.")
@click.option("--overwrite", is_flag=True, help="Replace existing stores.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def odmd(data_dir, out_dir, sets, fmt, overwrite, as_json):
    """Import ODMD's sets (Griffin & Corso, CVPR 2021) into verified stores of boxes.

    DATA_DIR is the data/ folder of the authors' repository griffbr/ODMD (odmd/ and
    odms_detection/ inside): ODMD's eight val/test sets (odmd-normal-val, ...) and its eight
    sets converted from ODMS (odms-detect-robot-val, ...). The pickles are read without running
    any code they carry; each store is checked against its manifest in splits/.

    \b
    Example:
      odms-data import odmd ODMD/data -o odmd-stores/
      odms-data baseline box-ls odmd-stores/odmd-normal-test.zarr -o box-ls.csv
    """
    from ..importers.odmd import import_odmd

    with Bars("importing {}") as bars:
        results = import_odmd(data_dir, out_dir, splits=list(sets) or None, fmt=fmt, overwrite=overwrite,
                              progress=bars)
    if as_json:
        echo_json({"stores": [{"split": r.attrs.split, "path": r.path, **r.attrs.counts,
                               "digest": r.attrs.digest} for r in results]})
        return
    for r in results:
        counts = r.attrs.counts
        echo_text(f"wrote {r.path}: {counts['examples']} examples, {counts['frames']} frames; "
                  f"matches splits/{r.name}.json")


@import_group.command("recording")
@click.argument("mask_dir", type=click.Path())
@click.option("--positions", type=click.Path(), default=None,
              help="CSV with columns frame, z[, depth] (schemas/RECORDING.md); or give --poses.")
@click.option("--poses", type=click.Path(), default=None,
              help="Camera poses instead of --positions: 4x4 matrices (text rows of 16 numbers or .npy), "
                   "KITTI odometry 3x4 rows, or a TUM trajectory (schemas/RECORDING.md).")
@_pose_option
@click.option("--time-tolerance", type=click.FloatRange(min=0), default=DEFAULT_TIME_TOLERANCE,
              show_default=True, help="Seconds between a frame's time (its file name) and its TUM pose.")
@click.option("--max-rotation", type=click.FloatRange(0, 180), default=DEFAULT_MAX_ROTATION,
              show_default=True, help="Degrees an example's frames may turn (--poses); turning more, it is "
                                       "refused and listed.")
@click.option("-o", "--output", type=click.Path(), default=None,
              help="Output store (default: <MASK_DIR name>.zarr).")
@_window_options
@click.option("--threshold", type=click.IntRange(0, 255), default=DEFAULT_THRESHOLD, show_default=True,
              help="Non-binary masks (JPEG, anti-aliased): pixels >= this are object.")
@_store_options
@click.option("--skip-bad", is_flag=True, help="Leave out bad rows and files, report what was skipped.")
@click.option("--workers", type=click.IntRange(1, 1024), default=None,
              show_default="all cores", help="Decoding processes.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def recording(mask_dir, positions, poses, pose, time_tolerance, max_rotation, output, windows, n_obs,
              threshold, d1, name, fmt, overwrite, skip_bad, workers, as_json):
    """Import your own recording: a folder of masks plus the camera position of each.

    Masks are PNG or JPEG files of any segmentation method; unlabelled recordings (no depth
    column, no --d1) are allowed, for a baseline to estimate their depth.

    \b
    Examples:
      odms-data import recording masks/ --positions positions.csv -o cup.zarr
      odms-data import recording masks/ --positions positions.csv --windows 10,15,20,25,30 --n-obs 10
      odms-data import recording masks/ --poses trajectory.txt --d1 0.4 --windows 10,15 --n-obs 10
    """
    from ..importers.recording import import_recording

    if (positions is None) == (poses is None):
        raise InputError("give the camera's --positions (a CSV) or its --poses (a pose file), one of them")
    window_list = _counts("--windows", windows)
    if n_obs is not None and window_list is None:
        raise InputError("--n-obs applies to windowed examples; give --windows too")
    with Bars("importing {}") as bars:
        result = import_recording(
            mask_dir, positions, output, poses=poses, pose=pose, time_tolerance=time_tolerance,
            max_rotation=max_rotation, windows=window_list, n_obs=n_obs or 10, threshold=threshold,
            d1=d1, name=name, fmt=fmt, overwrite=overwrite, skip_bad=skip_bad, workers=workers,
            progress=bars,
        )
    counts = result.attrs.counts
    if as_json:
        echo_json({"output": result.path, "examples": counts["examples"], "labelled": counts["labelled"],
                   "frames": counts["frames"], "digest": result.attrs.digest, "skipped": result.skipped})
        return
    echo_text(f"wrote {result.path}: {counts['examples']} example(s) ({counts['labelled']} labelled), "
               f"{counts['frames']} frames, digest {result.attrs.digest}")
    _report_skipped(result, "row(s) or file(s)" if poses is None else "file(s) or turning example(s)")


def _image_size(text: str | None) -> tuple[int, int] | None:
    """(height, width) from WIDTHxHEIGHT."""
    if text is None:
        return None
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() and len(p.strip()) <= 6 for p in parts):
        raise InputError(f"--image-size '{text[:40]}': expected WIDTHxHEIGHT in pixels, e.g. 640x480")
    return int(parts[1]), int(parts[0])


def _detections_format(given: str | None, path: str) -> str:
    if given is not None:
        return given
    p = Path(path)
    return "yolo" if p.is_dir() else "coco" if p.suffix.lower() == ".json" else "mot"


@import_group.command("detections")
@click.argument("detections", type=click.Path())
@click.option("--from", "source_format", type=click.Choice(["mot", "coco", "yolo"]), default=None,
              help="The detections' format (default: a folder is YOLO, a .json COCO, else MOTChallenge).")
@click.option("--poses", type=click.Path(), required=True,
              help="Camera poses: 4x4 matrices (text rows of 16 numbers or .npy), KITTI odometry 3x4 rows, "
                   "or a TUM trajectory (schemas/RECORDING.md), one per frame or matched by time.")
@_pose_option
@click.option("--track", type=int, default=None, help="The object's track id (MOTChallenge).")
@click.option("--category", type=int, default=None,
              help="The object's category id (COCO, YOLO), chosen by best score and followed by overlap.")
@click.option("--min-iou", type=click.FloatRange(0, 1), default=DEFAULT_MIN_IOU, show_default=True,
              help="Overlap with the box chosen last that continues the object; below it, a miss.")
@click.option("--images", type=click.Path(), default=None,
              help="COCO: the dataset's JSON with its image list; YOLO: the images' folder (their size).")
@click.option("--image-size", default=None, metavar="WxH", help="The images' size (MOTChallenge, YOLO).")
@click.option("--masks", is_flag=True, help="A store of masks from COCO results' RLE segmentations.")
@click.option("--fps", type=float, default=None,
              help="Frame rate: frame k at --start-time + k / fps, to match TUM poses by time.")
@click.option("--start-time", type=float, default=None,
              help="The first frame's time, s (with --fps; default: the first TUM pose's).")
@click.option("--time-tolerance", type=click.FloatRange(min=0), default=DEFAULT_TIME_TOLERANCE,
              show_default=True, help="Seconds between a frame's time and its TUM pose.")
@click.option("--max-rotation", type=click.FloatRange(0, 180), default=DEFAULT_MAX_ROTATION,
              show_default=True, help="Degrees an example's frames may turn; beyond, it is refused, listed.")
@click.option("-o", "--output", type=click.Path(), default=None,
              help="Output store (default: <DETECTIONS name>.zarr).")
@_window_options
@_store_options
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def detections(detections, source_format, poses, pose, track, category, min_iou, images, image_size, masks,
               fps, start_time, time_tolerance, max_rotation, output, windows, n_obs, d1, name, fmt,
               overwrite, as_json):
    """Import a detector's or tracker's boxes of one object and the camera's poses.

    DETECTIONS is a MOTChallenge file (frame,id,x,y,w,h,conf,...), COCO results JSON
    (image_id, category_id, bbox, score) or a folder of YOLO .txt files (class cx cy w h [conf]).
    The object is a track (--track), or the detections of a category (--category) chosen by best
    score in the first frame and followed by overlap; frames where two candidates were close are
    listed. A frame without its box is a missed detection. Boxes become a store of boxes with
    ODMD's camera movement; COCO RLE segmentations, with --masks, a store of masks. Formats and
    rules: docs/DETECTIONS.md.

    \b
    Examples:
      odms-data import detections gt.txt --track 3 --image-size 640x480 --poses tum.txt --fps 30
      odms-data import detections results.json --images instances.json --category 47 --poses c2w.npy
      odms-data import detections labels/ --images frames/ --category 0 --poses kitti.txt \\
          --windows 10,15,20,25,30 --n-obs 10 --d1 0.4 -o cup.zarr
    """
    from ..importers.detections import Camera, Which, import_detections

    window_list = _counts("--windows", windows)
    if n_obs is not None and window_list is None:
        raise InputError("--n-obs applies to windowed examples; give --windows too")
    camera = Camera(Path(poses), pose, fps, start_time, time_tolerance, max_rotation)
    with Bars("importing {}") as bars:
        done = import_detections(
            _detections_format(source_format, detections), detections, camera, output,
            which=Which(track, category, min_iou), images=images, image_size=_image_size(image_size),
            masks=masks, windows=window_list, n_obs=n_obs or 10, d1=d1, name=name, store_format=fmt,
            overwrite=overwrite, progress=bars,
        )
    result, counts = done.result, done.result.attrs.counts
    if as_json:
        echo_json({"output": result.path, "kind": result.attrs.kind, "examples": counts["examples"],
                   "labelled": counts["labelled"], "frames": done.frames, "missed": done.missed,
                   "close": done.close, "digest": result.attrs.digest, "skipped": result.skipped})
        return
    echo_text(f"wrote {result.path}: {counts['examples']} example(s) ({counts['labelled']} labelled) of "
              f"{result.attrs.kind} from {done.frames} frames, digest {result.attrs.digest}")
    echo_text(f"missed detections: {len(done.missed)} frame(s)" + (
        f" ({', '.join(one_line(m) for m in done.missed[:20])}{', ...' if len(done.missed) > 20 else ''})"
        if done.missed else ""))
    if done.close:
        echo_text(f"close choices: {len(done.close)} frame(s) where the rule chose between close candidates:")
        for line in done.close:
            echo_text(f"  {one_line(line)}")
    _report_skipped(result, "turning example(s)")


@import_group.command("synthia")
@click.argument("seq_dirs", nargs=-1, required=True, type=click.Path())
@click.option("-o", "--output", type=click.Path(), required=True, help="Output store (.zarr or .h5).")
@click.option("--camera", type=click.Choice(CAMERAS), default=CAMERAS[0], show_default=True, metavar="CAMERA",
              help="Whose frames to import: Stereo_Left or Stereo_Right / Omni_F, Omni_B, Omni_L or Omni_R.")
@click.option("--classes", default=None, metavar="C,C,...",
              help="Instance classes, by name (car, pedestrian, bicycle) or SYNTHIA class id "
                   "[default: car,pedestrian,bicycle; a class given here must occur].")
@click.option("--frames", default=",".join(map(str, PAPER_SELECTION.frames)), show_default=True,
              metavar="N,N,...", help="Frames per example; several give several windows per closest frame.")
@click.option("--stride", type=click.IntRange(min=1), default=PAPER_SELECTION.stride, show_default=True,
              help="A window starts every STRIDE frames of a track.")
@click.option("--min-area", type=click.IntRange(min=1), default=PAPER_SELECTION.min_area, show_default=True,
              help="Pixels the mask needs at the closest frame.")
@click.option("--no-border", is_flag=True,
              help="Drop windows in which the instance touches the image border.")
@click.option("--no-occluded", is_flag=True, help="Drop windows in which the instance is partly hidden.")
@click.option("--move", nargs=2, type=float, default=PAPER_SELECTION.move, show_default=True,
              metavar="MIN MAX", help="Camera movement z_n - z_1 of an example, m (the paper: 4.2 to 68).")
@click.option("--d1-range", nargs=2, type=float, default=PAPER_SELECTION.d1, show_default=True,
              metavar="MIN MAX", help="Depth at the closest frame, m (the paper: 1.5 to 62).")
@click.option("--max-gap", type=click.IntRange(min=0), default=PAPER_SELECTION.max_gap, show_default=True,
              help="Frames an instance may be absent inside its track (kept as empty masks).")
@click.option("--matrix-order", type=click.Choice(["column-major", "row-major"]), default=SYNTHIA_POSES.order,
              show_default=True, help="Order of the 16 numbers of a CameraParams file.")
@click.option("--pose", type=click.Choice(["camera-to-world", "world-to-camera"]),
              default=SYNTHIA_POSES.direction, show_default=True,
              help="What the CameraParams matrix maps (a wrong one shows where the camera turns: refused).")
@click.option("--forward", type=click.Choice(["-z", "+z"]), default=SYNTHIA_POSES.forward, show_default=True,
              help="The optical axis among the camera's axes in that matrix.")
@click.option("--name", default=None, help="Name used in the store and its example ids "
              "(default: the output's name).")
@click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default=None,
              help="Store backend (default: from the output suffix, else zarr).")
@click.option("--overwrite", is_flag=True, help="Replace an existing store.")
@click.option("--skip-bad", is_flag=True,
              help="Leave out bad frames and sequences, import the rest and report what was skipped.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--workers", type=click.IntRange(1, 1024), default=None,
              show_default="all cores", help="Decoding processes.")
def synthia(seq_dirs, output, camera, classes, frames, stride, min_area, no_border, no_occluded, move,
            d1_range, max_gap, matrix_order, pose, forward, name, fmt, overwrite, skip_bad, as_json, workers):
    """Make driving examples from SYNTHIA-SEQS video sequences, as the ODMS paper did.

    SEQ_DIRS are SYNTHIA-SEQS-XX-SEASON folders (RGB/, Depth/, GT/LABELS/, CameraParams/).
    Each example is one car, pedestrian or bicycle over consecutive frames, closest first, with
    the camera's movement along the optical axis and the object's mean depth per frame; ids are
    the release's folder names, <sequence>_<first frame>_<frames>_<instance>. The protocol, its
    options and SYNTHIA's conventions (with sources): schemas/SYNTHIA.md.

    \b
    Examples:
      odms-data import synthia SYNTHIA-SEQS-01-DAWN -o dawn.zarr
      odms-data import synthia SYNTHIA-SEQS-0* -o driving.zarr --frames 10,15,20 --no-occluded
    """
    from ..importers.synthia import import_synthia

    selection = Selection(
        classes=parse_classes(classes) if classes is not None else PAPER_SELECTION.classes,
        frames=tuple(_counts("--frames", frames) or ()), stride=stride, min_area=min_area,
        border=not no_border, occluded=not no_occluded, move=move, d1=d1_range, max_gap=max_gap,
    )
    with Bars("importing {}") as bars:
        result = import_synthia(
            seq_dirs, output, camera=camera, selection=selection, classes_given=classes is not None,
            convention=PoseConvention(matrix_order, pose, forward), name=name, fmt=fmt, overwrite=overwrite,
            skip_bad=skip_bad, workers=workers, progress=None if as_json else bars,
        )
    assert result.summary is not None  # the SYNTHIA importer always sums up its sequences
    if as_json:
        echo_json(result.summary.to_json())
        return
    for seq in result.summary.sequences:
        def tally(counts: dict[str, int]) -> str:
            return ", ".join(f"{n} {c}" for c, n in counts.items()) or "none"

        echo_text(f"{seq.name}: {seq.frames} frames; tracks: {tally(seq.tracks)}; "
                   f"examples: {tally(seq.examples)}")
    attrs = result.attrs
    echo_text(f"wrote {result.path}: {attrs.counts['examples']} examples, {attrs.counts['frames']} frames, "
               f"{len(attrs.oddities)} oddities recorded, digest {attrs.digest}")
    _report_skipped(result, "frame(s) or sequence(s)")
