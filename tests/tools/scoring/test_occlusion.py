"""The ``occlusion`` section: episodes found in ground truth, identity kept / lost / missed.

Synthetic runs at 10 fps: one pedestrian (actor 1) seen, hidden for a while, seen again;
tracks given per frame. Then the three shipped occlusion scenarios, run without rendering
with the ground-truth detector, must hold the episodes they were written for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lookahead.tools.scoring.io import GTFrame, RunData, TrackFrame
from lookahead.tools.scoring.occlusion import (
    REACQUIRE_FRAMES,
    evaluate_occlusion,
    occlusion_totals,
    run_occlusion,
)

ROOT = Path(__file__).resolve().parents[3]
BOX = np.array([100.0, 100.0, 120.0, 150.0])  # 20 x 50 px
PED = 0  # detection class id of pedestrian
DT = 0.1


def gt_frame(state: str) -> GTFrame:
    """One actor's GT: ``seen`` (evaluated), ``hidden`` (fraction 0, no box), ``partly``
    (fraction 0.3), ``out`` (left the image) or ``absent``."""
    if state == "absent":
        z = np.zeros(0)
        return GTFrame(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 4)), z, z, z,
                       np.zeros((0, 2)), z)
    box = BOX if state in ("seen", "partly") else np.full(4, np.nan)
    frac = {"seen": 1.0, "partly": 0.3, "hidden": 0.0, "out": 0.0}[state]
    trunc = 1.0 if state == "out" else 0.0
    one = np.ones(1)
    return GTFrame(np.array([1]), np.array([PED]), box[None, :].copy(), np.array([frac]), np.array([trunc]),
                   one * 20.0, np.zeros((1, 2)), one * np.inf)


def track_frame(track_id: int | None, box: np.ndarray = BOX) -> TrackFrame:
    """A frame with one confirmed pedestrian track ``track_id`` on ``box`` (None: no track)."""
    k = 0 if track_id is None else 1
    ids = np.array([track_id] if k else [], dtype=np.int64)
    one = np.ones(k)
    return TrackFrame(
        track_id=ids, xyxy=np.tile(box, (k, 1)), class_id=np.full(k, PED, dtype=np.int64), score=one,
        confirmed=np.ones(k, dtype=bool), range=one, ground_velocity=np.zeros((k, 2)), ttc=one,
        reported=np.ones(k, dtype=bool), initializing=np.zeros(k, dtype=bool),
    )


def make_run(states: list[str], tracks: list[int | None]) -> tuple[RunData, np.ndarray]:
    assert len(states) == len(tracks)
    gts = [gt_frame(s) for s in states]
    trk = [track_frame(t) for t in tracks]
    dets = [None] * len(states)
    return RunData(gt=gts, dets=dets, tracks=trk), np.arange(len(states)) * DT  # type: ignore[arg-type]


def episode_run(hidden: int, after: list[int | None], before: int | None = 7, lead: int = 10) -> dict:
    """``lead`` seen frames tracked as ``before``, ``hidden`` hidden frames (no track), then
    the seen frames tracked as ``after`` says; scored."""
    states = ["seen"] * lead + ["hidden"] * hidden + ["seen"] * len(after)
    tracks = [before] * lead + [None] * hidden + list(after)
    run, t = make_run(states, tracks)
    return evaluate_occlusion(run, t)


def test_hidden_for_one_second_and_the_same_id_after_is_kept():
    s = episode_run(10, [7] * 10)
    assert (s["episodes"], s["scored"], s["kept"], s["lost"], s["missed"]) == (1, 1, 1, 0, 0)
    assert s["kept_rate"] == 1.0
    (e,) = s["episode_list"]
    assert e == {"actor": 1, "class": "pedestrian", "t_hidden": 1.0, "t_back": 2.0, "duration_s": 1.0,
                 "id_before": 7, "id_after": 7, "outcome": "kept", "kept": True}
    assert s["per_class"]["pedestrian"]["kept_rate"] == 1.0


def test_a_new_id_after_is_lost():
    s = episode_run(10, [9] * 10)
    assert (s["kept"], s["lost"], s["missed"], s["kept_rate"]) == (0, 1, 0, 0.0)
    assert s["episode_list"][0]["id_after"] == 9


def test_reacquired_late_within_the_window_counts_with_the_settled_id():
    # no track for the first frames back, then the old id: kept
    s = episode_run(10, [None] * (REACQUIRE_FRAMES - 1) + [7] * 6)
    assert s["kept"] == 1
    # a coasting old box for one frame, then a new id takes over: lost (the settled id)
    s = episode_run(10, [7, 8, 8, 8, 8, 8, 8])
    assert s["lost"] == 1 and s["episode_list"][0]["id_after"] == 8


def test_never_reacquired_within_the_window_is_missed():
    s = episode_run(10, [None] * REACQUIRE_FRAMES + [7] * 5)
    assert (s["kept"], s["lost"], s["missed"], s["kept_rate"]) == (0, 0, 1, 0.0)
    assert s["episode_list"][0]["id_after"] is None


def test_not_tracked_before_is_untracked_and_not_scored():
    s = episode_run(10, [7] * 10, before=None)
    assert (s["episodes"], s["scored"], s["untracked"], s["kept_rate"]) == (1, 0, 1, None)


@pytest.mark.parametrize(("hidden", "counted"), [(2, False), (3, True), (30, True), (31, False), (60, False)])
def test_only_hides_of_0_3_to_3_s_are_episodes(hidden, counted):
    s = episode_run(hidden, [7] * 10)
    assert s["episodes"] == int(counted)


def test_leaving_the_image_or_partial_visibility_alone_is_not_an_occlusion():
    for gap in (["out"] * 10, ["absent"] * 10, ["partly"] * 10, ["hidden"] * 4 + ["out"] + ["hidden"] * 4):
        states = ["seen"] * 10 + gap + ["seen"] * 10
        run, t = make_run(states, [7] * 10 + [None] * len(gap) + [7] * 10)
        assert evaluate_occlusion(run, t)["episodes"] == 0, gap
    # partly visible frames around the hidden ones belong to the gap; the hidden span is timed
    states = ["seen"] * 10 + ["partly"] * 3 + ["hidden"] * 8 + ["partly"] * 2 + ["seen"] * 10
    run, t = make_run(states, [7] * 10 + [None] * 13 + [7] * 10)
    (e,) = evaluate_occlusion(run, t)["episode_list"]
    assert (e["t_hidden"], e["t_back"], e["duration_s"]) == (1.3, 2.3, 0.8)


def test_without_tracks_every_episode_is_untracked():
    run, t = make_run(["seen"] * 10 + ["hidden"] * 10 + ["seen"] * 10, [None] * 30)
    s = evaluate_occlusion(RunData(gt=run.gt, dets=run.dets, tracks=None), t)
    assert (s["episodes"], s["untracked"], s["kept_rate"]) == (1, 1, None)


def test_totals_sum_the_counts_and_recompute_the_rate():
    a, b = episode_run(10, [7] * 10), episode_run(10, [None] * 10)
    tot = occlusion_totals([{"occlusion": a}, {"occlusion": b}, {"detection": {}}])
    assert (tot["runs"], tot["episodes"], tot["scored"], tot["kept"], tot["missed"]) == (2, 2, 2, 1, 1)
    assert tot["kept_rate"] == 0.5 and tot["per_class"]["pedestrian"]["kept"] == 1


# --- the shipped scenarios: the occlusions really happen in their ground truth ---------------------

#: scenario -> (class, hidden span s) of each episode, as measured with the gt detector, no render
EXPECTED = {
    "occlusion_pedestrian": [("pedestrian", 1.2), ("pedestrian", 1.7)],
    "occlusion_cyclist": [("cyclist", 0.7), ("cyclist", 0.8)],
    "occlusion_car": [("car", 0.8), ("car", 1.1)],
    "occlusion_crossing": [("car", 0.8), ("car", 1.2), ("cyclist", 1.0), ("cyclist", 1.0),
                           ("pedestrian", 0.7), ("pedestrian", 1.4)],
    "occlusion_street": [("car", 0.6), ("cyclist", 1.5), ("pedestrian", 1.5)],
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_shipped_occlusion_scenarios_hold_their_episodes(name, tmp_path):
    from lookahead.sim.scenario import load_scenario
    from lookahead.tools.runs.suite import run_one

    path = ROOT / "scenarios" / f"{name}.yaml"
    assert load_scenario(path).duration <= 8.0
    result = run_one(str(path), str(tmp_path / name), render=False, detector=("gt", None))
    s = result["metrics"]["occlusion"]  # scored by ``lookahead suite`` / ``score`` (tools.scoring.run)
    assert s == run_occlusion(tmp_path / name)
    got = sorted((e["class"], e["duration_s"]) for e in s["episode_list"])
    assert got == sorted(EXPECTED[name]), s["episode_list"]
    assert all(0.5 <= d <= 2.0 for _, d in got)
    assert all(e["id_before"] is not None for e in s["episode_list"])  # tracked before each occlusion
