"""False AEB activations: brake onsets justified (or not) by ground-truth danger, pooled in totals."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.intent.labels import Label
from lookahead.tools.scoring.intent import (
    AEB_TTC_BOUND_S,
    evaluate_aeb,
    intent_sections,
    load_intent_run,
)
from lookahead.tools.scoring.totals import intent_totals, sweep_totals

BOX = [100.0, 100.0, 140.0, 200.0]
N = 20  # frames at 10 Hz


def actor(name: str, label: int, ttc: float | None, in_path: bool) -> dict:
    return {"name": name, "label": label, "ttc": ttc, "in_path": in_path}


def write_run(tmp: Path, brake: list[bool], actors_at) -> Path:
    """A run directory of ``N`` frames; ``actors_at(f)`` gives the ground-truth actors of frame ``f``."""
    run = tmp / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"scenario": {"expect": []}}))
    lines = []
    for f in range(N):
        acts = actors_at(f)
        lines.append({
            "t": round(0.1 * f, 4), "ego": {"brake": 6.0 if brake[f] else None},
            "ground_truth": {"actor_id": list(range(1, len(acts) + 1)), "name": [a["name"] for a in acts],
                             "class_id": [2] * len(acts), "visible": [BOX] * len(acts),
                             "label": [a["label"] for a in acts], "ttc": [a["ttc"] for a in acts],
                             "in_path": [a["in_path"] for a in acts]},
            "tracks": None, "assessments": None, "alerts": [], "collisions": [],
        })
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    return run


def braking(*spans: tuple[int, int]) -> list[bool]:
    return [any(a <= f < b for a, b in spans) for f in range(N)]


def parked(f: int) -> dict:
    """A parked car beside the path: never in path, not closing (TTC never)."""
    return actor("parked", int(Label.STABLE), None, False)


def lead_danger_from(start: int):
    """A stopped car ahead: approaching, then danger (in path, TTC under 4 s) from frame ``start``."""
    def at(f: int) -> list[dict]:
        ttc = 6.0 - 0.2 * f
        return [actor("lead", int(Label.DANGER if f >= start else Label.APPROACHING), ttc, True), parked(f)]
    return at


def test_an_onset_with_a_danger_actor_is_justified(tmp_path):
    aeb = intent_sections(load_intent_run(write_run(tmp_path, braking((12, N)), lead_danger_from(10))))["aeb"]
    assert (aeb["brake_onsets"], aeb["false_activations"], aeb["false_activation_rate"]) == (1, 0, 0.0)
    (onset,) = aeb["onset_list"]
    # the lead car is the justifying actor; its lowest true TTC in [0.7 s, 1.5 s] is at 1.5 s
    assert onset == {"t": 1.2, "justified": True, "actor": "lead", "ttc": pytest.approx(3.0), "label": "danger"}


def test_danger_within_the_tolerance_after_the_onset_still_justifies(tmp_path):
    # the label turns danger 0.3 s after the brake came on: within AEB_AFTER_S
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking((7, N)), lead_danger_from(10))))
    assert aeb["false_activations"] == 0 and aeb["onset_list"][0]["actor"] == "lead"


def test_danger_long_after_the_onset_does_not(tmp_path):
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking((5, N)), lead_danger_from(10))))
    assert (aeb["brake_onsets"], aeb["false_activations"], aeb["false_activation_rate"]) == (1, 1, 1.0)


def test_an_onset_with_only_a_parked_car_beside_the_path_is_false(tmp_path):
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking((4, 9)), lambda f: [parked(f)])))
    assert (aeb["brake_onsets"], aeb["false_activations"], aeb["false_activation_rate"]) == (1, 1, 1.0)
    assert aeb["onset_list"] == [{"t": 0.4, "justified": False, "actor": None, "ttc": None, "label": None}]


def test_in_path_under_the_aeb_ttc_bound_justifies_without_a_danger_label(tmp_path):
    # a label that lags (approaching) but the car is in path with true TTC under the bound
    def at(f: int) -> list[dict]:
        return [actor("lead", int(Label.APPROACHING), AEB_TTC_BOUND_S - 0.1, True)]

    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking((5, N)), at)))
    assert aeb["false_activations"] == 0 and aeb["onset_list"][0]["label"] == "approaching"
    # the same TTC out of the path justifies nothing
    (tmp_path / "b").mkdir()
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path / "b", braking((5, N)),
                                                 lambda f: [{**at(f)[0], "in_path": False}])))
    assert aeb["false_activations"] == 1


def test_two_onsets_one_false_one_justified(tmp_path):
    # a phantom brake at 0.2..0.5 s (nothing in danger yet), released, then a real one at 1.2 s
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking((2, 5), (12, N)), lead_danger_from(10))))
    assert (aeb["brake_onsets"], aeb["false_activations"], aeb["false_activation_rate"]) == (2, 1, 0.5)
    assert [(o["t"], o["justified"]) for o in aeb["onset_list"]] == [(0.2, False), (1.2, True)]


def test_braking_at_the_first_frame_is_an_onset(tmp_path):
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking((0, 3)), lambda f: [parked(f)])))
    assert aeb["brake_onsets"] == 1 and aeb["onset_list"][0]["t"] == 0.0


def test_no_aeb_no_onsets_and_no_rate(tmp_path):
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path, braking(), lead_danger_from(10))))
    assert aeb == {"brake_onsets": 0, "false_activations": 0, "false_activation_rate": None, "onset_list": []}


def _metrics(tmp: Path, name: str, brake: list[bool], actors_at) -> dict:
    (tmp / name).mkdir()
    return intent_sections(load_intent_run(write_run(tmp / name, brake, actors_at)))


def test_totals_sum_counts_and_recompute_the_rate(tmp_path):
    runs = [
        _metrics(tmp_path, "a", braking((2, 5), (12, N)), lead_danger_from(10)),  # 2 onsets, 1 false
        _metrics(tmp_path, "b", braking((12, N)), lead_danger_from(10)),  # 1 onset, justified
        _metrics(tmp_path, "c", braking(), lambda f: [parked(f)]),  # no AEB
        _metrics(tmp_path, "d", braking((4, 9)), lambda f: [parked(f)]),  # 1 onset, false
    ]
    tot = intent_totals(runs)["aeb"]
    assert tot == {"runs": 4, "brake_onsets": 4, "false_activations": 2, "false_activation_rate": 0.5}
    assert sweep_totals(runs)["aeb"] == tot
    # runs without AEB onsets anywhere: no rate; metrics files without the section pool as nothing
    none = intent_totals([runs[2], {k: v for k, v in runs[2].items() if k != "aeb"}])["aeb"]
    assert none == {"runs": 1, "brake_onsets": 0, "false_activations": 0, "false_activation_rate": None}


def _stationary_car_run(out: Path, aeb: bool) -> Path:
    """The shipped stationary car (40 km/h) with a 1.2 s / 4 m/s^2 driver model, written to ``out``."""
    from lookahead.sim.driver import DriverConfig
    from lookahead.sim.runner import Runner
    from lookahead.sim.scenario import load_scenario
    from lookahead.tools.sinks.rundir import RunDirWriter

    sc = load_scenario(Path(__file__).resolve().parents[3] / "scenarios" / "stationary_car.yaml")
    sc = sc.model_copy(update={"ego": sc.ego.model_copy(update={"driver": DriverConfig(), "aeb": aeb})})
    Runner(sc, sinks=[RunDirWriter(out, sc)], render=False).run()
    return out


def test_a_driver_braking_without_the_aeb_is_no_onset(tmp_path):
    run = _stationary_car_run(tmp_path / "run", aeb=False)
    ticks = [json.loads(x) for x in (run / "ticks.jsonl").read_text().splitlines()]
    assert any(t["ego"]["brake"] for t in ticks)  # the driver brakes ...
    sections = intent_sections(load_intent_run(run))
    assert sections["aeb"]["brake_onsets"] == 0  # ... which is not the AEB
    assert sections["closed_loop"]["aeb_active_s"] == 0.0


def test_onsets_are_the_aebs_own_brake(tmp_path):
    """Ticks with ``aeb_brake`` score from it, not from ``brake`` (which a driver's braking sets)."""
    run = write_run(tmp_path, braking((2, 5), (12, N)), lead_danger_from(10))
    lines = [json.loads(x) for x in (run / "ticks.jsonl").read_text().splitlines()]
    for f, rec in enumerate(lines):  # the AEB's own brake only from frame 12: the first span is a driver's
        rec["ego"]["aeb_brake"] = 6.0 if f >= 12 else None
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    aeb = evaluate_aeb(load_intent_run(run))
    assert (aeb["brake_onsets"], aeb["false_activations"]) == (1, 0)
    assert aeb["onset_list"][0]["t"] == 1.2


def test_old_run_directories_without_aeb_brake_score_from_brake(tmp_path):
    # write_run records ``brake`` only, as runs did before ``aeb_brake``: scored from it
    (tmp_path / "a").mkdir()
    aeb = evaluate_aeb(load_intent_run(write_run(tmp_path / "a", braking((4, 9)), lambda f: [parked(f)])))
    assert (aeb["brake_onsets"], aeb["false_activations"]) == (1, 1)
    # unless run.json says the AEB was off: that brake was not the AEB's
    (tmp_path / "b").mkdir()
    run = write_run(tmp_path / "b", braking((4, 9)), lambda f: [parked(f)])
    (run / "run.json").write_text(json.dumps({"scenario": {"expect": [], "ego": {"aeb": False}}}))
    assert evaluate_aeb(load_intent_run(run))["brake_onsets"] == 0
