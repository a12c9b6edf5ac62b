"""``Runner.step`` / ``Runner.observe``: one camera frame at a time, the same loop ``run()`` is."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def stationary(**update):
    sc = load_scenario(ROOT / "scenarios" / "stationary_car.yaml")
    return sc.model_copy(update=update)


def lines(records) -> list[str]:
    return [json.dumps(r.to_dict(), sort_keys=True) for r in records]


def test_run_is_a_loop_over_step():
    sc = stationary(ego=stationary().ego.model_copy(update={"aeb": True}))
    ran = RecordCollector()
    summary = Runner(sc, sinks=[ran], render=False).run()
    stepped = RecordCollector()
    r = Runner(sc, sinks=[stepped], render=False)
    results = []
    while r.world.tick < r.n_ticks:
        results.append(r.step())
        if results[-1].done:
            break
    assert lines(stepped.records) == lines(ran.records) and len(ran.records) == summary.frames
    assert [p.perceived.frame.index for p in results] == list(range(summary.frames))
    assert all(p.ticks == r.frame_every for p in results)
    assert any(rec.ego["brake"] is not None for rec in ran.records)  # the AEB acted in both


def test_step_commands_the_ego_and_observe_records_the_current_state():
    r = Runner(stationary(), render=False)
    first = r.observe()
    assert (first.frame.index, first.frame.tick, r.frame_index) == (0, 0, 1)
    v0 = r.world.odometry.speed
    result = r.step(-4.0)  # 0.1 s at -4 m/s^2
    assert r.world.ego.accel_command == -4.0 and result.perceived.frame.index == 1
    assert r.world.odometry.speed == pytest.approx(v0 - 0.4, abs=1e-6)
    r.step()  # back to the scenario's (cruise) controller
    assert r.world.ego.accel_command is None and r.world.odometry.speed > v0 - 0.4
    r.close()


def test_a_run_ending_between_frames_steps_its_last_ticks_unobserved():
    sc = stationary(duration=1.05)  # 21 ticks at 20 Hz, frames every 2 ticks
    r = Runner(sc, render=False)
    results = [r.step() for _ in range(11)]
    assert [res.done for res in results] == [False] * 10 + [True]
    last = results[-1]
    assert last.perceived is None and last.ticks == 1 and r.world.tick == 21 and r.frame_index == 10
    again = r.step()  # past the end: nothing happens
    assert (again.ticks, again.perceived, again.done) == (0, None, True)
    r.close()


def test_a_collision_ends_the_step_and_the_run():
    sc = stationary()
    r = Runner(sc, render=False)
    while not (res := r.step(2.0)).done:
        pass
    assert res.ended_on_collision and res.collisions and res.perceived is not None
    assert r.world.tick < r.n_ticks
    kept_going = Runner(stationary(end_on_collision=False), render=False)
    while not (res := kept_going.step(2.0)).done:
        assert not res.ended_on_collision
    assert kept_going.world.tick == kept_going.n_ticks and kept_going.world.collisions
