"""Our tracker vs the SORT reference on real MOTChallenge sequences (MOT15 train).

Data (``tests/data/mot15``, provenance and licence in its README): the public ACF
detections (``det.txt``), ground truth (``gt.txt``) and ``seqinfo.ini`` of TUD-Campus,
TUD-Stadtmitte (25 fps, 640x480), KITTI-17 and KITTI-13 (10 fps, ~1230x370). Both
trackers get the same detections; everything is evaluated with
``tools.scoring.mot_eval.evaluate_mot`` (TrackEval CLEAR / Identity / HOTA; MOT15 GT rows with
conf 0 are ignored).

- Detections of three kinds per sequence: the public ACF detections, and the sequence's
  ground truth through the simulated detector's noise model at two levels
  (``tools.scoring.mot_noise``: ``low`` and ``high``, seed 0) -- detectors the settings were
  not chosen on.
- SORT: ``tools.bench.sort_reference.Sort()`` with its defaults (max_age=1, min_hits=3,
  IoU 0.3), fed every detection as is, as in Bewley et al. (SORT ignores scores).
- Ours: what ``lookahead track --det <seq>/det.txt`` runs (``run_tracker_on_mot``;
  ``test_cli_path_is_the_evaluated_path`` checks the files are identical):
  ``Tracker(mot_tracker_config(), frame_rate=<seqinfo.ini frameRate>)`` -- the ADAS defaults
  with the MOT profile (``tools.scoring.mot_eval.MOT_PROFILE``: no coasting boxes, 0.3 s
  memory) -- on ACF's unbounded scores brought to [0, 1] per file, ``clip(conf / P75(conf), 0, 1)``
  (``normalise_scores``; the noise model's scores are in [0, 1] already). One configuration for
  every sequence and detector.

Tests:

- ``test_ours_beats_sort_on_mot15``: public detections, MOTA, IDF1 and HOTA >= SORT on
  every sequence, pooled MOTA/IDF1 >= SORT's, fewer ID switches in total.
- ``test_one_configuration_beats_sort_with_every_detector``: MOTA and IDF1 >= SORT on all
  twelve (sequence, detector) cells.
- ``test_leave_one_out_vs_sort``: held-out evidence. For each (sequence, detector) cell, the
  memory (0.3, 1 s), acceleration noise (1, 5 box sizes/s^2) and ``min_hits`` (2, 3) are
  chosen on the cells of the *other* sequences with the *other* detectors (maximise the worst
  margin over SORT, ties by the mean margin, over MOTA/IDF1) and the choice must beat SORT
  on the held-out cell in MOTA and IDF1.
- ``test_one_second_memory_loses_in_a_crowd`` (strict xfail): with 1 s, HOTA falls below
  SORT on TUD-Stadtmitte's public detections -- why the profile keeps 0.3 s.
- ``test_default_config_loses_to_sort`` (strict xfail): ``TrackerConfig()`` as it is (coasting
  boxes reported) is not for MOT files.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from lookahead.perception.mot import MotRecords, from_boxes, iter_frames, read_mot
from lookahead.perception.tracker import Tracker, TrackerConfig
from lookahead.tools.bench.sort_reference import Sort
from lookahead.tools.scoring.mot_eval import (
    MOT_PROFILE,
    SCORE_PERCENTILE,
    evaluate_mot,
    mot_tracker_config,
    normalise_scores,
    read_seqinfo,
    run_tracker_on_mot,
    track_records,
)
from lookahead.tools.scoring.mot_noise import MOT_NOISE_LEVELS, noisy_detections

DATA = Path(__file__).resolve().parents[3] / "tests" / "data" / "mot15"
SEQUENCES = ("TUD-Campus", "TUD-Stadtmitte", "KITTI-17", "KITTI-13")
#: The public detections and the noise model's two levels.
DETECTORS = ("public", *MOT_NOISE_LEVELS)
CELLS = tuple(itertools.product(SEQUENCES, DETECTORS))
METRICS = ("mota", "idf1", "hota")
#: The issue's criterion on every cell.
CELL_METRICS = ("mota", "idf1")

#: Leave-one-out candidates: (max_lost_s s, std_weight_accel box sizes/s^2, min_hits): the
#: profile's and the ADAS memory; pedestrian dynamics and the ADAS default; ours vs SORT's
#: confirmation count.
LOO_GRID = tuple(itertools.product((0.3, 1.0), (1.0, 5.0), (2, 3)))


@dataclasses.dataclass(frozen=True)
class Seq:
    name: str
    frame_rate: float
    length: int
    width: int
    height: int
    gt: MotRecords
    det: MotRecords


@cache
def load(seq: str) -> Seq:
    """One sequence, its rate and size from ``seqinfo.ini`` (as ``lookahead track`` reads them)."""
    info = read_seqinfo(DATA / seq / "seqinfo.ini")
    return Seq(
        name=seq, frame_rate=info.frame_rate, length=info.length, width=info.width, height=info.height,
        gt=read_mot(DATA / seq / "gt.txt"), det=read_mot(DATA / seq / "det.txt"),
    )


@cache
def detections(name: str, detector: str = "public") -> MotRecords:
    """The sequence's public detections, or its ground truth through the noise ``detector`` level."""
    seq = load(name)
    if detector == "public":
        return seq.det
    return noisy_detections(seq.gt, seq.width, seq.height, seq.length, detector, seed=0)


def run_sort(dets: MotRecords, num_frames: int) -> MotRecords:
    sort = Sort()
    out = []
    for f, rows in iter_frames(dets, num_frames):
        res = sort.update(np.column_stack([rows.xyxy, rows.conf]))
        out.append(from_boxes(f, res[:, 4], res[:, :4]))
    return MotRecords.concat(out)


def run_ours(
    seq: Seq, config: TrackerConfig, percentile: float | None = SCORE_PERCENTILE, detector: str = "public"
) -> MotRecords:
    """Our tracker at the sequence's rate; ``percentile`` None = raw scores."""
    dets = detections(seq.name, detector)
    dets = dets if percentile is None else normalise_scores(dets, percentile)
    return track_records(dets, Tracker(config, frame_rate=seq.frame_rate), seq.length)


@cache
def sort_metrics(name: str, detector: str = "public") -> dict:
    seq = load(name)
    return evaluate_mot(seq.gt, run_sort(detections(name, detector), seq.length), num_frames=seq.length)


@cache
def ours_metrics(name: str, detector: str = "public", **overrides) -> dict:
    """Ours with ``mot_tracker_config(**overrides)``."""
    seq = load(name)
    trk = run_ours(seq, mot_tracker_config(**overrides), detector=detector)
    return evaluate_mot(seq.gt, trk, num_frames=seq.length)


def pooled(per_seq: dict[str, dict]) -> dict:
    """MOTA, IDF1 and ID switches of all sequences' counts summed."""
    gt = sum(m["num_gt_dets"] for m in per_seq.values())
    errors = sum(m["fn"] + m["fp"] + m["id_switches"] for m in per_seq.values())
    # IDF1 = 2 IDTP / (GT + tracker dets), so IDTP is recovered exactly per sequence.
    idtp = sum(m["idf1"] * (m["num_gt_dets"] + m["num_tracker_dets"]) / 2 for m in per_seq.values())
    dets = sum(m["num_tracker_dets"] for m in per_seq.values())
    return {
        "mota": 1.0 - errors / gt,
        "idf1": 2.0 * idtp / (gt + dets),
        "id_switches": sum(m["id_switches"] for m in per_seq.values()),
    }


def table(ours: dict[tuple[str, str], dict]) -> str:
    """One line per (sequence, detector) cell: ours vs SORT (for failure messages)."""
    lines = []
    for (seq, det), o in ours.items():
        s = sort_metrics(seq, det)
        lines.append(
            f"{seq} {det}: ours MOTA {o['mota']:.3f} IDF1 {o['idf1']:.3f} HOTA {o['hota']:.3f} "
            f"IDSW {o['id_switches']} | SORT MOTA {s['mota']:.3f} IDF1 {s['idf1']:.3f} "
            f"HOTA {s['hota']:.3f} IDSW {s['id_switches']}"
        )
    return "\n".join(lines)


def below_sort(ours: dict[tuple[str, str], dict], metrics: tuple[str, ...] = METRICS) -> list[str]:
    """The (sequence, detector, metric) cells where ours is below SORT."""
    return [f"{s} {d} {k}" for (s, d), m in ours.items() for k in metrics if m[k] < sort_metrics(s, d)[k]]


@pytest.mark.parametrize("name", SEQUENCES)
def test_mot15_files_match_seqinfo(name: str) -> None:
    seq = load(name)
    info = json.loads((DATA / name / "seqinfo.json").read_text())  # provenance copy
    assert (info["name"], info["frame_rate"], info["length"], info["width"], info["height"]) == (
        read_seqinfo(DATA / name / "seqinfo.ini").name, seq.frame_rate, seq.length, seq.width, seq.height
    )
    gt, dets, n = seq.gt, seq.det, seq.length
    assert 1 <= gt.frame.min() and gt.frame.max() <= n
    assert 1 <= dets.frame.min() and dets.frame.max() <= n
    assert np.all(dets.track_id == -1) and np.all(gt.track_id >= 1)
    assert set(np.unique(gt.conf)) <= {0.0, 1.0}
    for rec in (gt, dets):  # boxes overlap the image (MOT15 boxes may cross its border)
        x1, y1, x2, y2 = rec.xyxy.T
        assert np.all((x2 > 0) & (x1 < seq.width) & (y2 > 0) & (y1 < seq.height))
    # ACF scores are not probabilities: the reason for normalise_scores.
    assert dets.conf.max() > 1.0
    norm = normalise_scores(dets).conf
    assert norm.min() >= 0.0 and norm.max() == 1.0
    assert np.all(np.diff(norm[np.argsort(dets.conf)]) >= 0)  # order preserved


@pytest.mark.parametrize("name", SEQUENCES)
def test_cli_path_is_the_evaluated_path(name: str, tmp_path: Path) -> None:
    """``run_tracker_on_mot`` without a frame rate (``lookahead track``) reads seqinfo.ini
    and writes exactly the tracks evaluated here."""
    seq = load(name)
    out = tmp_path / "tracks.txt"
    summary = run_tracker_on_mot(DATA / name / "det.txt", out)
    assert summary["frame_rate"] == seq.frame_rate
    assert summary["frame_rate_source"] == str((DATA / name / "seqinfo.ini").resolve())
    assert summary["frames"] == seq.length
    written, evaluated = read_mot(out), run_ours(seq, mot_tracker_config())
    assert np.array_equal(written.frame, evaluated.frame)
    assert np.array_equal(written.track_id, evaluated.track_id)
    assert np.allclose(written.xyxy, evaluated.xyxy, atol=0.01)  # file keeps 2 decimals


def test_the_profile_is_the_adas_defaults_but_the_protocol() -> None:
    """The MOT path changes no association, score or motion setting of the ADAS defaults."""
    assert set(MOT_PROFILE) == {"output_lost", "max_lost_s"}
    changed = {k for k, v in mot_tracker_config().model_dump().items() if TrackerConfig().model_dump()[k] != v}
    assert changed == set(MOT_PROFILE)


def test_ours_beats_sort_on_mot15() -> None:
    ours = {(s, "public"): ours_metrics(s) for s in SEQUENCES}
    text = table(ours)
    assert not below_sort(ours), f"below SORT: {below_sort(ours)}\n{text}"
    by_seq = {s: m for (s, _), m in ours.items()}
    p_ours, p_sort = pooled(by_seq), pooled({s: sort_metrics(s) for s in SEQUENCES})
    assert p_ours["mota"] >= p_sort["mota"], f"pooled MOTA {p_ours} vs {p_sort}\n{text}"
    assert p_ours["idf1"] >= p_sort["idf1"], f"pooled IDF1 {p_ours} vs {p_sort}\n{text}"
    assert p_ours["id_switches"] <= p_sort["id_switches"], f"{p_ours} vs {p_sort}\n{text}"


def test_one_configuration_beats_sort_with_every_detector() -> None:
    ours = {(s, d): ours_metrics(s, d) for s, d in CELLS}
    bad = below_sort(ours, CELL_METRICS)
    assert not bad, f"below SORT: {bad}\n{table(ours)}"


def _loo_candidate(cell: tuple[str, str], memory: float, accel: float, min_hits: int) -> dict:
    return ours_metrics(*cell, max_lost_s=memory, std_weight_accel=accel, min_hits=min_hits)


def test_leave_one_out_vs_sort() -> None:
    """Each cell's settings chosen on the other sequences' other detectors only."""
    def margins(c: tuple, cells: list[tuple[str, str]]) -> np.ndarray:
        return np.array([[_loo_candidate(x, *c)[k] - sort_metrics(*x)[k] for k in CELL_METRICS] for x in cells])

    report, failures = [], []
    for held in CELLS:
        train = [(s, d) for s, d in CELLS if s != held[0] and d != held[1]]
        best = max(LOO_GRID, key=lambda c, train=train: (margins(c, train).min(), margins(c, train).mean()))
        got = margins(best, [held])[0]
        report.append(
            f"{held}: chosen on the others memory {best[0]:g} s, accel {best[1]:g}, min_hits {best[2]} -> "
            + ", ".join(f"{k} {v:+.3f}" for k, v in zip(CELL_METRICS, got, strict=True))
        )
        failures += [f"{held} {k}" for k, v in zip(CELL_METRICS, got, strict=True) if v < 0]
    assert not failures, f"held-out below SORT: {failures}\n" + "\n".join(report)


@pytest.mark.xfail(
    strict=True,
    reason="known: with a 1 s memory and no appearance model, lost tracks in TUD-Stadtmitte's crowd "
    "come back on a neighbour: MOTA and IDF1 still beat SORT, HOTA does not (0.373 vs 0.381); "
    "why MOT_PROFILE keeps max_lost_s at 0.3 s. If this passes, revisit the profile in "
    "tools/scoring/mot_eval.py",
)
def test_one_second_memory_loses_in_a_crowd() -> None:
    ours = {("TUD-Stadtmitte", "public"): ours_metrics("TUD-Stadtmitte", max_lost_s=1.0)}
    assert not below_sort(ours), table(ours)


@pytest.mark.xfail(
    strict=True,
    reason="known: TrackerConfig() as it is reports coasting boxes for 0.2 s (false positives to "
    "MOTChallenge) and its score thresholds assume a typical confident score of about 1 (raw ACF "
    "scores are unbounded); MOT files go through mot_tracker_config() and normalise_scores. "
    "If this passes, update tests/tools/scoring/test_mot_real.py",
)
@pytest.mark.parametrize("percentile", [None, SCORE_PERCENTILE], ids=["raw-scores", "normalised-scores"])
def test_default_config_loses_to_sort(percentile: float | None) -> None:
    ours = {}
    for name in SEQUENCES:
        seq = load(name)
        ours[(name, "public")] = evaluate_mot(seq.gt, run_ours(seq, TrackerConfig(), percentile), num_frames=seq.length)
    assert not below_sort(ours), table(ours)


def test_unbounded_scores_are_normalised_and_probabilities_kept() -> None:
    """ACF's scores are brought to [0, 1]; a [0, 1] detector's are its own scale (calibrated per
    detector, ``perception.score_calibration``); a file without scores is all confident."""
    seq = load("TUD-Campus")
    noisy = detections("TUD-Campus", "low")
    assert normalise_scores(noisy) is noisy
    blank = dataclasses.replace(seq.det, conf=np.full(len(seq.det), -1.0))  # "conf -1" files
    assert np.all(normalise_scores(blank).conf == 1.0)
