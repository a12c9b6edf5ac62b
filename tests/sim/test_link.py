"""The vehicle-to-vehicle link (``sim.link``): latency, jitter, loss, timeouts, bounded buffers."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from lookahead.sim.link import Link, LinkConfig


@dataclass
class Msg:
    sender: str
    t: float


def test_messages_arrive_after_the_latency_and_the_newest_wins():
    link = Link(LinkConfig(latency=0.2, jitter=0.0, loss=0.0), seed=1)
    for k in range(5):
        link.send(Msg("a", 0.1 * k), 0.1 * k)
    assert link.receive(0.19) == {}
    assert link.receive(0.2)["a"].t == 0.0
    assert link.receive(0.45)["a"].t == pytest.approx(0.2)


def test_stale_messages_are_dropped_and_buffers_stay_bounded():
    cfg = LinkConfig(latency=0.05, jitter=0.03, loss=0.0, timeout=0.3, capacity=3)
    link = Link(cfg, seed=2)
    for k in range(200):  # 10 Hz from two senders, read every frame
        t = 0.1 * k
        link.send(Msg("a", t), t)
        link.send(Msg("b", t), t)
        got = link.receive(t + 0.09)
        assert all(t + 0.09 - m.t <= cfg.timeout for m in got.values())
        assert len(link.buffered("a")) <= 3 and link.in_flight <= 4
    # a sender that goes silent: its last message expires after the timeout
    assert link.receive(20.0)["a"].t == pytest.approx(19.9)
    assert link.receive(25.0) == {} and link.buffered("a") == []
    late = Link(LinkConfig(latency=1.0, jitter=0.0, timeout=0.5), seed=0)
    late.send(Msg("a", 0.0), 0.0)
    assert late.receive(2.0) == {} and late.stats.expired == 1 and late.in_flight == 0


def test_loss_and_jitter_follow_the_settings_and_the_seed():
    cfg = LinkConfig(latency=0.2, jitter=0.1, loss=0.3, timeout=1.0, capacity=1000)
    a, b = Link(cfg, seed=7), Link(cfg, seed=7)
    for k in range(2000):
        a.send(Msg("s", k * 0.01), k * 0.01)
        b.send(Msg("s", k * 0.01), k * 0.01)
    assert a.stats == b.stats and 0.26 < a.stats.lost / a.stats.sent < 0.34
    a.receive(100.0)
    assert a.stats.delivered + a.stats.expired == a.stats.sent - a.stats.lost
    # jitter: arrivals spread over [latency, latency + jitter]
    c = Link(LinkConfig(latency=0.2, jitter=0.1, timeout=5.0), seed=3)
    for k in range(50):
        c.send(Msg(f"s{k}", 0.0), 0.0)
    assert len(c.receive(0.199)) == 0 and 10 < len(c.receive(0.25)) < 40 and len(c.receive(0.3)) == 50
