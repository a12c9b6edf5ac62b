"""Pedestrians who wave, fall and loiter: the world does it visibly, ground truth labels it, and
intent recognises it from the track's history (``intent.gestures``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lookahead.intent.labels import Behaviour
from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.sim.shapes import make_shape

ROOT = Path(__file__).resolve().parents[2]


def test_a_raised_arm_and_a_fall_change_the_body_as_drawn():
    person = make_shape("pedestrian", "adult", np.random.default_rng(3))
    _, rest = person.local_box(0.0)
    _, waving = person.local_box((0.0, -2.7, 0.0))
    _, lying = person.local_box((0.0, 0.0, np.pi / 2))
    assert waving[2] > rest[2] + 0.2  # the hand above the head
    assert lying[2] < 0.6 and lying[0] > rest[2] - 0.1  # lying along x, as long as it was tall
    assert person.local_box((0.0, 0.0, 0.0))[1].tolist() == rest.tolist()  # no gesture: the same box


@pytest.mark.parametrize("name, behaviour, recall", [
    ("ped_waving", Behaviour.WAVING, 0.7),  # from 1.5 s of history on
    ("ped_falling", Behaviour.FALLING, 0.7),
    ("ped_loitering", Behaviour.LOITERING, 0.3),
])
def test_each_gesture_is_labelled_and_recognised_in_its_scenario(name, behaviour, recall):
    sink = RecordCollector()
    Runner(with_detector(load_scenario(ROOT / "scenarios" / f"{name}.yaml"), "gt"), sinks=[sink], render=False).run()
    truth_frames = [r for r in sink.records if int(behaviour) in r.ground_truth.behaviour.tolist()]
    assert len(truth_frames) >= 10  # the scripted gesture is ground truth's behaviour
    tracked = [r for r in truth_frames if len(r.tracks.track_id)]
    hits = [r for r in tracked if int(behaviour) in r.assessments.behaviour.tolist()]
    assert len(hits) >= recall * len(tracked)
    others = [b for r in sink.records for b in r.assessments.behaviour.tolist()
              if b in (Behaviour.WAVING, Behaviour.FALLING, Behaviour.LOITERING) and b != behaviour]
    assert not others  # no other gesture is seen
