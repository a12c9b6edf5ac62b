"""Actor shapes: determinism, sizes, gait and the tightness of ``local_box``."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.sim.shapes import SUBTYPES, ActorShape, Part, make_shape

ALL = [(c, s) for c, subs in SUBTYPES.items() for s in subs]
PHASES = np.linspace(0.0, 2.0 * np.pi, 13)


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


_AXIS_FRAME = {  # columns: the part's own x, y, z expressed so that its axis is the named one
    "z": np.eye(3),
    "y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "x": np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
}


def surface_points(part: Part, gait_phase: float, stride: float) -> np.ndarray:
    """Dense points on a part's surface in the local frame, posed independently of sim.shapes."""
    th = part.swing * np.sin(gait_phase + part.phase) if stride > 0 else 0.0
    pivot, pos = np.array(part.pivot), np.array(part.position)
    centre = pivot + _rot_y(th) @ (pos - pivot)
    rot = _rot_y(th + part.tilt)
    h = np.array(part.half_extents)
    if part.kind == "box":
        local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
    elif part.kind == "cylinder":
        t = np.linspace(0.0, 2.0 * np.pi, 181)[:-1]
        rim = np.stack([h[0] * np.cos(t), h[0] * np.sin(t)], axis=1)
        local = np.concatenate([np.column_stack([rim, np.full(len(t), z)]) for z in (-h[2], h[2])])
        local = local @ _AXIS_FRAME[part.axis].T
    else:
        u, v = np.meshgrid(np.linspace(0, np.pi, 61), np.linspace(0, 2 * np.pi, 121))
        local = h[0] * np.stack(
            [np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)], axis=-1
        ).reshape(-1, 3)
    return centre + local @ rot.T


def all_points(shape: ActorShape, gait_phase: float) -> np.ndarray:
    return np.concatenate([surface_points(p, gait_phase, shape.stride) for p in shape.parts])


@pytest.mark.parametrize(("cls", "subtype"), ALL)
def test_same_rng_state_gives_same_shape(cls: str, subtype: str) -> None:
    a = make_shape(cls, subtype, np.random.default_rng(11))
    b = make_shape(cls, subtype, np.random.default_rng(11))
    assert a == b
    assert a.cls == cls and a.subtype == subtype


def test_shapes_vary_with_the_rng() -> None:
    for cls, subtype in ALL:
        shapes = [make_shape(cls, subtype, np.random.default_rng(s)) for s in range(6)]
        assert len({s.parts for s in shapes}) > 1, (cls, subtype)


def test_unknown_class_or_subtype_is_rejected() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="class"):
        make_shape("spaceship", "x", rng)
    with pytest.raises(ValueError, match="subtype"):
        make_shape("car", "limousine", rng)


@pytest.mark.parametrize(("cls", "subtype"), ALL)
def test_local_box_contains_all_parts_and_is_tight(cls: str, subtype: str) -> None:
    shape = make_shape(cls, subtype, np.random.default_rng(3))
    for g in PHASES:
        centre, size = shape.local_box(g)
        pts = all_points(shape, g)
        lo, hi = centre - size / 2, centre + size / 2
        assert np.all(pts >= lo - 1e-9) and np.all(pts <= hi + 1e-9), (cls, subtype, g)
        # tight: the sampled surface reaches every face (sampling error < 1 mm)
        np.testing.assert_allclose(pts.min(axis=0), lo, atol=1e-3)
        np.testing.assert_allclose(pts.max(axis=0), hi, atol=1e-3)


@pytest.mark.parametrize(("cls", "subtype"), ALL)
def test_rest_box_stands_on_the_ground_centred_on_the_footprint(cls: str, subtype: str) -> None:
    shape = make_shape(cls, subtype, np.random.default_rng(4))
    centre, size = shape.local_box(0.0) if shape.stride == 0 else shape._rest
    assert abs(centre[0]) < 1e-9 and abs(centre[1]) < 1e-9
    assert abs(centre[2] - size[2] / 2) < 1e-9  # bottom at z = 0
    assert shape.footprint == pytest.approx((size[0], size[1]))


SIZES = {  # (length range, width range, height range), metres
    ("pedestrian", "adult"): ((0.15, 0.5), (0.3, 0.7), (1.55, 1.95)),
    ("pedestrian", "child"): ((0.1, 0.4), (0.2, 0.5), (1.0, 1.35)),
    ("cyclist", "bicycle"): ((1.5, 2.0), (0.4, 0.8), (1.5, 2.0)),
    ("motorcyclist", "e-bike"): ((1.4, 2.0), (0.5, 0.9), (1.3, 1.9)),
    ("motorcyclist", "motorcycle"): ((1.8, 2.4), (0.6, 1.0), (1.3, 1.9)),
    ("tricycle", "tricycle"): ((1.8, 2.8), (0.9, 1.4), (1.4, 2.0)),
    ("car", "sedan"): ((4.3, 5.0), (1.7, 1.95), (1.35, 1.55)),
    ("car", "suv"): ((4.4, 5.05), (1.8, 2.05), (1.6, 1.85)),
    ("car", "hatchback"): ((3.7, 4.3), (1.6, 1.85), (1.4, 1.6)),
    ("truck", "truck"): ((6.0, 10.0), (2.2, 2.6), (2.9, 3.8)),
    ("bus", "bus"): ((10.0, 13.0), (2.4, 2.6), (2.9, 3.4)),
    ("animal", "dog"): ((0.6, 1.3), (0.12, 0.3), (0.4, 0.8)),
    ("animal", "deer"): ((1.2, 2.0), (0.2, 0.45), (1.1, 1.65)),
    ("animal", "cow"): ((2.0, 3.2), (0.5, 0.85), (1.2, 1.65)),
    ("obstacle", "barrier"): ((1.4, 2.7), (0.3, 0.8), (0.7, 1.1)),
    ("obstacle", "cone"): ((0.3, 0.55), (0.3, 0.55), (0.5, 0.85)),
    ("obstacle", "box"): ((0.2, 0.9), (0.2, 0.9), (0.15, 0.8)),
    ("obstacle", "debris"): ((1.0, 2.6), (0.7, 2.0), (0.15, 0.7)),
    ("obstacle", "bicycle"): ((1.5, 1.8), (0.5, 0.6), (0.95, 1.1)),
}


@pytest.mark.parametrize(("cls", "subtype"), ALL)
def test_sizes_are_plausible(cls: str, subtype: str) -> None:
    for seed in range(8):
        shape = make_shape(cls, subtype, np.random.default_rng(seed))
        (l0, l1), (w0, w1), (h0, h1) = SIZES[(cls, subtype)]
        length, width = shape.footprint
        assert l0 <= length <= l1 and w0 <= width <= w1 and h0 <= shape.height <= h1, (
            seed,
            length,
            width,
            shape.height,
        )


def test_vehicles_have_wheels_inside_the_footprint() -> None:
    expected = {"car": 4, "truck": 4, "bus": 4, "cyclist": 2, "motorcyclist": 2, "tricycle": 3}
    for cls, subtype in ALL:
        if cls not in expected:
            continue
        shape = make_shape(cls, subtype, np.random.default_rng(1))
        wheels = [p for p in shape.parts if p.kind == "cylinder" and p.axis == "y"]
        assert len(wheels) >= expected[cls], (cls, subtype)
        length, width = shape.footprint
        for w in wheels:
            x, y, z = w.position
            r, _, hw = w.half_extents
            assert abs(z - r) < 1e-9  # touching the ground
            assert abs(x) + r <= length / 2 + 1e-9 and abs(y) + hw <= width / 2 + 1e-9


@pytest.mark.parametrize(("cls", "subtype"), [("pedestrian", "adult"), ("animal", "dog")])
def test_legs_swing_in_antiphase_when_walking(cls: str, subtype: str) -> None:
    shape = make_shape(cls, subtype, np.random.default_rng(2))
    assert shape.stride > 0
    rest = np.array([p.tilt for p in shape.parts])
    _, pitch = shape.part_poses(np.pi / 2)
    swing = pitch - rest
    moving = np.abs(swing) > 0.1
    assert moving.sum() >= 4  # two legs + two arms, or four legs
    assert (swing[moving] > 0).sum() == (swing[moving] < 0).sum()
    # mid-stride is at least as long as standing (a person's stride sticks out)
    extra = 0.2 if cls == "pedestrian" else 0.0
    assert shape.local_box(np.pi / 2)[1][0] >= shape.footprint[0] + extra
    centres, pitch0 = shape.part_poses(0.0)  # legs vertical again at phase 0
    np.testing.assert_allclose(pitch0, rest, atol=1e-12)
    np.testing.assert_allclose(centres, [p.position for p in shape.parts], atol=1e-12)


def test_static_shapes_do_not_animate() -> None:
    shape = make_shape("car", "sedan", np.random.default_rng(0))
    assert shape.stride == 0
    for g in PHASES:
        c, s = shape.local_box(g)
        np.testing.assert_array_equal(s, shape.local_box(0.0)[1])
    assert shape.gait_phase_at(12.0) == 0.0


def test_gait_phase_advances_one_cycle_per_stride() -> None:
    shape = make_shape("pedestrian", "adult", np.random.default_rng(0))
    assert shape.gait_phase_at(shape.stride / 4) == pytest.approx(np.pi / 2)
    assert shape.gait_phase_at(shape.stride) == pytest.approx(0.0, abs=1e-9)


def test_local_box_is_fast_enough() -> None:
    import time

    shape = make_shape("animal", "cow", np.random.default_rng(0))
    t = time.perf_counter()
    for g in np.linspace(0, 6, 500):
        shape.local_box(g)
    assert (time.perf_counter() - t) / 500 < 5e-4  # s per call
