"""Where the static scene's pieces lie on a ``RoadLayout``: world-frame geometry only.

World frame: x along the road, y left, z up (m). Nothing here touches PyBullet:
``sim.scene`` builds bodies at these places, ``sim.weather`` lights the night from
the same lamp positions, so the two cannot drift apart.

* Surfaces: the layout's rectangles split into pieces that do not overlap
  (``disjoint``), and the kerb strips along pavement edges that touch asphalt.
* Structure zones: which side of a zone's long axis faces the road (``zone_side``).
* Lamp posts: one row per structure zone, a post every ``POST_SPACING`` m from
  ``POST_FIRST`` m along the zone's long axis, ``POST_INSET`` m inside its road
  side; each post's arm holds the lamp head ``LAMP_ARM`` m further toward the road
  (``lamp_posts``, ``lamp_heads``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lookahead.sim.layout import Rect, RoadLayout

POST_HEIGHT = 7.0  # m, top of a lamp post's pole
POST_SPACING = 30.0  # m between lamp posts along a zone
POST_FIRST = 10.0  # m from the start of a zone's long axis to its first post
POST_INSET = 0.4  # m from a zone's road side in to the posts
LAMP_ARM = 1.25  # m from the pole to the lamp head's centre, toward the road
LAMP_HEAD_Z = 6.85  # m, underside of the lamp head


# ---------------------------------------------------------------------- surfaces
def subtract(r: Rect, s: Rect) -> list[Rect]:
    """``r`` minus ``s`` as up to four disjoint rectangles."""
    if s.x1 <= r.x0 or s.x0 >= r.x1 or s.y1 <= r.y0 or s.y0 >= r.y1:
        return [r]
    out = []
    if s.x0 > r.x0:
        out.append(Rect(r.x0, r.y0, s.x0, r.y1))
    if s.x1 < r.x1:
        out.append(Rect(s.x1, r.y0, r.x1, r.y1))
    x0, x1 = max(r.x0, s.x0), min(r.x1, s.x1)
    if s.y0 > r.y0:
        out.append(Rect(x0, r.y0, x1, s.y0))
    if s.y1 < r.y1:
        out.append(Rect(x0, s.y1, x1, r.y1))
    return out


def disjoint(rects: Sequence[Rect], minus: Sequence[Rect] = ()) -> list[Rect]:
    """Pieces covering the union of ``rects`` without overlaps, minus ``minus``."""
    done: list[Rect] = []
    for r in rects:
        pieces = [r]
        for s in [*done, *minus]:
            pieces = [q for piece in pieces for q in subtract(piece, s)]
        done.extend(q for q in pieces if q.x1 - q.x0 > 1e-6 and q.y1 - q.y0 > 1e-6)
    return done


def kerb_strips(sidewalks: Sequence[Rect], asphalt: Sequence[Rect], width: float) -> list[Rect]:
    """Strips ``width`` m wide along every sidewalk edge that touches the asphalt."""
    tol, out = 0.05, []
    for r in sidewalks:
        for a in asphalt:
            x0, x1 = max(r.x0, a.x0), min(r.x1, a.x1)
            y0, y1 = max(r.y0, a.y0), min(r.y1, a.y1)
            w = min(width, r.y1 - r.y0, r.x1 - r.x0)
            if x1 - x0 > 0.5 and abs(a.y1 - r.y0) < tol:
                out.append(Rect(x0, r.y0, x1, r.y0 + w))
            elif x1 - x0 > 0.5 and abs(a.y0 - r.y1) < tol:
                out.append(Rect(x0, r.y1 - w, x1, r.y1))
            elif y1 - y0 > 0.5 and abs(a.x1 - r.x0) < tol:
                out.append(Rect(r.x0, y0, r.x0 + w, y1))
            elif y1 - y0 > 0.5 and abs(a.x0 - r.x1) < tol:
                out.append(Rect(r.x1 - w, y0, r.x1, y1))
    return out


# ---------------------------------------------------------------------- structure zones
def zone_side(zone: Rect, asphalt: Sequence[Rect]) -> float:
    """+1 if the road lies to the left of ``zone``'s long axis (``Rect.long_axis``), else -1.

    The road is the asphalt piece whose centre is nearest the axis across it; with no
    asphalt, -1.
    """
    origin, d, _, _ = zone.long_axis()
    normal = np.array([-d[1], d[0]])
    road = np.array([[(a.x0 + a.x1) / 2, (a.y0 + a.y1) / 2] for a in asphalt]).reshape(-1, 2)
    rel = road - origin
    nearest = rel[np.argmin(np.abs(rel @ normal))] if len(road) else -normal
    return 1.0 if float(nearest @ normal) > 0 else -1.0


@dataclass(frozen=True)
class LampPosts:
    """The lamp posts of one structure zone (world xy, m): post k < ``n`` stands at
    ``foot_origin + direction * s_k`` and its lamp head hangs over
    ``head_origin + direction * s_k``, s_k = ``POST_FIRST`` + k ``POST_SPACING``.

    ``side``: +1 when the arms (and the road) are to the left of ``direction``, -1 right.
    """

    foot_origin: np.ndarray  # (2,) start of the line of the posts' feet
    head_origin: np.ndarray  # (2,) start of the line of the heads, LAMP_ARM m nearer the road
    direction: np.ndarray  # (2,) unit vector along the zone's long axis
    length: float  # m, the zone's length along ``direction``
    n: int
    side: float

    @property
    def yaw(self) -> float:
        """Heading of ``direction`` (rad, CCW from world +x)."""
        return float(np.arctan2(self.direction[1], self.direction[0]))

    def along(self) -> np.ndarray:
        """(n,) distance of each post from the lines' start (m)."""
        return POST_FIRST + POST_SPACING * np.arange(self.n)

    def feet(self) -> np.ndarray:
        """(n, 2) world xy of the posts' feet (m)."""
        return self.foot_origin[None, :] + self.along()[:, None] * self.direction[None, :]

    def heads(self) -> np.ndarray:
        """(n, 3) world positions of the lamp heads' undersides (m), at ``LAMP_HEAD_Z``."""
        xy = self.head_origin[None, :] + self.along()[:, None] * self.direction[None, :]
        return np.column_stack([xy, np.full(self.n, LAMP_HEAD_Z)])


def lamp_posts(zone: Rect, side: float) -> LampPosts | None:
    """The lamp posts of structure zone ``zone`` whose road side is ``side``
    (``zone_side``); None when the zone is too short for one (< ``POST_FIRST`` m)."""
    origin, d, length, depth = zone.long_axis()
    n = int((length - POST_FIRST) // POST_SPACING) + 1
    if n <= 0:
        return None
    normal = np.array([-d[1], d[0]])
    inset = depth / 2 - POST_INSET  # from the zone's centre line toward the road (m)
    return LampPosts(
        origin + normal * side * inset, origin + normal * side * (inset + LAMP_ARM), d, length, n, side
    )


def lamp_heads(layout: RoadLayout) -> np.ndarray:
    """(N, 3) world positions (m) of the lamp heads on ``layout`` (every structure zone's
    ``lamp_posts``): where ``sim.scene`` draws them and ``sim.weather`` lights from."""
    asphalt = disjoint(layout.asphalt)
    rows = [lamp_posts(z, zone_side(z, asphalt)) for z in layout.structure_zones]
    heads = [r.heads() for r in rows if r is not None]
    return np.concatenate(heads) if heads else np.zeros((0, 3))
