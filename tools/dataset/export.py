"""``lookahead export-dataset``: labelled image datasets from rendered scenario runs.

Each scenario runs in closed loop (``sim.runner.Runner``, rendering on) with an
``ExportSink`` that, on every ``every``-th camera frame (frame index % every ==
0), writes the RGB image and the ground-truth labels of that frame. Labelled
objects: detection classes (``class_id >= 0``, names ``perception.detections.
CLASSES``) with a visible box of positive area (``visible_fraction > 0``); boxes
are the *visible* boxes (tight box of the actor's segmentation pixels), xyxy px.
File names depend only on the scenario name and frame index (deterministic).

Formats (``out`` layout):

* ``yolo``: ``images/{seq}_{frame:06d}.png``, ``labels/{seq}_{frame:06d}.txt``
  (``class cx cy w h``, normalised to [0, 1], 6 decimals; an empty file for a
  frame without objects), ``data.yaml`` (``train``/``val`` = ``images``
  relative to the YAML, ``nc``, ``names``, and ``attributes``, the sidecar
  directory). The label files stay standard 5-column YOLO; what YOLO has no
  column for is in the sidecar ``attributes/{seq}_{frame:06d}.json`` (one per
  image, a separate directory so YOLO loaders never see it): a JSON list whose
  item k describes line k of the label file -- ``actor_id`` (= the COCO
  ``track_id``), ``name``, ``class_id``, ``subtype``, ``occlusion`` (1 -
  visible_fraction), ``truncation`` (share of the amodal box outside the image),
  both 3 decimals as in COCO, and ``range_m`` (nearest point's x, 3 decimals).
* ``coco``: ``images/{seq}_{frame:06d}.png`` and ``annotations.json``: images
  (1-based ids, with ``sequence``, ``frame_index``, ``t``), annotations (``bbox``
  [x, y, w, h] px, ``area``, ``iscrowd`` 0, ``track_id`` = actor id,
  ``occlusion`` = 1 - visible_fraction, ``truncation`` = share of the amodal box
  outside the image, ``attributes`` with both plus name, subtype, range),
  categories with ``id = class_id + 1`` (COCO ids start at 1).
* ``mot``: one MOTChallenge sequence per scenario, ``{seq}/img1/{n:06d}.jpg``,
  ``{seq}/gt/gt.txt`` rows ``frame,id,x,y,w,h,1,class,visibility`` (frame ``n``
  = 1-based count of exported frames, id = actor id, box top-left + size px,
  class = ``class_id + 1`` -- so pedestrian = 1 as in MOT16+ -- visibility =
  visible_fraction) and ``{seq}/seqinfo.ini`` (frameRate = camera rate / every,
  plus a ``classes`` key listing the class names in class-id order).
* ``study``: the CARLA study's layout: ``images/{seq}_frame_{frame:06d}.jpg``
  and ``labels/{seq}_frame_{frame:06d}.json``, a JSON list with one object per
  actor: ``bbox`` (the 4 corners of the visible box, top-left first, clockwise,
  px), ``speed_m_s`` (ground speed), ``tracked_id`` (id of the confirmed track
  matched to the actor this frame by one-to-one IoU >= 0.5, else null), plus
  ``class``, ``class_id``, ``distance_m`` (range, nearest point's x),
  ``actor_id``, ``name``.

Box coordinates are written with 2 decimals (YOLO: 6 decimals normalised), so
re-read boxes are within 0.01 px of the ground truth.

File and directory names made from user data (scenario names, a generator's
``name`` and split names) go through ``safe_file_stem``: only ``[A-Za-z0-9._-]``
are kept (others become ``_``, leading dots are dropped, the length is capped),
and a name that had to be changed gets a short hash of the original, so distinct
names (``base[v=1]``, ``base[v=2]``) stay distinct; every path is checked to lie
inside ``--out`` (``inside``).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path

import cv2
import numpy as np
import yaml
from pydantic import ValidationError

from lookahead.perception.detections import CLASSES
from lookahead.perception.tracker import TrackState
from lookahead.sim.records import Sink, TickRecord
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import Scenario, load_scenario
from lookahead.tools.dataset.scene_gen import (
    CameraRandom,
    GeneratorSpec,
    SplitSpec,
    generate_scenario,
    is_generator,
    load_generator,
    overlapping_split,
    split_seeds,
)
from lookahead.tools.runs.inputs import is_suite, load_suite, read_yaml
from lookahead.tools.scoring.matching import class_iou, hungarian_match
from lookahead.tools.sinks.rundir import OutputError, inside, prepare_dir, safe_file_stem

log = logging.getLogger(__name__)

FORMATS = ("yolo", "coco", "mot", "study")
JPEG_QUALITY = 95


@dataclass(frozen=True)
class ObjectLabel:
    """One labelled object of a frame (ego frame, SI; box in px)."""

    actor_id: int
    name: str
    cls: str
    class_id: int
    subtype: str
    xyxy: tuple[float, float, float, float]
    visible_fraction: float
    truncation: float
    range_m: float
    speed_m_s: float
    tracked_id: int | None


def frame_labels(rec: TickRecord) -> list[ObjectLabel]:
    """The labelled objects of one frame (module docstring), with matched confirmed tracks."""
    gt = rec.ground_truth
    vis = np.asarray(gt.visible, dtype=np.float64).reshape(-1, 4)
    keep = (
        (np.asarray(gt.class_id) >= 0) & np.all(np.isfinite(vis), axis=1)
        & (np.asarray(gt.visible_fraction) > 0)
        & (vis[:, 2] > vis[:, 0]) & (vis[:, 3] > vis[:, 1])
    )
    idx = np.flatnonzero(keep)
    tracked: dict[int, int] = {}
    tr = rec.tracks
    if tr is not None and len(tr.track_id) and len(idx):
        conf = np.asarray(tr.state) == int(TrackState.CONFIRMED)
        rows, cols = hungarian_match(class_iou(tr.xyxy[conf], None, vis[idx], None))
        ids = np.asarray(tr.track_id)[conf]
        tracked = {int(idx[c]): int(ids[r]) for r, c in zip(rows, cols, strict=True)}
    speed = np.linalg.norm(np.asarray(gt.velocity, dtype=np.float64).reshape(-1, 2), axis=1)
    return [
        ObjectLabel(
            actor_id=int(gt.actor_id[i]), name=str(gt.name[i]), cls=str(gt.cls[i]),
            class_id=int(gt.class_id[i]), subtype=str(gt.subtype[i]),
            xyxy=tuple(float(v) for v in vis[i]),  # type: ignore[arg-type]
            visible_fraction=float(gt.visible_fraction[i]), truncation=float(gt.truncation[i]),
            range_m=float(gt.range[i]), speed_m_s=float(speed[i]), tracked_id=tracked.get(int(i)),
        )
        for i in idx.tolist()
    ]


def _write_image(path: Path, rgb: np.ndarray) -> None:
    params = [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY] if path.suffix == ".jpg" else []
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), params):
        raise OutputError(f"{path}: could not write image")


def _r2(x: float) -> float:
    return round(float(x), 2)


@dataclass
class _Seq:
    """What a writer knows of the sequence (scenario) being exported."""

    name: str
    width: int
    height: int
    rate: float
    frames: int = 0
    objects: int = 0

    @property
    def stem(self) -> str:
        """The name as used in file names (``safe_file_stem``)."""
        return safe_file_stem(self.name)


class Writer:
    """Base dataset writer: one call per exported frame, then ``finish``."""

    image_ext = ".png"

    def __init__(self, out: Path) -> None:
        self.out = out
        self.seq: _Seq | None = None
        self.sequences: list[_Seq] = []

    def begin(self, seq: _Seq) -> None:
        self.seq = seq
        self.sequences.append(seq)
        inside(self.out, self.out / seq.stem)

    def write(self, rec: TickRecord, labels: list[ObjectLabel]) -> None:
        raise NotImplementedError

    def end(self) -> None: ...

    def finish(self) -> None: ...

    def _image(self, path: Path, rec: TickRecord) -> None:
        if rec.frame.image is not None:
            _write_image(path, rec.frame.image)


class YoloWriter(Writer):
    ATTRIBUTES = "attributes"  # sidecar directory (module docstring)

    def __init__(self, out: Path) -> None:
        super().__init__(out)
        self.images, self.labels = prepare_dir(out / "images"), prepare_dir(out / "labels")
        self.attributes = prepare_dir(out / self.ATTRIBUTES)

    def write(self, rec: TickRecord, labels: list[ObjectLabel]) -> None:
        s = self.seq
        stem = f"{s.stem}_{rec.frame_index:06d}"
        self._image(self.images / f"{stem}{self.image_ext}", rec)
        lines, attrs = [], []
        for o in labels:
            x0, y0, x1, y1 = o.xyxy
            cx, cy = (x0 + x1) / 2 / s.width, (y0 + y1) / 2 / s.height
            w, h = (x1 - x0) / s.width, (y1 - y0) / s.height
            lines.append(f"{o.class_id} {cx:.6f} {cy:.6f} {w:.6f} {h:.6f}\n")
            attrs.append({"actor_id": o.actor_id, "name": o.name, "class_id": o.class_id, "subtype": o.subtype,
                          "occlusion": round(1.0 - o.visible_fraction, 3), "truncation": round(o.truncation, 3),
                          "range_m": round(o.range_m, 3)})
        (self.labels / f"{stem}.txt").write_text("".join(lines))
        (self.attributes / f"{stem}.json").write_text(json.dumps(attrs, ensure_ascii=False) + "\n")

    def finish(self) -> None:
        data = {"train": "images", "val": "images", "nc": len(CLASSES), "names": dict(enumerate(CLASSES)),
                "attributes": self.ATTRIBUTES}
        (self.out / "data.yaml").write_text(
            "# lookahead export-dataset (YOLO); paths relative to this file\n" + yaml.safe_dump(data, sort_keys=False)
        )


class CocoWriter(Writer):
    def __init__(self, out: Path) -> None:
        super().__init__(out)
        self.images_dir = prepare_dir(out / "images")
        self.images: list[dict] = []
        self.annotations: list[dict] = []

    def write(self, rec: TickRecord, labels: list[ObjectLabel]) -> None:
        s = self.seq
        name = f"{s.stem}_{rec.frame_index:06d}{self.image_ext}"
        self._image(self.images_dir / name, rec)
        image_id = len(self.images) + 1
        self.images.append({
            "id": image_id, "file_name": f"images/{name}", "width": s.width, "height": s.height,
            "sequence": s.name, "frame_index": rec.frame_index, "t": round(rec.t, 4),
        })
        for o in labels:
            x0, y0, x1, y1 = o.xyxy
            w, h = _r2(x1 - x0), _r2(y1 - y0)
            occlusion, trunc = round(1.0 - o.visible_fraction, 3), round(o.truncation, 3)
            self.annotations.append({
                "id": len(self.annotations) + 1, "image_id": image_id, "category_id": o.class_id + 1,
                "bbox": [_r2(x0), _r2(y0), w, h], "area": round(w * h, 2), "iscrowd": 0,
                "track_id": o.actor_id, "occlusion": occlusion, "truncation": trunc,
                "attributes": {"occlusion": occlusion, "truncation": trunc, "name": o.name,
                               "subtype": o.subtype, "range_m": round(o.range_m, 3)},
            })

    def finish(self) -> None:
        doc = {
            "info": {"description": "lookahead export-dataset (COCO), visible boxes",
                     "sequences": [s.name for s in self.sequences]},
            "images": self.images,
            "annotations": self.annotations,
            "categories": [{"id": i + 1, "name": n, "supercategory": "object"} for i, n in enumerate(CLASSES)],
        }
        (self.out / "annotations.json").write_text(json.dumps(doc, indent=1) + "\n")


class MotWriter(Writer):
    image_ext = ".jpg"

    def __init__(self, out: Path, every: int) -> None:
        super().__init__(out)
        self.every = every
        self.rows: list[str] = []

    def begin(self, seq: _Seq) -> None:
        super().begin(seq)
        self.dir = prepare_dir(inside(self.out, self.out / seq.stem))
        self.img1, self.gt = prepare_dir(self.dir / "img1"), prepare_dir(self.dir / "gt")
        self.rows = []

    def write(self, rec: TickRecord, labels: list[ObjectLabel]) -> None:
        n = self.seq.frames + 1  # 1-based count of exported frames
        self._image(self.img1 / f"{n:06d}{self.image_ext}", rec)
        for o in labels:
            x0, y0, x1, y1 = o.xyxy
            self.rows.append(f"{n},{o.actor_id},{_r2(x0)},{_r2(y0)},{_r2(x1 - x0)},{_r2(y1 - y0)},1,"
                             f"{o.class_id + 1},{round(o.visible_fraction, 3)}\n")

    def end(self) -> None:
        s = self.seq
        (self.gt / "gt.txt").write_text("".join(self.rows))
        rate = max(1, round(s.rate / self.every))
        (self.dir / "seqinfo.ini").write_text(
            f"[Sequence]\nname={s.stem}\nimDir=img1\nframeRate={rate}\nseqLength={s.frames}\n"
            f"imWidth={s.width}\nimHeight={s.height}\nimExt={self.image_ext}\n"
            f"classes={','.join(CLASSES)}\n"
        )


class StudyWriter(Writer):
    image_ext = ".jpg"

    def __init__(self, out: Path) -> None:
        super().__init__(out)
        self.images, self.labels = prepare_dir(out / "images"), prepare_dir(out / "labels")

    def write(self, rec: TickRecord, labels: list[ObjectLabel]) -> None:
        stem = f"{self.seq.stem}_frame_{rec.frame_index:06d}"
        self._image(self.images / f"{stem}{self.image_ext}", rec)
        items = []
        for o in labels:
            x0, y0, x1, y1 = (_r2(v) for v in o.xyxy)
            items.append({
                "bbox": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]],
                "speed_m_s": round(o.speed_m_s, 2), "tracked_id": o.tracked_id,
                "class": o.cls, "class_id": o.class_id, "distance_m": round(o.range_m, 2),
                "actor_id": o.actor_id, "name": o.name,
            })
        (self.labels / f"{stem}.json").write_text(json.dumps(items, indent=2, ensure_ascii=False) + "\n")


def make_writer(fmt: str, out: Path, every: int) -> Writer:
    if fmt == "yolo":
        return YoloWriter(out)
    if fmt == "coco":
        return CocoWriter(out)
    if fmt == "mot":
        return MotWriter(out, every)
    if fmt == "study":
        return StudyWriter(out)
    raise ValueError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")


@dataclass
class ExportSink:
    """Runner sink: every ``every``-th camera frame goes to ``writer``."""

    writer: Writer
    seq: _Seq
    every: int
    images: int = 0
    missing_images: int = field(default=0)

    def on_start(self, info: dict) -> None:
        self.writer.begin(self.seq)

    def on_tick(self, rec: TickRecord) -> None:
        if rec.frame_index % self.every:
            return
        labels = frame_labels(rec)
        self.writer.write(rec, labels)
        self.seq.frames += 1
        self.seq.objects += len(labels)
        self.images += rec.frame.image is not None
        self.missing_images += rec.frame.image is None

    def on_end(self, summary: dict) -> None:
        self.writer.end()


def export_scenarios(
    scenarios: Sequence[Scenario], fmt: str, every: int, out: Path, render: bool = True,
    extra_sinks: Sequence[Sink] = (),
) -> dict:
    """Run each scenario and export every ``every``-th frame into ``out`` (``extra_sinks``
    are given to every run, e.g. to keep a run directory). Returns a summary dict."""
    if every < 1:
        raise ValueError(f"--every: expected an integer >= 1, got {every}")
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise ValueError(f"scenario names must be unique in one export, got {names}")
    stems = [safe_file_stem(n).lower() for n in names]  # a case-insensitive file system too
    if len(set(stems)) != len(stems):
        raise ValueError(f"scenario names must give distinct file names in one export, got {names}")
    out = prepare_dir(Path(out))
    writer = make_writer(fmt, out, every)
    seqs = _run_export(scenarios, writer, every, render, extra_sinks)
    writer.finish()
    return {
        "format": fmt, "out": str(out), "every": every, "sequences": seqs,
        "frames": sum(s["frames"] for s in seqs), "objects": sum(s["objects"] for s in seqs),
    }


def _export_chunk(spec: GeneratorSpec, seeds: list[int], weather: str | None, fmt: str, every: int,
                  out: str) -> tuple[list[dict], list[dict], list[dict]]:
    """A worker's job: export the generated scenes ``seeds`` of ``spec`` (as resolved by the
    caller: seed ranges and camera overridden) into ``out``.

    Returns (sequence summaries, COCO images, COCO annotations) -- the COCO lists
    (empty for other formats) are merged and renumbered by the caller.
    """
    scenarios = [generate_scenario(spec, s, weather) for s in seeds]
    writer = make_writer(fmt, Path(out), every)
    seqs = _run_export(scenarios, writer, every, render=True)
    if isinstance(writer, CocoWriter):
        return seqs, writer.images, writer.annotations
    return seqs, [], []


def _run_export(scenarios: Sequence[Scenario], writer: Writer, every: int, render: bool,
                extra_sinks: Sequence[Sink] = ()) -> list[dict]:
    seqs = []
    for sc in scenarios:
        seq = _Seq(sc.name, sc.camera.width, sc.camera.height, float(sc.camera.rate))
        sink = ExportSink(writer, seq, every)
        Runner(sc, sinks=[sink, *extra_sinks], render=render).run()
        if sink.missing_images:
            log.warning("%s: %d frame(s) without an image (render off?)", sc.name, sink.missing_images)
        seqs.append({"name": seq.name, "frames": seq.frames, "images": sink.images, "objects": seq.objects})
        log.info("%s: %d frames, %d objects", sc.name, seq.frames, seq.objects)
    return seqs


def export_generated(
    gen_path: Path, fmt: str, every: int, out: Path, splits: Sequence[str] | None = None,
    weather: str | None = None, workers: int = 1, chunk: int = 8, progress=None,
    seeds: tuple[int, int] | None = None, camera: tuple[int, int] | None = None,
) -> dict:
    """Export the scenes of a generator file (``tools.dataset.scene_gen``), one dataset per split in
    ``out/<split>``; ``weather`` forces one weather kind on every scene (same scenes).
    ``seeds`` [first, last) replaces the seed range of the one split exported (more scenes
    of it, e.g. a second training set); it must not overlap another split's range.
    ``camera`` (width, height) px replaces the file's camera resolution: the same scenes,
    field of view and mount, seen with more or fewer pixels.

    Scenes run on a process pool of ``workers`` in chunks of ``chunk`` seeds; the
    result does not depend on ``workers`` (COCO ids follow seed order).
    """
    if every < 1:
        raise ValueError(f"--every: expected an integer >= 1, got {every}")
    spec = load_generator(gen_path)
    splits = list(splits or spec.splits)
    if seeds is not None:
        spec = with_split_seeds(spec, splits, seeds, gen_path)
    if camera is not None:
        spec = with_camera(spec, camera)
    split_list = {sp: list(split_seeds(spec, sp)) for sp in splits}  # validates the split names
    for sp in splits:  # validate a scene of each split (and the weather name) before running anything
        generate_scenario(spec, split_list[sp][0], weather)
    out = prepare_dir(Path(out))
    result: dict = {"format": fmt, "out": str(out), "every": every, "weather": weather,
                    "camera": [spec.camera.width, spec.camera.height], "splits": {}}
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) if workers > 1 else None
    try:
        for sp in splits:
            split_dir = prepare_dir(inside(out, out / safe_file_stem(sp)))
            writer = make_writer(fmt, split_dir, every)
            jobs = [(spec, split_list[sp][i:i + chunk], weather, fmt, every, str(split_dir))
                    for i in range(0, len(split_list[sp]), chunk)]
            if pool is None:
                parts = []
                for job in jobs:
                    parts.append(_export_chunk(*job))
                    if progress:
                        progress(len(job[1]))
            else:
                futures = [pool.submit(_export_chunk, *job) for job in jobs]
                parts = []
                for f, job in zip(futures, jobs, strict=True):
                    parts.append(f.result())
                    if progress:
                        progress(len(job[1]))
            seqs = [s for part in parts for s in part[0]]
            if isinstance(writer, CocoWriter):
                for _, images, annotations in parts:
                    base = len(writer.images)
                    for im in images:
                        writer.images.append({**im, "id": im["id"] + base})
                    for an in annotations:
                        writer.annotations.append(
                            {**an, "id": len(writer.annotations) + 1, "image_id": an["image_id"] + base})
            writer.sequences = [_Seq(s["name"], spec.camera.width, spec.camera.height, spec.camera.rate)
                                for s in seqs]
            writer.finish()
            result["splits"][sp] = {"scenes": len(split_list[sp]), "seeds": list(spec.splits[sp].seeds),
                                    "frames": sum(s["frames"] for s in seqs),
                                    "objects": sum(s["objects"] for s in seqs)}
    finally:
        if pool is not None:
            pool.shutdown()
    return result


def with_split_seeds(spec: GeneratorSpec, splits: Sequence[str], seeds: tuple[int, int],
                     gen_path: Path) -> GeneratorSpec:
    """``spec`` with the seed range of the single split in ``splits`` set to ``seeds``
    [first, last); ValueError (naming the file) when that is not one split, or the range is
    empty or overlaps another split's."""
    if len(splits) != 1:
        raise ValueError(f"--seeds: replaces the range of one split, give exactly one --split (got {len(splits)})")
    sp = splits[0]
    split_seeds(spec, sp)  # the split exists
    lo, hi = seeds
    if not 0 <= lo < hi:
        raise ValueError(f"--seeds: expected FIRST LAST with 0 <= FIRST < LAST, got {lo} {hi}")
    ranges = {**spec.splits, sp: SplitSpec(seeds=(lo, hi))}
    other = overlapping_split(ranges, sp)
    if other is not None:
        a, b = ranges[other].seeds
        raise ValueError(f"--seeds: [{lo}, {hi}) overlaps split {other!r} [{a}, {b}) of {gen_path}")
    return spec.model_copy(update={"splits": ranges})


def with_camera(spec: GeneratorSpec, size: tuple[int, int]) -> GeneratorSpec:
    """``spec`` with its camera resolution set to ``size`` (width, height) px, every other
    camera draw (field of view, mount) unchanged; ValueError when out of range."""
    w, h = size
    try:
        cam = CameraRandom.model_validate({**spec.camera.model_dump(), "width": w, "height": h})
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ValueError(f"--camera {w}x{h}: {err['loc'][0]} {err['msg'].lower()}") from None
    return spec.model_copy(update={"camera": cam})


def load_sources(source: Path) -> list[Scenario]:
    """The scenarios of a scenario YAML or of a suite YAML (a mapping with ``scenarios``)."""
    if is_suite(read_yaml(source, "scenario or suite")):
        _, paths = load_suite(source)
        return [load_scenario(p) for p in paths]
    return [load_scenario(source)]


def export_dataset(source: Path, fmt: str, every: int, out: Path, render: bool = True) -> dict:
    """Export the scenario or suite ``source`` as a ``fmt`` dataset into ``out`` (module docstring)."""
    if fmt not in FORMATS:
        raise ValueError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    return export_scenarios(load_sources(source), fmt, every, out, render=render)


def export_source(
    source: Path, fmt: str, every: int, out: Path, render: bool = True, splits: Sequence[str] | None = None,
    weather: str | None = None, workers: int = 1, progress=None, seeds: tuple[int, int] | None = None,
    camera: tuple[int, int] | None = None,
) -> dict:
    """``lookahead export-dataset``: a scenario, a suite or a generator file (``tools.dataset.scene_gen``)
    exported as a ``fmt`` dataset into ``out``; ``splits``, ``weather``, ``workers``, ``seeds`` and
    ``camera`` apply to generator files only (``ValueError`` otherwise).

    Returns ``export_generated``'s result (with ``splits``) for a generator file, else
    ``export_dataset``'s (with ``sequences``).
    """
    if fmt not in FORMATS:
        raise ValueError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    if is_generator(read_yaml(source, "scenario, suite or generator")):
        return export_generated(Path(source), fmt, every, Path(out), splits, weather, workers,
                                progress=progress, seeds=seeds, camera=camera)
    if splits or weather or seeds or camera:
        raise ValueError("--split, --weather, --seeds and --camera apply to generator files only")
    return export_dataset(Path(source), fmt, every, Path(out), render=render)
