"""A vehicle-to-vehicle link: messages arrive late, out of step or not at all.

``Link.send(message, t)`` puts a message on the air at time ``t`` (s); it is lost with
probability ``loss``, else it arrives ``latency + U(0, jitter)`` s later (so messages may
overtake each other). ``Link.receive(t)`` hands over what has arrived by ``t``: per
sender the newest message no older than ``timeout`` (by its capture time ``message.t``),
buffered up to ``capacity`` messages per sender (the oldest go first). Nothing grows
without bound: in-flight messages past the timeout are dropped too. Every draw comes from
the link's seed. Messages need ``sender`` and ``t`` attributes
(``perception.cooperative.SharedObjects``). ``stats`` counts sent, lost, delivered,
expired and overflowed messages.
"""

from __future__ import annotations

import heapq
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field


class LinkConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    latency: float = Field(0.05, ge=0.0, le=10.0, description="s from sending to arrival (the least)")
    jitter: float = Field(0.02, ge=0.0, le=10.0, description="s; arrival is latency + U(0, jitter) after sending")
    loss: float = Field(0.0, ge=0.0, le=1.0, description="probability a message never arrives")
    timeout: float = Field(0.5, gt=0.0, le=60.0, description="s; older messages (by capture time) are dropped")
    capacity: int = Field(4, ge=1, le=1000, description="messages buffered per sender")


@dataclass
class LinkStats:
    sent: int = 0
    lost: int = 0
    delivered: int = 0
    expired: int = 0  # dropped in flight or in the buffer for being older than the timeout
    overflowed: int = 0  # pushed out of a full buffer


@dataclass(order=True)
class _InFlight:
    arrival: float
    order: int  # ties: in sending order
    message: Any = field(compare=False)


class Link:
    """One receiver's link from any number of senders (see the module docstring)."""

    def __init__(self, config: LinkConfig | None = None, seed: int = 0) -> None:
        self.config = config or LinkConfig()
        self._rng = np.random.default_rng([int(seed), 0x11A4])
        self._air: list[_InFlight] = []
        self._buffers: dict[str, deque] = {}
        self._order = 0
        self.stats = LinkStats()

    def send(self, message: Any, t: float) -> None:
        """Put ``message`` on the air at time ``t`` (s)."""
        c = self.config
        self.stats.sent += 1
        lost = self._rng.random() < c.loss
        delay = c.latency + c.jitter * self._rng.random()  # both draws always: the stream stays aligned
        if lost:
            self.stats.lost += 1
            return
        self._order += 1
        heapq.heappush(self._air, _InFlight(float(t) + delay, self._order, message))

    def receive(self, t: float) -> dict[str, Any]:
        """Sender -> its newest message arrived by ``t`` and captured no more than ``timeout``
        s before it (the buffers keep up to ``capacity`` per sender for ``buffered``)."""
        timeout = self.config.timeout
        while self._air and self._air[0].arrival <= t:
            m = heapq.heappop(self._air).message
            if t - m.t > timeout:
                self.stats.expired += 1
                continue
            buf = self._buffers.setdefault(m.sender, deque())
            buf.append(m)
            self.stats.delivered += 1
            if len(buf) > self.config.capacity:
                buf.popleft()
                self.stats.overflowed += 1
        stale = [m for m in self._air if t - m.message.t > timeout]  # never to arrive in time
        if stale:
            self.stats.expired += len(stale)
            self._air = [m for m in self._air if t - m.message.t <= timeout]
            heapq.heapify(self._air)
        out = {}
        for sender, buf in self._buffers.items():
            while buf and t - buf[0].t > timeout:
                buf.popleft()
                self.stats.expired += 1
            if buf:
                out[sender] = max(buf, key=lambda m: m.t)
        return out

    def buffered(self, sender: str) -> list[Any]:
        """The messages of ``sender`` held now (oldest arrival first)."""
        return list(self._buffers.get(sender, ()))

    @property
    def in_flight(self) -> int:
        return len(self._air)
