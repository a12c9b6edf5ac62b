"""Score a run directory against its ground truth: ``detection``, ``tracking``, ``estimation``.

``score_run`` reads the run directory through ``tools.sinks.rundir.RunDir`` (each
file parsed once), computes every section (these three, and ``intent``, ``danger``,
``closed_loop``, ``expectations``, ``timing`` from ``tools.scoring.intent`` / ``timing``,
``behaviour`` from ``tools.scoring.behaviour``, ``cipv`` from ``tools.scoring.cipv`` for
records with a primary target, and ``cooperative`` from ``tools.scoring.cooperative`` for
runs with other cameras)
and merges them into ``metrics.json`` (other sections, and foreign keys inside these,
are kept; the file is replaced atomically, and only after everything was computed).
Suite and sweep totals are ``tools.scoring.totals``. ``score_command`` is the body of
``lookahead score RUN_DIR``.

Constants (defined and explained in the ``tools.scoring`` modules):
    IoU >= 0.5 for every match (``matching.IOU_THRESHOLD``).
    Evaluated GT: visible box, class_id >= 0, visible_fraction >= 0.5, visible box
        height >= 10 px (``detection.MIN_VISIBLE_FRACTION``, ``MIN_BOX_HEIGHT_PX``);
        other visible GT is don't-care (matching detections / tracks ignored).
    Range errors over unoccluded GT: visible_fraction >= 0.9, truncation < 0.05,
        range 5..50 m; range_abs_err is the 90th percentile (m).
    TTC error over GT TTC < 5 s, relative. Estimation skips pairs whose track is still
        ``initializing`` (intent label; age < init_frames) -- don't-care, as for labels.
    Tracking and estimation score every reported track: confirmed, and lost ones the
        tracker still outputs (coasting); class-aware matching, TrackEval metrics.
"""

from __future__ import annotations

import logging
from pathlib import Path

from lookahead.tools.scoring.behaviour import behaviour_section
from lookahead.tools.scoring.cipv import cipv_section
from lookahead.tools.scoring.cooperative import cooperative_section
from lookahead.tools.scoring.detection import evaluate_detection
from lookahead.tools.scoring.estimation import evaluate_estimation
from lookahead.tools.scoring.intent import intent_sections, load_intent_run
from lookahead.tools.scoring.io import RunData, load_run
from lookahead.tools.scoring.narration import narration_section
from lookahead.tools.scoring.observed import has_ground_truth, observed_section
from lookahead.tools.scoring.occlusion import run_occlusion
from lookahead.tools.scoring.timing import load_timings, timing_section
from lookahead.tools.scoring.tracking import evaluate_tracking
from lookahead.tools.scoring.truth import TruthJoined
from lookahead.tools.sinks.rundir import (
    RunDir,
    as_rundir,
    merge_sections,
    write_metrics,
)

log = logging.getLogger(__name__)

SECTIONS = ("detection", "tracking", "estimation")



def evaluate(run: RunData) -> dict[str, dict]:
    """The ``detection``, ``tracking`` and ``estimation`` sections of loaded run data."""
    return {
        "detection": evaluate_detection(run),
        "tracking": evaluate_tracking(run),
        "estimation": evaluate_estimation(run),
    }


def compute_sections(run: RunDir | Path) -> dict[str, dict]:
    """The sections of a run directory (nothing written), with ``timing`` when recorded; a run
    without ground truth (``lookahead watch``) gets the ``observed`` counts instead of scores.

    ``ticks.jsonl`` is parsed once (``RunDir``): the frame arrays and the intent
    fields are read from the same records.
    """
    rd = as_rundir(run)
    if has_ground_truth(rd):
        sections = evaluate(load_run(rd))
        intent_run = load_intent_run(rd)
        sections.update(intent_sections(intent_run))
        sections["occlusion"] = run_occlusion(rd)  # identity kept through occlusions
        behaviour = behaviour_section(rd, intent_run)  # behaviours and risk levels
        if behaviour is not None:
            sections["behaviour"] = behaviour
        cipv = cipv_section(rd, intent_run)  # the primary target; closed-loop records only
        if cipv is not None:
            sections["cipv"] = cipv
        cooperative = cooperative_section(rd, intent_run)  # only runs with other cameras
        if cooperative is not None:
            sections["cooperative"] = cooperative
        narration = narration_section(rd.path)  # only runs narrated (``lookahead run --narrate``)
        if narration is not None:
            sections["narration"] = narration
    else:  # real video: nothing to score against (``score --truth`` joins a simulated run's)
        load_run(rd)  # every record checked all the same
        sections = {"observed": observed_section(rd)}
    timings = load_timings(rd)
    if timings:
        sections["timing"] = timing_section(timings)
    return sections


def score_run(run: RunDir | Path, truth: RunDir | Path | None = None) -> dict:
    """Score a run directory (a path, or a ``RunDir`` whose parsed files are reused) and
    merge the sections into its ``metrics.json``. ``truth``: the simulated run whose raw video a
    ``lookahead watch`` run (``run``, no ground truth) watched; its ground truth, matched by
    camera frame, is scored against (``tools.scoring.truth.TruthJoined``).

    Returns:
        The whole merged ``metrics.json`` content.

    Raises:
        FileNotFoundError / NotADirectoryError: no run directory or ``ticks.jsonl``.
        RunDirError: malformed ``ticks.jsonl`` line or unreadable ``metrics.json``
            (one-line message naming the file and line); nothing is written.
    """
    rd = as_rundir(run) if truth is None else TruthJoined(Path(run), truth)
    sections = compute_sections(rd)
    metrics = merge_sections(rd.read_metrics(), sections)
    path = write_metrics(rd.path, metrics)
    if "detection" in sections:
        d, t = sections["detection"], sections["tracking"]
        log.info("scored %s -> %s: precision %s recall %s ap50 %s mota %s",
                 rd.path, path, d["precision"], d["recall"], d["ap50"], t["mota"])
    else:
        log.info("summarised %s (no ground truth) -> %s", rd.path, path)
    return metrics
