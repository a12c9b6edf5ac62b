"""The PyBullet scene (``sim.scene``) on its own, without a renderer: pooled scenery that
does not grow with the road, lamp posts where ``sim.roadside`` puts them, actor bodies
and the segmentation look-up."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from lookahead.perception.camera import CameraModel
from lookahead.sim.bullet import BulletClient
from lookahead.sim.layout import Marking, Rect, RoadLayout
from lookahead.sim.roadside import disjoint, lamp_posts, zone_side
from lookahead.sim.scene import Scene, ground_colour
from lookahead.sim.shapes import make_shape

CAM = CameraModel.from_fov(320, 180, 90.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-2.0)
EGO = (100.0, 0.0, 0.0)


def road(length: float) -> RoadLayout:
    return RoadLayout(
        asphalt=(Rect(0.0, -3.5, length, 3.5),),
        sidewalks=(Rect(0.0, -6.5, length, -3.5), Rect(0.0, 3.5, length, 6.5)),
        markings=(Marking((0.0, 0.0), (length, 0.0), dashed=True),),
        structure_zones=(Rect(0.0, 7.5, length, 21.5), Rect(0.0, -21.5, length, -7.5)),
    )


@pytest.fixture()
def client():
    c = BulletClient(hidden_z=-1000.0)
    yield c
    c.close()


def base_positions(client: BulletClient) -> np.ndarray:
    """(N, 3) base positions of every body in the client (m)."""
    uids = [p.getBodyUniqueId(i, physicsClientId=client.cid) for i in range(p.getNumBodies(physicsClientId=client.cid))]
    return np.array([p.getBasePositionAndOrientation(u, physicsClientId=client.cid)[0] for u in uids])


def test_pooled_scenery_does_not_grow_with_the_road() -> None:
    counts = []
    for length in (1_000.0, 10_000.0):
        c = BulletClient(hidden_z=-1000.0)
        try:
            Scene(c, CAM, road(length), seed=3, far=250.0, backend="tiny")
            counts.append(p.getNumBodies(physicsClientId=c.cid))
        finally:
            c.close()
    assert counts[0] == counts[1] > 0


def test_lamp_posts_stand_where_roadside_puts_them(client: BulletClient) -> None:
    layout = road(2_000.0)
    scene = Scene(client, CAM, layout, seed=3, far=250.0, backend="tiny")
    scene.show_scenery(EGO, structures=True)
    pos = base_positions(client)
    asphalt = disjoint(layout.asphalt)
    for zone in layout.structure_zones:
        posts = lamp_posts(zone, zone_side(zone, asphalt))
        feet = posts.feet()
        ahead = feet[(feet[:, 0] > EGO[0] + 5.0) & (feet[:, 0] < EGO[0] + 150.0)]
        assert len(ahead) >= 4
        for x, y in ahead:
            assert np.min(np.abs(pos - [x, y, 0.0]).sum(axis=1)) < 1e-9, (x, y)
    scene.show_scenery(EGO, structures=False)  # silhouettes: no roadside structures
    pos = base_positions(client)
    assert not np.any(np.isclose(pos[:, 0], feet[0, 0]) & np.isclose(pos[:, 1], feet[0, 1]))


def test_actor_bodies_and_segmentation_ids(client: BulletClient) -> None:
    scene = Scene(client, CAM, road(500.0), seed=1, far=250.0, backend="tiny")
    scene.add_actor(7, make_shape("pedestrian", "adult", np.random.default_rng(0)))
    uid = p.getBodyUniqueId(p.getNumBodies(physicsClientId=client.cid) - 1, physicsClientId=client.cid)
    assert scene.actor_ids(np.array([[uid, -1, 0]])).tolist() == [[7, -1, -1]]
    with pytest.raises(ValueError, match="already added"):
        scene.add_actor(7, make_shape("pedestrian", "adult", np.random.default_rng(0)))
    with pytest.raises(KeyError):
        scene.place_actors({8: (110.0, 0.0, 0.0, 0.0)})
    scene.place_actors({7: (110.0, -5.0, 0.0, 0.0)})  # on the pavement: lifted onto it
    z = p.getBasePositionAndOrientation(uid, physicsClientId=client.cid)[0][2]
    assert z == pytest.approx(0.15)
    scene.remove_actor(7)
    scene.remove_actor(7)  # unknown ids are ignored
    assert scene.actor_ids(np.array([uid])).tolist() == [-1]


def test_ground_colour_is_seeded() -> None:
    assert np.array_equal(ground_colour(4), ground_colour(4))
    assert np.all((ground_colour(4) >= 0.0) & (ground_colour(4) <= 1.0))
