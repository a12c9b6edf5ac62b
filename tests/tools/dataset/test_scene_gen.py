"""The detector-data scene generator: deterministic, disjoint splits, forced weather, clear errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from lookahead.sim.scenario import ScenarioError
from lookahead.tools.dataset.export import with_camera
from lookahead.tools.dataset.scene_gen import (
    GeneratorSpec,
    generate_scenario,
    load_generator,
    split_seeds,
)

ROOT = Path(__file__).resolve().parents[3]
SHIPPED = ROOT / "scenarios" / "generators" / "detector.yaml"


@pytest.fixture(scope="module")
def spec() -> GeneratorSpec:
    return load_generator(SHIPPED)


def test_same_seed_same_scene_and_seeds_differ(spec):
    a, b = generate_scenario(spec, 17), generate_scenario(spec, 17)
    assert a.model_dump() == b.model_dump()
    c = generate_scenario(spec, 18)
    assert c.model_dump() != a.model_dump()
    assert a.perception.detector.kind == "gt" and not a.end_on_collision


def test_shipped_splits_are_disjoint(spec):
    seen: set[int] = set()
    for name in ("train", "val", "test"):
        seeds = set(split_seeds(spec, name))
        assert seeds and not seeds & seen
        seen |= seeds


def test_forced_weather_changes_only_the_weather(spec):
    base = generate_scenario(spec, 5).model_dump()
    for kind in ("clear", "night", "fog", "rain"):
        forced = generate_scenario(spec, 5, weather=kind).model_dump()
        assert forced["weather"]["kind"] == kind
        assert {k: v for k, v in forced.items() if k != "weather"} == {
            k: v for k, v in base.items() if k != "weather"}
    assert generate_scenario(spec, 5, weather="fog").weather.visibility == pytest.approx(80.0)


def test_scenes_cover_every_class_and_stay_valid(spec):
    classes = set()
    for seed in range(40):
        sc = generate_scenario(spec, seed)  # validated by the Scenario model
        classes |= {a.type for a in sc.actors}
        assert 1 <= sc.road.lanes <= 4 and all(a.start.x >= 3.0 for a in sc.actors)
    assert {"pedestrian", "cyclist", "motorcyclist", "tricycle", "car", "truck", "bus", "animal"} <= classes


def test_bad_generator_file_is_one_line(tmp_path):
    bad = tmp_path / "gen.yaml"
    bad.write_text("generator:\n  splits:\n    train: {seeds: [10, 5]}\n")
    with pytest.raises(ScenarioError, match=r"gen\.yaml: generator\.splits\.train\.seeds"):
        load_generator(bad)
    bad.write_text("generator:\n  splits: {train: {seeds: [0, 2]}}\n  lanez: 3\n")
    with pytest.raises(ScenarioError, match="lanez"):
        load_generator(bad)
    bad.write_text("generator:\n  splits: {train: {seeds: [0, 20]}, val: {seeds: [10, 30]}}\n")
    with pytest.raises(ScenarioError, match=r"gen\.yaml: generator\.splits: split 'train' \[0, 20\] overlaps split 'val'"):
        load_generator(bad)
    with pytest.raises(ValueError, match="--split"):
        split_seeds(load_generator(SHIPPED), "holdout")


def test_the_focus_generator_draws_more_animals_and_night_than_the_shipped_one(spec):
    focus = load_generator(SHIPPED.with_name("detector_focus.yaml"))
    assert {n: focus.splits[n].seeds for n in ("val", "test")} == {n: spec.splits[n].seeds for n in ("val", "test")}

    def drawn(s: GeneratorSpec) -> tuple[int, int]:
        scenes = [generate_scenario(s, seed) for seed in range(10800, 10860)]
        animals = sum(a.type == "animal" for sc in scenes for a in sc.actors)
        return animals, sum(sc.weather.kind == "night" for sc in scenes)

    (a0, n0), (a1, n1) = drawn(spec), drawn(focus)
    assert a1 > 1.5 * a0 and n1 > n0


@pytest.mark.parametrize("wh", [(960, 540), (1280, 720)])
def test_a_larger_camera_sees_the_same_scenes(spec, wh):
    """``export-dataset --camera WxH``: detector.yaml's scenes seed for seed, only the pixels differ."""
    big = with_camera(spec, wh)
    for split in ("train", "val", "test"):
        assert split_seeds(big, split) == split_seeds(spec, split)
    for seed in (3, 200017):
        a, b = generate_scenario(spec, seed).model_dump(), generate_scenario(big, seed).model_dump()
        assert (b["camera"].pop("width"), b["camera"].pop("height")) == wh
        a["camera"].pop("width"), a["camera"].pop("height")
        assert a == b  # the field of view, mount, actors, weather: all the same


def test_a_camera_out_of_range_is_refused(spec):
    with pytest.raises(ValueError, match=r"^--camera 8000x720: width .*4096"):
        with_camera(spec, (8000, 720))


@pytest.mark.parametrize(("body", "field"), [
    ("  lane_width: [3.8, 3.0]\n", "generator.lane_width: expected [min, max] with min <= max, got [3.8, 3.0]"),
    ("  lanes: [4, 1]\n", "generator.lanes: expected [min, max]"),
    ("  traffic: [6, 0]\n", "generator.traffic: expected [min, max]"),
    ("  ego_speed: [15.0, 0.0]\n", "generator.ego_speed: expected [min, max]"),
    ("  actors: {count: [10, 3]}\n", "generator.actors.count: expected [min, max]"),
    ("  actors: {x: [90.0, 3.0]}\n", "generator.actors.x: expected [min, max]"),
    ("  actors: {parked_cars: [3, 0]}\n", "generator.actors.parked_cars: expected [min, max]"),
    ("  camera: {fov_h: [95.0, 85.0]}\n", "generator.camera.fov_h: expected [min, max]"),
    ("  camera: {pitch: [.nan, 2.0]}\n", "generator.camera.pitch.0: Input should be a finite number"),
    ("  weather: {fog_visibility: [.nan, .nan]}\n", "generator.weather.fog_visibility.0"),
    ("  weather: {intensity: [.inf, 1.0]}\n", "generator.weather.intensity.0"),
    ("  weather: {fog_visibility: [0.0, 300.0]}\n", "generator.weather.fog_visibility.0"),
    ("  actors: {count: [0, 1000000000]}\n", "generator.actors.count.1"),
    ("  actors: {mix: {dragon: 1.0}}\n", "generator.actors.mix: unknown class(es) dragon"),
    ("  actors: {mix: {car: -1.0}}\n", "generator.actors.mix: expected weights >= 0"),
    ("  camera: {fov_h: [85.0, 200.0]}\n", "generator.camera.fov_h.1"),
])
def test_a_reversed_or_non_finite_range_is_one_line_naming_file_and_field(tmp_path, capsys, lookahead, body, field):
    gen = tmp_path / "gen.yaml"
    gen.write_text("generator:\n  splits: {train: {seeds: [0, 2]}}\n" + body)
    with pytest.raises(ScenarioError) as err:
        load_generator(gen)
    assert f"{gen}: {field}" in str(err.value) and "\n" not in str(err.value), str(err.value)
    code = lookahead("export-dataset", gen, "--format", "coco", "--out", tmp_path / "out")
    lines = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
    assert code == 2 and len(lines) == 1 and f"{gen}: {field}" in lines[0], lines
    assert not (tmp_path / "out").exists()


def test_equal_range_ends_are_a_constant(tmp_path):
    gen = tmp_path / "gen.yaml"
    gen.write_text("generator:\n  splits: {train: {seeds: [0, 2]}}\n  lane_width: [3.5, 3.5]\n  lanes: [2, 2]\n")
    sc = generate_scenario(load_generator(gen), 1)
    assert sc.road.lane_width == 3.5 and sc.road.lanes == 2
