"""The rendered loop with frame k+1 rendered while frame k is perceived, and perception latency.

Overlap must change nothing a run records; ``perception.latency`` frames delay what the AEB
and the driver are told (and when the driver is warned) by exactly that many frames.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.tools.scoring.intent import evaluate_danger, load_intent_run
from lookahead.tools.sinks.rundir import RunDirWriter

ROOT = Path(__file__).resolve().parents[2]


def stationary_aeb(latency: int = 0, duration: float = 4.5):
    """The ego (13.9 m/s) closing on a stationary car, AEB on, ground-truth detector."""
    sc = with_detector(load_scenario(ROOT / "scenarios" / "stationary_car.yaml"), "gt", None)
    return sc.model_copy(update={
        "duration": duration,
        "ego": sc.ego.model_copy(update={"aeb": True}),
        "perception": sc.perception.model_copy(update={"latency": latency}),
    })


def lines(records) -> list[str]:
    return [json.dumps(r.to_dict(), sort_keys=True) for r in records]


def run(sc, overlap: bool, render: bool = True) -> tuple[Runner, RecordCollector, object]:
    sink = RecordCollector()
    r = Runner(sc, sinks=[sink], render=render, overlap=overlap)
    return r, sink, r.run()


@pytest.mark.parametrize("latency", [0, 1])
def test_overlap_records_exactly_what_the_sequential_loop_does(latency):
    r_seq, seq, s_seq = run(stationary_aeb(latency), overlap=False)
    r_ovl, ovl, s_ovl = run(stationary_aeb(latency), overlap=True)
    assert lines(ovl.records) == lines(seq.records)
    assert r_ovl.aeb.activations == r_seq.aeb.activations and r_seq.aeb.activations
    assert s_seq.overlapped == 0
    # every frame overlaps but the first and, at latency 0, those while the AEB brakes (it may
    # release at once, so the world waits for the frame's decision)
    braking = sum(rec.ego["aeb_brake"] is not None for rec in seq.records)
    assert s_ovl.overlapped >= s_ovl.frames - 1 - (braking + 2 if latency == 0 else 0)
    assert s_ovl.overlapped > s_ovl.frames // 2


def test_one_frame_of_latency_delays_every_decision_by_one_frame():
    r0, rec0, _ = run(stationary_aeb(0), overlap=True, render=False)
    r1, rec1, _ = run(stationary_aeb(1), overlap=True, render=False)
    period = r0.frame_every / r0.scenario.rate
    assert r1.aeb.activations[0] == pytest.approx(r0.aeb.activations[0] + period)
    first_brake = [next(r.t for r in recs.records if r.ego["aeb_brake"] is not None) for recs in (rec0, rec1)]
    assert first_brake[1] == pytest.approx(first_brake[0] + period)
    # perception itself is untouched until the brake differs
    until = [r for r in rec0.records if r.t < first_brake[0] - 1e-9]
    assert lines(until) == lines(rec1.records[: len(until)])


def test_warning_lead_time_counts_the_latency(tmp_path):
    lead = {}
    for latency in (0, 1):
        sc = stationary_aeb(latency).model_copy(update={"ego": stationary_aeb().ego.model_copy(update={"aeb": False})})
        Runner(sc, sinks=[RunDirWriter(tmp_path / str(latency), sc)], render=False).run()
        run_ = load_intent_run(tmp_path / str(latency))
        assert run_.latency_frames == latency
        lead[latency] = evaluate_danger(run_)["lead_time_s_median"]
    # the same alert, delivered one frame (0.1 s) later, at a TTC 0.1 s shorter
    assert lead[1] == pytest.approx(lead[0] - 0.1, abs=0.02)


def test_a_render_worker_that_dies_is_one_error_and_leaves_nothing_behind():
    import os
    import signal

    from lookahead.sim.render_process import RenderError

    sc = stationary_aeb(duration=2.0)
    r = Runner(sc, render=True)
    r.step()
    proc, shm = r.renderer._proc, r.renderer._shms[0].name
    os.kill(proc.pid, signal.SIGKILL)
    with pytest.raises(RenderError, match="render worker died"):
        r.step()
    r.close()
    assert not proc.is_alive() and not os.path.exists(f"/dev/shm/{shm.lstrip('/')}")


def test_the_render_worker_ends_with_its_runner():
    r = Runner(stationary_aeb(duration=1.0), render=True)
    proc = r.renderer._proc
    assert proc.is_alive()
    r.run()  # closes the runner
    proc.join(5.0)
    assert not proc.is_alive() and proc.exitcode == 0
