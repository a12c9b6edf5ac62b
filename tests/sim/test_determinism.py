"""Same scenario and seed twice -> byte-identical ticks.jsonl, with rendering on."""

from __future__ import annotations

from pathlib import Path

from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.sinks.rundir import RunDirWriter

ROOT = Path(__file__).resolve().parents[2]


def run_once(out: Path, name: str) -> tuple[bytes, str]:
    sc = load_scenario(ROOT / "scenarios" / name)
    runner = Runner(sc, sinks=[RunDirWriter(out, sc)], render=True)
    backend = runner.renderer.backend
    runner.run()
    return (out / "ticks.jsonl").read_bytes(), backend


def test_rendered_runs_are_byte_identical(tmp_path):
    a, backend_a = run_once(tmp_path / "a", "child_behind_parked_car.yaml")
    b, backend_b = run_once(tmp_path / "b", "child_behind_parked_car.yaml")
    assert backend_a == backend_b
    assert len(a) > 1000 and a == b


def test_a_different_seed_changes_the_run(tmp_path):
    sc = load_scenario(ROOT / "scenarios" / "child_behind_parked_car.yaml")
    outs = []
    for seed in (1, 2):
        s = sc.model_copy(update={"seed": seed})
        RunnerOut = tmp_path / f"s{seed}"
        Runner(s, sinks=[RunDirWriter(RunnerOut, s)], render=False).run()
        outs.append((RunnerOut / "ticks.jsonl").read_bytes())
    assert outs[0] != outs[1]
