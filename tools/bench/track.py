"""``lookahead bench track``: our tracker vs deep-sort-realtime on the same detections.

Both trackers run in one process on identical per-frame detections:

- MOT15 (``tests/data/mot15``): public ACF detections, scores normalised per
  sequence (``tools.scoring.mot_eval.normalise_scores``); ours with ``mot_tracker_config()``.
- simulated: GT-noise detections of scenarios run without rendering
  (``Runner(..., render=False)``); ours with the scenario's ``TrackerConfig``
  (the defaults for the shipped scenarios). Ground truth and scoring are those
  of ``lookahead score`` (``tools.scoring.tracking.frame_rows``: evaluated GT,
  don't-care GT, class-aware matching).

deep-sort-realtime (``DeepSort``) runs **without its appearance embedder**
(``embedder=None``), so ``embeds`` must be passed. We pass one constant unit
vector per detection (``DEEPSORT_EMBED_DIM`` = 1): every cosine distance is 0,
the appearance term is neutral and association reduces to deep-sort's own
motion machinery (Mahalanobis-gated matching cascade, then IoU). Random
embeddings would instead disable its cascade (tracks missed for more than one
frame could never be re-found) and any box-derived vector would invent an
appearance model. Dimension 1 is the cheapest for its appearance code, so the
speed ratio is conservative; accuracy is the same for any dimension. Its other
parameters are the library defaults except the time budget, matched to ours:
``max_age`` = our ``Tracker.max_lost_frames`` and the tracks reported per frame
are the confirmed ones missed for at most our ``Tracker.output_lost_frames``
(0 in MOT mode: matched this frame) -- as in ours, boxes are the Kalman posterior.
deep-sort gets every detection (it has no score thresholds); ours applies its
ByteTrack score stages.

Timing: only the ``update`` calls (inputs are built beforehand, outputs read
afterwards), per frame with ``perf_counter``; per sequence the two trackers run
one after the other, order alternating per repeat. fps = frames / summed update
time over all sequences, median over repeats; ``fps_over_deepsort`` = ours / its.

JSON: ``machine``; ``cases`` -- ``ours``, ``deepsort`` (per-frame ms over every
frame and repeat, plus ``fps``) and ``<tracker>/<sequence>``; ``ratios``;
``accuracy`` {tracker: {sequence: mota, idf1, hota, ...}} (TrackEval via
``evaluate_mot``, first repeat -- both trackers are deterministic);
``accuracy_pooled`` {tracker: {mot15 | sim: mota, idf1}} over summed counts;
``sort_reference`` {``accuracy`` {sequence: ...}, ``accuracy_pooled`` {mot15: ...}}: the
SORT reference tracker (``tools.bench.sort_reference.Sort()``, its defaults, fed every
detection, untimed) on the MOT15 sequences, the baseline ours must match or beat;
``sequences`` (MOT15 frame rate and length from each ``seqinfo.ini``); ``inputs`` {tracker: {sequence: frames, detections fed}};
``repeats``; ``deepsort_config``.
"""

from __future__ import annotations

import gc
import json
import logging
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from lookahead.perception.detections import Detections
from lookahead.perception.mot import MotRecords, from_boxes, iter_frames, read_mot, to_detections
from lookahead.perception.tracker import Tracker, TrackerConfig
from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.bench.common import case, machine
from lookahead.tools.bench.sort_reference import Sort
from lookahead.tools.scoring.io import GTFrame, TrackFrame
from lookahead.tools.scoring.mot_eval import (
    evaluate_mot,
    mot_tracker_config,
    normalise_scores,
    read_seqinfo,
)
from lookahead.tools.scoring.tracking import frame_rows

log = logging.getLogger(__name__)

ROOT = Path(__file__).resolve().parents[2]  # the checkout: the MOT15 test data is not packaged
MOT15_DIR = ROOT / "tests" / "data" / "mot15"
MOT15_SEQUENCES = ("TUD-Campus", "TUD-Stadtmitte", "KITTI-17", "KITTI-13")
SIM_SCENARIOS = tuple(SCENARIOS / f"{n}.yaml" for n in ("highway_traffic", "urban_mix", "cut_in"))
TRACKERS = ("ours", "deepsort")
DEEPSORT_EMBED_DIM = 1

#: Per-frame output of a tracker: ids (K,), xyxy (K, 4), class ids (K,).
FrameOut = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass
class TrackSequence:
    """One detection sequence and how to score tracks on it."""

    name: str
    source: str  # "mot15" | "sim"
    frame_rate: float
    config: TrackerConfig
    dets: list[Detections]  # per frame, the input of both trackers
    score: Callable[[list[FrameOut]], dict]

    @property
    def num_detections(self) -> int:
        return sum(len(d) for d in self.dets)


# --------------------------------------------------------------------- sequences
def mot15_sequence(name: str, data_dir: Path = MOT15_DIR) -> TrackSequence:
    """A MOT15 sequence: normalised public detections, scored against its gt.txt.

    Frame rate and length come from its ``seqinfo.ini``, as in ``lookahead track``.
    """
    info = read_seqinfo(data_dir / name / "seqinfo.ini")
    gt = read_mot(data_dir / name / "gt.txt")
    det = normalise_scores(read_mot(data_dir / name / "det.txt"))
    n = int(info.length)

    def score(outs: list[FrameOut]) -> dict:
        rows = [from_boxes(f, ids, xyxy) for f, (ids, xyxy, _) in enumerate(outs, start=1)]
        return evaluate_mot(gt, MotRecords.concat(rows), num_frames=n)

    return TrackSequence(
        name=name, source="mot15", frame_rate=float(info.frame_rate), config=mot_tracker_config(),
        dets=[to_detections(rows) for _, rows in iter_frames(det, n)], score=score,
    )


def sort_outputs(seq: TrackSequence) -> list[FrameOut]:
    """The SORT reference (``tools.bench.sort_reference.Sort()``, defaults) over the sequence, untimed."""
    sort = Sort()
    outs = []
    for dets in seq.dets:
        res = sort.update(np.column_stack([dets.xyxy, dets.score]))
        outs.append((res[:, 4].astype(np.int64), res[:, :4], np.zeros(len(res), dtype=np.int64)))
    return outs


class _Collector:
    """Runner sink keeping each frame's detections and ground truth."""

    def __init__(self) -> None:
        self.frames: list = []

    def on_start(self, info: dict) -> None:
        pass

    def on_tick(self, record) -> None:
        self.frames.append((record.detections, record.ground_truth))

    def on_end(self, summary: dict) -> None:
        pass


def _gt_frame(gt):
    return GTFrame(
        actor_id=gt.actor_id, class_id=gt.class_id, visible=gt.visible, visible_fraction=gt.visible_fraction,
        truncation=gt.truncation, range=gt.range, velocity=gt.velocity, ttc=gt.ttc,
    )


def _track_frame(out: FrameOut):
    ids, xyxy, cls = out
    k = len(ids)
    nan = np.full(k, np.nan)
    yes = np.ones(k, dtype=bool)
    return TrackFrame(
        track_id=ids, xyxy=xyxy, class_id=cls, score=nan, confirmed=yes, range=nan,
        ground_velocity=np.full((k, 2), np.nan), ttc=nan, reported=yes, initializing=~yes,
    )


def sim_sequence(scenario_path: Path) -> TrackSequence:
    """A scenario run without rendering: its GT-noise detections, scored like ``lookahead score``."""
    scenario = load_scenario(scenario_path)
    sink = _Collector()
    Runner(scenario, sinks=[sink], render=False).run()
    gts = [_gt_frame(gt) for _, gt in sink.frames]

    def score(outs: list[FrameOut]) -> dict:
        g_rows, t_rows = [], []
        for f, (gt, out) in enumerate(zip(gts, outs, strict=True), start=1):
            g, t, _ = frame_rows(f, gt, _track_frame(out))
            g_rows.append(g)
            t_rows.append(t)
        return evaluate_mot(
            np.concatenate(g_rows), np.concatenate(t_rows), num_frames=len(gts), mot16_preprocess=False
        )

    return TrackSequence(
        name=scenario.name, source="sim", frame_rate=float(scenario.camera.rate),
        config=TrackerConfig(**scenario.perception.tracker), dets=[d for d, _ in sink.frames], score=score,
    )


# ---------------------------------------------------------------------- trackers
@dataclass
class TrackerRun:
    """One tracker's pass over a sequence: per-frame update ms, outputs, and what it was fed."""

    ms: list[float] = field(default_factory=list)
    outs: list[FrameOut] = field(default_factory=list)
    detections: int = 0  # detections passed to the tracker's update calls

    @property
    def frames(self) -> int:
        return len(self.ms)


def run_ours(seq: TrackSequence) -> TrackerRun:
    """Our tracker over the sequence."""
    tracker = Tracker(seq.config, frame_rate=seq.frame_rate)
    run = TrackerRun()
    for dets in seq.dets:
        t0 = time.perf_counter()
        trk = tracker.update(dets)
        run.ms.append((time.perf_counter() - t0) * 1e3)
        run.outs.append((trk.track_id, trk.xyxy, trk.class_id))
        run.detections += len(dets)
    return run


def deepsort_inputs(dets: Detections, embed_dim: int = DEEPSORT_EMBED_DIM) -> tuple[list, list[np.ndarray]]:
    """deep-sort's ``raw_detections`` (``([l, t, w, h], score, class)``) and constant unit embeds."""
    ltwh = np.concatenate([dets.xyxy[:, :2], dets.xyxy[:, 2:] - dets.xyxy[:, :2]], axis=1)
    raw = [(list(b), float(s), int(c)) for b, s, c in zip(ltwh, dets.score, dets.class_id, strict=True)]
    embed = np.full(embed_dim, 1.0 / np.sqrt(embed_dim), dtype=np.float32)
    return raw, [embed] * len(raw)


def _deepsort_output(tracks: list, max_missed: int) -> FrameOut:
    sel = [t for t in tracks if t.is_confirmed() and t.time_since_update <= max_missed]
    return (
        np.array([int(t.track_id) for t in sel], dtype=np.int64),
        np.array([t.to_ltrb() for t in sel], dtype=np.float64).reshape(-1, 4),
        np.array([int(t.get_det_class()) for t in sel], dtype=np.int64),
    )


@contextmanager
def _quiet(logger_name: str) -> Iterator[None]:
    """Silence a library's INFO logs (deep-sort logs its settings on every construction)."""
    logger = logging.getLogger(logger_name)
    level = logger.level
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(level)


def run_deepsort(
    seq: TrackSequence, max_age: int | None = None, embed_dim: int = DEEPSORT_EMBED_DIM
) -> TrackerRun:
    """deep-sort-realtime over the sequence (no embedder; module docstring).

    Args:
        seq: the sequence.
        max_age: frames a missed track is kept; None = our ``Tracker.max_lost_frames``.
        embed_dim: length of the constant unit embedding.
    """
    # lazy: deep-sort-realtime is optional (the 'dev' extra)
    from deep_sort_realtime.deepsort_tracker import DeepSort

    ours = Tracker(seq.config, frame_rate=seq.frame_rate)  # only for its frame budgets
    with _quiet("deep_sort_realtime"):
        tracker = DeepSort(max_age=ours.max_lost_frames if max_age is None else max_age, embedder=None)
    inputs = [deepsort_inputs(d, embed_dim) for d in seq.dets]
    run = TrackerRun()
    for raw, embeds in inputs:
        t0 = time.perf_counter()
        tracks = tracker.update_tracks(raw, embeds=embeds)
        run.ms.append((time.perf_counter() - t0) * 1e3)
        run.outs.append(_deepsort_output(tracks, ours.output_lost_frames))
        run.detections += len(raw)
    return run


RUNNERS: dict[str, Callable[[TrackSequence], TrackerRun]] = {
    "ours": run_ours,
    "deepsort": run_deepsort,
}


# ------------------------------------------------------------------------- bench
def load_sequences(
    mot_sequences: Sequence[str] = MOT15_SEQUENCES, scenarios: Sequence[Path] = SIM_SCENARIOS
) -> list[TrackSequence]:
    seqs = [mot15_sequence(n) for n in mot_sequences] + [sim_sequence(Path(p)) for p in scenarios]
    for s in seqs:
        log.info("sequence %s (%s): %d frames, %d detections", s.name, s.source, len(s.dets), s.num_detections)
    return seqs


def _pooled(metrics: list[dict]) -> dict:
    """MOTA and IDF1 of the summed counts (IDTP recovered from IDF1 per sequence)."""
    gt = sum(m["num_gt_dets"] for m in metrics)
    trk = sum(m["num_tracker_dets"] for m in metrics)
    errors = sum(m["fn"] + m["fp"] + m["id_switches"] for m in metrics)
    idtp = sum(m["idf1"] * (m["num_gt_dets"] + m["num_tracker_dets"]) / 2 for m in metrics)
    return {"mota": round(1.0 - errors / gt, 4) if gt else None,
            "idf1": round(2.0 * idtp / (gt + trk), 4) if gt + trk else None}


def _accuracy(m: dict) -> dict:
    keys = ("mota", "idf1", "hota", "id_switches", "fp", "fn", "num_tracker_ids")
    return {k: round(m[k], 4) if isinstance(m[k], float) else m[k] for k in keys}


def _timed_passes(seqs: list[TrackSequence], repeats: int) -> tuple[dict, dict, dict]:
    """Per tracker: per-frame ms per sequence, total seconds per repeat, first ``TrackerRun`` per sequence."""
    ms = {t: {s.name: [] for s in seqs} for t in TRACKERS}
    totals = {t: [0.0] * repeats for t in TRACKERS}
    first: dict[str, dict[str, TrackerRun]] = {t: {} for t in TRACKERS}
    for name in TRACKERS:  # warm-up: imports, caches
        RUNNERS[name](seqs[0])
    for r in range(repeats):
        for s in seqs:
            for name in TRACKERS if r % 2 == 0 else TRACKERS[::-1]:
                gc.collect()
                run = RUNNERS[name](s)
                ms[name][s.name] += run.ms
                totals[name][r] += sum(run.ms) / 1e3
                first[name].setdefault(s.name, run)
        log.info("repeat %d/%d, s per tracker: %s", r + 1, repeats, {t: round(v[r], 4) for t, v in totals.items()})
    return ms, totals, first


def bench_track(
    out: Path | None,
    repeats: int = 3,
    *,
    mot_sequences: Sequence[str] = MOT15_SEQUENCES,
    scenarios: Sequence[Path] = SIM_SCENARIOS,
) -> dict:
    """Time and score our tracker and deep-sort-realtime on the same sequences; write JSON to ``out``."""
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    seqs = load_sequences(mot_sequences, scenarios)
    ms, totals, runs = _timed_passes(seqs, repeats)
    frames = sum(len(s.dets) for s in seqs)
    cases, fps = {}, {}
    for name in TRACKERS:
        fps[name] = float(np.median([frames / t for t in totals[name]]))
        cases[name] = {**case([x for s in seqs for x in ms[name][s.name]]), "fps": round(fps[name], 2)}
    for s in seqs:
        for name in TRACKERS:
            cases[f"{name}/{s.name}"] = case(ms[name][s.name])
    metrics = {t: {s.name: s.score(runs[t][s.name].outs) for s in seqs} for t in TRACKERS}
    sources = sorted({s.source for s in seqs})
    mot = [s for s in seqs if s.source == "mot15"]
    sort_metrics = {s.name: s.score(sort_outputs(s)) for s in mot}
    result = {
        "machine": machine(),
        "cases": cases,
        "ratios": {"fps_over_deepsort": round(fps["ours"] / fps["deepsort"], 4)},
        "accuracy": {t: {n: _accuracy(m) for n, m in metrics[t].items()} for t in TRACKERS},
        "accuracy_pooled": {
            t: {src: _pooled([metrics[t][s.name] for s in seqs if s.source == src]) for src in sources}
            for t in TRACKERS
        },
        "sort_reference": {
            "accuracy": {n: _accuracy(m) for n, m in sort_metrics.items()},
            "accuracy_pooled": {"mot15": _pooled(list(sort_metrics.values()))} if mot else {},
        },
        "sequences": {
            s.name: {"source": s.source, "frames": len(s.dets), "detections": s.num_detections,
                     "frame_rate": s.frame_rate}
            for s in seqs
        },
        "inputs": {
            t: {s.name: {"frames": runs[t][s.name].frames, "detections": runs[t][s.name].detections} for s in seqs}
            for t in TRACKERS
        },
        "repeats": repeats,
        "deepsort_config": {"version": _deepsort_version(), "embedder": None,
                     "embeds": f"constant unit vector, dim {DEEPSORT_EMBED_DIM}",
                     "max_age": "our Tracker.max_lost_frames", "reported": "confirmed, missed <= our output_lost_frames"},
    }
    if out is not None:
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result, indent=2) + "\n")
        log.info("wrote %s", out)
    return result


def _deepsort_version() -> str | None:
    try:
        return version("deep-sort-realtime")
    except PackageNotFoundError:
        return None
