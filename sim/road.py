"""The road: a highway-env ``RoadNetwork`` plus the ``RoadLayout`` the renderer draws.

highway-env draws y downward; our world frame has y to the left. This module
and ``sim.world`` are the only places that convert: (x, y)_world = (x, -y)_hw,
heading_world = -heading_hw. Lane 0 is the leftmost lane, centred on world
y = 0; lane i is centred on y = -i * lane_width.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from highway_env.road.lane import LineType, StraightLane
from highway_env.road.road import RoadNetwork

from lookahead.sim.layout import Marking, Rect, RoadLayout
from lookahead.sim.scenario import RoadSpec

MAIN_FROM, MAIN_TO = "main0", "main1"
CROSS_NB = ("cross_s", "cross_n")  # cross street, lane heading world +y
CROSS_SB = ("cross_n2", "cross_s2")  # cross street, lane heading world -y
STRUCTURE_DEPTH = 14.0  # m of roadside zone beyond each pavement


def to_hw(xy: np.ndarray) -> np.ndarray:
    """World xy (..., 2) -> highway-env xy."""
    out = np.array(xy, dtype=np.float64)
    out[..., 1] *= -1.0
    return out


def from_hw(xy: np.ndarray) -> np.ndarray:
    """highway-env xy (..., 2) -> world xy."""
    return to_hw(xy)


@dataclass(frozen=True)
class RoadGeometry:
    """Derived numbers of the main road (world frame, m)."""

    lanes: int
    lane_width: float
    length: float
    left_edge: float
    right_edge: float
    cross_x: float | None = None
    cross_half_width: float = 0.0

    def lane_y(self, lane: int) -> float:
        """World y of a lane's centre line."""
        return -lane * self.lane_width


def build_road(spec: RoadSpec, cross_x: float | None = None) -> tuple[RoadNetwork, RoadGeometry, RoadLayout]:
    """Network, geometry and layout of a scenario's road.

    ``kind: intersection`` adds a two-lane cross street (one lane each way,
    3.5 m lanes) at world x = ``cross_x`` to the straight main road.
    """
    w, n, length = spec.lane_width, spec.lanes, spec.length
    net = RoadNetwork()
    for i in range(n):
        y_hw = i * w
        lines = [
            LineType.CONTINUOUS_LINE if i == 0 else LineType.STRIPED,
            LineType.CONTINUOUS_LINE if i == n - 1 else LineType.NONE,
        ]
        net.add_lane(
            MAIN_FROM,
            MAIN_TO,
            StraightLane([0.0, y_hw], [length, y_hw], width=w, line_types=lines, speed_limit=spec.speed_limit),
        )
    left_edge, right_edge = w / 2.0, -(n - 1) * w - w / 2.0
    geometry = RoadGeometry(n, w, length, left_edge, right_edge)

    asphalt = [Rect(0.0, right_edge, length, left_edge)]
    markings = [Marking((0.0, left_edge - 0.2), (length, left_edge - 0.2))]
    markings.append(Marking((0.0, right_edge + 0.2), (length, right_edge + 0.2)))
    for i in range(1, n):
        y = -i * w + w / 2.0
        markings.append(Marking((0.0, y), (length, y), dashed=True))
    sw = spec.sidewalk_width
    sidewalks: list[Rect] = []
    zones: list[Rect] = []
    if spec.sidewalks:
        sidewalks = [Rect(0.0, left_edge, length, left_edge + sw), Rect(0.0, right_edge - sw, length, right_edge)]
    side_l, side_r = left_edge + (sw if spec.sidewalks else 1.0), right_edge - (sw if spec.sidewalks else 1.0)
    zones = [Rect(0.0, side_l + 1.0, length, side_l + 1.0 + STRUCTURE_DEPTH),
             Rect(0.0, side_r - 1.0 - STRUCTURE_DEPTH, length, side_r - 1.0)]

    if spec.kind == "intersection":
        cx = float(cross_x if cross_x is not None else length / 2.0)
        cw = 3.5
        far = 400.0
        y0, y1 = right_edge - far, left_edge + far
        # Northbound (world +y) lane right of the centre line, southbound left of it.
        net.add_lane(*CROSS_NB, StraightLane(to_hw([cx + cw / 2, y0]), to_hw([cx + cw / 2, y1]), width=cw,
                                             line_types=[LineType.STRIPED, LineType.CONTINUOUS_LINE], speed_limit=13.9))
        net.add_lane(*CROSS_SB, StraightLane(to_hw([cx - cw / 2, y1]), to_hw([cx - cw / 2, y0]), width=cw,
                                             line_types=[LineType.STRIPED, LineType.CONTINUOUS_LINE], speed_limit=13.9))
        asphalt.append(Rect(cx - cw, y0, cx + cw, y1))
        markings.append(Marking((cx, y0), (cx, right_edge - sw - 1.0), dashed=True))
        markings.append(Marking((cx, left_edge + sw + 1.0), (cx, y1), dashed=True))
        gap = cw + (sw if spec.sidewalks else 0.0) + 1.0
        sidewalks = [piece for r in sidewalks for piece in _cut_x(r, cx - gap, cx + gap)]
        zones = [piece for r in zones for piece in _cut_x(r, cx - gap - 2.0, cx + gap + 2.0)]
        markings = [m for mk in markings for m in _cut_marking(mk, cx - cw - 0.5, cx + cw + 0.5)]
        geometry = RoadGeometry(n, w, length, left_edge, right_edge, cross_x=cx, cross_half_width=cw)

    layout = RoadLayout(asphalt=tuple(asphalt), sidewalks=tuple(sidewalks), markings=tuple(markings),
                        structure_zones=tuple(zones))
    return net, geometry, layout


def _cut_x(r: Rect, x0: float, x1: float) -> list[Rect]:
    out = []
    if r.x0 < x0:
        out.append(Rect(r.x0, r.y0, min(r.x1, x0), r.y1))
    if r.x1 > x1:
        out.append(Rect(max(r.x0, x1), r.y0, r.x1, r.y1))
    return out


def _cut_marking(m: Marking, x0: float, x1: float) -> list[Marking]:
    (ax, ay), (bx, by) = m.start, m.end
    if ay != by or max(ax, bx) <= x0 or min(ax, bx) >= x1:
        return [m]
    lo, hi = min(ax, bx), max(ax, bx)
    out = []
    if lo < x0:
        out.append(Marking((lo, ay), (x0, ay), m.width, m.dashed))
    if hi > x1:
        out.append(Marking((x1, ay), (hi, ay), m.width, m.dashed))
    return out
