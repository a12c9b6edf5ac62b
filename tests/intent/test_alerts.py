"""Alerts: debounce, hysteresis, events that say which object, why and when."""

from __future__ import annotations

import numpy as np

from lookahead.intent.alerts import AlertConfig, AlertManager
from lookahead.intent.labels import Assessment, Behaviour, Label, Risk


def frame(risks: list[int], labels: list[int] | None = None) -> Assessment:
    n = len(risks)
    return Assessment(
        ttc=np.full(n, 2.0), in_path=np.ones(n, bool), risk=np.array(risks),
        label=np.array(labels if labels is not None else [Label.DANGER] * n),
        behaviour=np.full(n, int(Behaviour.CROSSING)),
    )


def feed(mgr: AlertManager, risks: list[int], tid: int = 7) -> list[list[str]]:
    out = []
    for k, r in enumerate(risks):
        ev = mgr.update(0.1 * k, np.array([tid]), np.array([0]), np.array([12.0]), frame([r]))
        out.append([e.kind for e in ev])
    return out


H, C, M = int(Risk.HIGH), int(Risk.CRITICAL), int(Risk.MEDIUM)


def test_fcw_needs_two_frames_at_high_and_critical_is_immediate():
    mgr = AlertManager(AlertConfig(on_frames_high=2, on_frames_critical=1, off_frames=3))
    assert feed(mgr, [H, M, H, H, C]) == [[], [], [], ["fcw"], ["critical"]]
    assert mgr.active() == {7: C}


def test_hysteresis_no_flicker_then_clear():
    mgr = AlertManager(AlertConfig(on_frames_high=1, off_frames=3))
    kinds = feed(mgr, [H, M, H, M, M, M, M])
    assert kinds == [["fcw"], [], [], [], [], ["clear"], []]


def test_critical_falls_back_to_fcw_level_not_off():
    mgr = AlertManager(AlertConfig(on_frames_high=1, off_frames=2))
    assert feed(mgr, [C, H, H, H]) == [["critical"], [], ["downgrade"], []]
    assert mgr.active() == {7: H}


def test_initializing_tracks_never_alert():
    mgr = AlertManager(AlertConfig(on_frames_high=1))
    ev = mgr.update(0.0, np.array([1]), np.array([0]), np.array([5.0]), frame([C], [Label.INITIALIZING]))
    assert ev == []


def test_alert_says_what_why_and_when_in_two_languages():
    mgr = AlertManager(AlertConfig(on_frames_critical=1))
    (ev,) = mgr.update(3.5, np.array([4]), np.array([0]), np.array([8.25]), frame([C]))
    d = ev.to_dict()
    assert (d["t"], d["track_id"], d["kind"], d["level_name"]) == (3.5, 4, "critical", "CRITICAL")
    assert "range 8.2 m" in d["reason"] or "range 8.3 m" in d["reason"]
    assert "TTC 2.0 s" in d["reason"] and "crossing" in d["reason"]
    assert "危险靠近" in d["reason_zh"] and "横穿" in d["reason_zh"] and "碰撞时间 2.0 秒" in d["reason_zh"]


def test_a_track_that_blinks_out_keeps_its_alert_state():
    mgr = AlertManager(AlertConfig(on_frames_high=1, forget_frames=5))
    mgr.update(0.0, np.array([1]), np.array([0]), np.array([9.0]), frame([H]))
    mgr.update(0.1, np.array([], dtype=int), np.array([], dtype=int), np.array([]), frame([]))
    ev = mgr.update(0.2, np.array([1]), np.array([0]), np.array([9.0]), frame([H]))
    assert ev == []  # no second warning for the same object


def test_a_hand_over_moves_the_alert_to_the_new_id_without_a_new_event():
    import numpy as np

    from lookahead.intent.alerts import AlertConfig, AlertManager
    from lookahead.intent.labels import Assessment, Label, Risk

    m = AlertManager(AlertConfig())
    crit = Assessment(ttc=np.array([0.8]), in_path=np.array([True]), risk=np.array([int(Risk.CRITICAL)]),
                      label=np.array([int(Label.DANGER)]), behaviour=np.array([0]))
    events = []
    for k in range(4):
        events += m.update(0.1 * k, np.array([1_000_000]), np.array([0]), np.array([8.0]), crit)
    assert [e.kind for e in events] == ["critical"]
    m.hand_over(1_000_000, 4)
    later = m.update(0.5, np.array([4]), np.array([0]), np.array([6.0]), crit)
    assert later == [] and m.active() == {4: int(Risk.CRITICAL)}
