"""Where the static scene's pieces lie (``sim.roadside``): disjoint surfaces, kerbs, the
road side of structure zones and the lamp-post layout the scene and the weather share."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.sim.layout import Rect, RoadLayout
from lookahead.sim.roadside import (
    LAMP_ARM,
    LAMP_HEAD_Z,
    POST_FIRST,
    POST_INSET,
    POST_SPACING,
    disjoint,
    kerb_strips,
    lamp_heads,
    lamp_posts,
    zone_side,
)

ASPHALT = (Rect(0.0, -12.0, 2_000.0, 12.0),)
LEFT, RIGHT = Rect(0.0, 13.0, 2_000.0, 27.0), Rect(0.0, -27.0, 2_000.0, -13.0)


def area(rects) -> float:
    return sum((r.x1 - r.x0) * (r.y1 - r.y0) for r in rects)


def test_disjoint_pieces_cover_the_union_without_overlap() -> None:
    a, b = Rect(0.0, 0.0, 10.0, 4.0), Rect(6.0, 2.0, 12.0, 8.0)
    pieces = disjoint([a, b])
    assert area(pieces) == pytest.approx(40.0 + 36.0 - 8.0)
    for i, p in enumerate(pieces):
        for q in pieces[i + 1 :]:
            assert min(p.x1, q.x1) <= max(p.x0, q.x0) or min(p.y1, q.y1) <= max(p.y0, q.y0)
    assert area(disjoint([b], minus=[a])) == pytest.approx(36.0 - 8.0)


def test_kerb_strips_run_along_edges_touching_asphalt() -> None:
    walk = Rect(0.0, 12.0, 100.0, 15.0)
    assert kerb_strips([walk], ASPHALT, 0.2) == [Rect(0.0, 12.0, 100.0, 12.2)]
    assert kerb_strips([Rect(0.0, 20.0, 100.0, 23.0)], ASPHALT, 0.2) == []


def test_zone_side_faces_the_road() -> None:
    assert zone_side(LEFT, ASPHALT) == -1.0  # road to the right of the +x axis
    assert zone_side(RIGHT, ASPHALT) == 1.0
    assert zone_side(Rect(20.0, -500.0, 30.0, 500.0), [Rect(0.0, -500.0, 10.0, 500.0)]) == 1.0  # axis +y
    assert zone_side(LEFT, []) == -1.0


def test_lamp_posts_every_30_m_inside_the_road_side() -> None:
    posts = lamp_posts(LEFT, zone_side(LEFT, ASPHALT))
    assert posts is not None and posts.n == int((2_000.0 - POST_FIRST) // POST_SPACING) + 1 == 67
    feet, heads = posts.feet(), posts.heads()
    edge = LEFT.y0  # the zone's road side
    np.testing.assert_allclose(feet[:2], [[POST_FIRST, edge + POST_INSET], [POST_FIRST + POST_SPACING, edge + POST_INSET]])
    np.testing.assert_allclose(heads[:, :2] - feet, np.tile([0.0, -LAMP_ARM], (posts.n, 1)), atol=1e-12)
    assert np.all(heads[:, 2] == LAMP_HEAD_Z)
    assert lamp_posts(Rect(0.0, 13.0, 9.5, 18.0), -1.0) is None  # 9.5 m long: too short for a post


def test_lamp_heads_cover_every_zone() -> None:
    layout = RoadLayout(asphalt=ASPHALT, structure_zones=(LEFT, RIGHT, Rect(0.0, 30.0, 4.0, 39.0)))
    heads = lamp_heads(layout)
    assert heads.shape == (2 * 67, 3)
    assert set(np.round(heads[:, 1], 9)) == {LEFT.y0 + POST_INSET - LAMP_ARM, RIGHT.y1 - POST_INSET + LAMP_ARM}
    assert lamp_heads(RoadLayout(asphalt=ASPHALT)).shape == (0, 3)
