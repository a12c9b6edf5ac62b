"""``Collision``: the record of the ego hitting something (light: no simulator import, so the
records that carry it load without highway-env)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Collision:
    """The ego hit something: when, what, and how hard (m/s)."""

    t: float
    tick: int
    actor_id: int
    name: str
    cls: str
    ego_speed: float
    relative_speed: float

    def to_dict(self) -> dict:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()}
