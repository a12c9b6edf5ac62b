"""Dataset export round trips: labels re-read from each format match the ground truth."""

from __future__ import annotations

import configparser
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from lookahead.perception.detections import CLASSES
from lookahead.perception.geometry import iou_matrix
from lookahead.perception.mot import read_mot
from lookahead.perception.tracker import TrackState
from lookahead.sim.scenario import load_scenario
from lookahead.tools.dataset.export import FORMATS, export_dataset, export_scenarios

ROOT = Path(__file__).resolve().parents[3]
SCENARIO = ROOT / "scenarios" / "urban_mix.yaml"  # many classes in view from the start
DURATION, EVERY = 1.5, 2
TOL_PX = 0.5


class Capture:
    """Keeps each frame's ground truth and tracks (the export's reference)."""

    def __init__(self) -> None:
        self.frames: dict[int, tuple] = {}

    def on_start(self, info: dict) -> None: ...

    def on_tick(self, rec) -> None:
        self.frames[rec.frame_index] = (rec.ground_truth, rec.tracks)

    def on_end(self, summary: dict) -> None: ...


def expected(gt) -> list[int]:
    """Indices of the GT rows every format must label: class_id >= 0, a visible box."""
    v = gt.visible
    ok = (gt.class_id >= 0) & np.all(np.isfinite(v), axis=1) & (gt.visible_fraction > 0)
    return np.flatnonzero(ok & (v[:, 2] > v[:, 0]) & (v[:, 3] > v[:, 1])).tolist()


@pytest.fixture(scope="module")
def short():
    sc = load_scenario(SCENARIO)
    det = sc.perception.detector.model_copy(update={"kind": "gt"})  # the default ONNX model may be absent
    return sc.model_copy(update={"duration": DURATION, "perception": sc.perception.model_copy(update={"detector": det})})


@pytest.fixture(scope="module")
def exported(short, tmp_path_factory: pytest.TempPathFactory):
    """fmt -> (dataset dir, result, captured frames); one short rendered run per format."""
    out = {}
    for fmt in FORMATS:
        cap = Capture()
        d = tmp_path_factory.mktemp(fmt)
        out[fmt] = (d, export_scenarios([short], fmt, EVERY, d, extra_sinks=[cap]), cap.frames)
    return out


def kept_frames(frames: dict) -> list[int]:
    return [f for f in sorted(frames) if f % EVERY == 0]


def test_counts_and_deterministic_names(exported, short) -> None:
    d, res, frames = exported["yolo"]
    kept = kept_frames(frames)
    assert res["frames"] == len(kept) == 8
    assert res["objects"] == sum(len(expected(frames[f][0])) for f in kept) > 20
    assert sorted(p.name for p in (d / "images").iterdir()) == [f"urban_mix_{f:06d}.png" for f in kept]
    assert sorted(p.name for p in (d / "labels").iterdir()) == [f"urban_mix_{f:06d}.txt" for f in kept]
    img = cv2.imread(str(d / "images" / f"urban_mix_{kept[-1]:06d}.png"))
    assert img.shape == (short.camera.height, short.camera.width, 3) and img.std() > 5


def test_yolo_round_trip(exported, short) -> None:
    d, _, frames = exported["yolo"]
    data = yaml.safe_load((d / "data.yaml").read_text())
    assert data["nc"] == len(CLASSES) and [data["names"][i] for i in range(len(CLASSES))] == list(CLASSES)
    assert (d / data["train"]).is_dir()
    w, h = short.camera.width, short.camera.height
    for f in kept_frames(frames):
        gt = frames[f][0]
        rows = np.loadtxt(d / "labels" / f"urban_mix_{f:06d}.txt", ndmin=2).reshape(-1, 5)
        idx = expected(gt)
        assert rows[:, 0].astype(int).tolist() == gt.class_id[idx].tolist()
        cx, cy, bw, bh = rows[:, 1] * w, rows[:, 2] * h, rows[:, 3] * w, rows[:, 4] * h
        xyxy = np.column_stack([cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2])
        np.testing.assert_allclose(xyxy, gt.visible[idx], atol=TOL_PX)
        assert np.all((rows[:, 1:] >= 0) & (rows[:, 1:] <= 1))


def test_yolo_attributes_sidecar_round_trip(exported) -> None:
    """attributes/{stem}.json: item k = line k of labels/{stem}.txt, with occlusion, truncation,
    range and actor id as COCO has them; the label files stay 5 columns."""
    d, _, frames = exported["yolo"]
    data = yaml.safe_load((d / "data.yaml").read_text())
    assert data["attributes"] == "attributes"
    kept = kept_frames(frames)
    assert sorted(p.name for p in (d / data["attributes"]).iterdir()) == [f"urban_mix_{f:06d}.json" for f in kept]
    coco = json.loads((exported["coco"][0] / "annotations.json").read_text())
    coco_by_frame = {im["frame_index"]: [a for a in coco["annotations"] if a["image_id"] == im["id"]]
                     for im in coco["images"]}
    n_occluded = 0
    for f in kept:
        gt = frames[f][0]
        idx = expected(gt)
        attrs = json.loads((d / "attributes" / f"urban_mix_{f:06d}.json").read_text())
        lines = (d / "labels" / f"urban_mix_{f:06d}.txt").read_text().splitlines()
        assert len(attrs) == len(lines) == len(idx) and all(len(line.split()) == 5 for line in lines)
        assert [a["actor_id"] for a in attrs] == gt.actor_id[idx].tolist()
        assert [a["class_id"] for a in attrs] == [int(line.split()[0]) for line in lines]
        assert [a["name"] for a in attrs] == [gt.name[i] for i in idx]
        np.testing.assert_allclose([a["occlusion"] for a in attrs], 1 - gt.visible_fraction[idx], atol=1e-3)
        np.testing.assert_allclose([a["truncation"] for a in attrs], gt.truncation[idx], atol=1e-3)
        np.testing.assert_allclose([a["range_m"] for a in attrs], gt.range[idx], atol=1e-3)
        coco_anns = coco_by_frame[f]  # same run, same scenario and seed: the same objects as COCO's
        assert [(a["actor_id"], a["occlusion"], a["truncation"]) for a in attrs] == [
            (c["track_id"], c["occlusion"], c["truncation"]) for c in coco_anns]
        n_occluded += sum(a["occlusion"] > 0.05 for a in attrs)
    assert n_occluded > 0  # the attributes are not all zero


def test_coco_round_trip(exported) -> None:
    d, _, frames = exported["coco"]
    doc = json.loads((d / "annotations.json").read_text())
    assert [c["name"] for c in doc["categories"]] == list(CLASSES)
    cat = {c["id"]: c["name"] for c in doc["categories"]}
    kept = kept_frames(frames)
    assert [im["frame_index"] for im in doc["images"]] == kept
    assert len({a["id"] for a in doc["annotations"]}) == len(doc["annotations"])
    for im in doc["images"]:
        assert (d / im["file_name"]).is_file()
        gt = frames[im["frame_index"]][0]
        anns = [a for a in doc["annotations"] if a["image_id"] == im["id"]]
        idx = expected(gt)
        assert [a["track_id"] for a in anns] == gt.actor_id[idx].tolist()
        assert [cat[a["category_id"]] for a in anns] == [CLASSES[c] for c in gt.class_id[idx]]
        xywh = np.array([a["bbox"] for a in anns]).reshape(-1, 4)
        xyxy = np.column_stack([xywh[:, :2], xywh[:, :2] + xywh[:, 2:]])
        np.testing.assert_allclose(xyxy, gt.visible[idx], atol=TOL_PX)
        np.testing.assert_allclose([a["occlusion"] for a in anns], 1 - gt.visible_fraction[idx], atol=1e-3)
        np.testing.assert_allclose([a["truncation"] for a in anns], gt.truncation[idx], atol=1e-3)


def test_mot_round_trip(exported, short) -> None:
    d, _, frames = exported["mot"]
    seq = d / "urban_mix"
    kept = kept_frames(frames)
    ini = configparser.ConfigParser()
    ini.read(seq / "seqinfo.ini")
    s = ini["Sequence"]
    assert (int(s["seqLength"]), int(s["imWidth"]), int(s["imHeight"])) == (len(kept), short.camera.width, short.camera.height)
    assert int(s["frameRate"]) == round(short.camera.rate / EVERY) and s["imDir"] == "img1"
    assert sorted(p.name for p in (seq / "img1").iterdir()) == [f"{n:06d}.jpg" for n in range(1, len(kept) + 1)]
    mot = read_mot(seq / "gt" / "gt.txt")
    for n, f in enumerate(kept, start=1):
        gt = frames[f][0]
        rows = mot[mot.frame == n]
        idx = expected(gt)
        assert rows.track_id.tolist() == gt.actor_id[idx].tolist()
        assert (rows.extra[:, 0].astype(int) - 1).tolist() == gt.class_id[idx].tolist()
        np.testing.assert_allclose(rows.xyxy, gt.visible[idx], atol=TOL_PX)
        np.testing.assert_allclose(rows.extra[:, 1], gt.visible_fraction[idx], atol=1e-3)
        assert np.all(rows.conf == 1)


def test_study_round_trip(exported) -> None:
    d, _, frames = exported["study"]
    n_tracked = 0
    for f in kept_frames(frames):
        gt, tracks = frames[f]
        assert (d / "images" / f"urban_mix_frame_{f:06d}.jpg").is_file()
        items = json.loads((d / "labels" / f"urban_mix_frame_{f:06d}.json").read_text())
        idx = expected(gt)
        assert [o["actor_id"] for o in items] == gt.actor_id[idx].tolist()
        assert [(o["class"], o["class_id"]) for o in items] == [(gt.cls[i], int(gt.class_id[i])) for i in idx]
        for o, i in zip(items, idx, strict=True):
            (x0, y0), (x1, y1b), (x1b, y1), (x0b, y0b) = o["bbox"]  # TL, TR, BR, BL
            assert (y1b, x1b, x0b, y0b) == (y0, x1, x0, y1)
            np.testing.assert_allclose([x0, y0, x1, y1], gt.visible[i], atol=TOL_PX)
            assert o["distance_m"] == pytest.approx(gt.range[i], abs=0.01)
            assert o["speed_m_s"] == pytest.approx(np.linalg.norm(gt.velocity[i]), abs=0.01)
            if o["tracked_id"] is not None:
                n_tracked += 1
                k = tracks.track_id.tolist().index(o["tracked_id"])
                assert tracks.state[k] == TrackState.CONFIRMED
                assert iou_matrix(tracks.xyxy[k:k + 1], gt.visible[i:i + 1])[0, 0] >= 0.5
        ids = [o["tracked_id"] for o in items if o["tracked_id"] is not None]
        assert len(ids) == len(set(ids))  # one-to-one
    assert n_tracked > 5


def test_export_dataset_from_suite_yaml_and_cli_errors(short, tmp_path: Path, capsys, lookahead) -> None:
    sc = tmp_path / "short.yaml"
    sc.write_text(yaml.safe_dump(short.model_copy(update={"duration": 0.5}).model_dump(mode="json")))
    suite = tmp_path / "suite.yaml"
    suite.write_text("name: tiny\nscenarios: [short.yaml]\n")
    res = export_dataset(suite, "mot", 1, tmp_path / "ds", render=False)  # labels only: fast
    assert [s["name"] for s in res["sequences"]] == ["urban_mix"] and res["frames"] == 5
    assert (tmp_path / "ds" / "urban_mix" / "gt" / "gt.txt").stat().st_size > 0
    assert lookahead("export-dataset", sc, "--format", "voc", "--every", 1, "--out", tmp_path / "x") == 2
    assert capsys.readouterr().err.startswith("error: --format")
    assert lookahead("export-dataset", tmp_path / "missing.yaml", "--format", "yolo", "--every", 1, "--out", tmp_path / "x") == 2
    assert capsys.readouterr().err.startswith("error: ")
    assert lookahead("export-dataset", sc, "--format", "yolo", "--every", 0, "--out", tmp_path / "x") == 2
    assert "--every" in capsys.readouterr().err


def test_a_generator_split_exported_with_other_seeds(tmp_path: Path) -> None:
    """``--seeds`` gives the scenes a file with that range would give; overlaps are refused."""
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    def gen(train: str) -> Path:
        path = tmp_path / f"gen_{train.replace(', ', '_')}.yaml"
        path.write_text(f"generator:\n  duration: 0.5\n  splits:\n    train: {{seeds: [{train}]}}\n"
                        "    val: {seeds: [900, 901]}\n")
        return path

    run = CliRunner().invoke
    base = ["export-dataset", str(gen("0, 2")), "--format", "coco", "--split", "train"]
    res = run(app, [*base, "--seeds", "7", "8", "--out", str(tmp_path / "more")])
    assert res.exit_code == 0, res.output
    assert "train: 1 scenes" in res.output
    res = run(app, ["export-dataset", str(gen("7, 8")), "--format", "coco", "--split", "train",
                    "--out", str(tmp_path / "file")])
    assert res.exit_code == 0, res.output
    a = (tmp_path / "more" / "train" / "annotations.json").read_text()
    assert a == (tmp_path / "file" / "train" / "annotations.json").read_text()
    assert json.loads(a)["images"] and json.loads(a)["annotations"]
    res = run(app, [*base, "--seeds", "899", "905", "--out", str(tmp_path / "bad")])
    assert res.exit_code == 2 and "--seeds: [899, 905) overlaps split 'val' [900, 901)" in res.output
    res = run(app, [*base[:-2], "--seeds", "7", "8", "--out", str(tmp_path / "bad")])
    assert res.exit_code == 2 and "give exactly one --split" in res.output
    assert not (tmp_path / "bad").exists()  # refused before anything was written


def test_a_generator_exported_with_another_camera(tmp_path: Path) -> None:
    """``--camera WxH`` renders the file's scenes at that size: the same objects, boxes scaled."""
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    gen = tmp_path / "gen.yaml"
    gen.write_text("generator:\n  duration: 1.0\n  splits:\n    test: {seeds: [3, 4]}\n")
    run = CliRunner().invoke
    base = ["export-dataset", str(gen), "--format", "coco"]
    for name, extra in (("small", ["--camera", "320x180"]), ("file", [])):
        res = run(app, [*base, *extra, "--out", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
    small, full = (json.loads((tmp_path / n / "test" / "annotations.json").read_text()) for n in ("small", "file"))
    assert {(im["width"], im["height"]) for im in small["images"]} == {(320, 180)}
    assert {(im["width"], im["height"]) for im in full["images"]} == {(640, 360)}
    assert len(small["images"]) == len(full["images"]) == 2
    from lookahead.tools.detector.data import load_split

    a, b = load_split(tmp_path / "small" / "test"), load_split(tmp_path / "file" / "test")
    for i in range(2):
        assert a.images[i].shape == (180, 320, 3)
        big = b.visible[i] >= 0.5  # objects seen in both (a few pixels at 320x180 may vanish)
        assert big.sum() >= 3
        found = [any(c2 == c and np.abs(2 * box2 - box).max() <= 2.5 for box2, c2 in zip(a.boxes[i], a.classes[i], strict=True))
                 for box, c in zip(b.boxes[i][big], b.classes[i][big], strict=True)]
        assert np.mean(found) >= 0.8, found  # the same objects, boxes half the size to a pixel or so
    res = run(app, [*base, "--camera", "wide", "--out", str(tmp_path / "bad")])
    assert res.exit_code == 2 and "WIDTHxHEIGHT" in res.output
    res = run(app, [*base, "--camera", "8000x720", "--out", str(tmp_path / "bad")])
    assert res.exit_code == 2 and "--camera 8000x720: width" in res.output
    assert not (tmp_path / "bad").exists()


# --- names from user data stay file names under --out ------------------------------------------

def test_safe_file_stem_keeps_plain_names_and_defuses_the_rest():
    from lookahead.tools.sinks.rundir import MAX_STEM, safe_file_stem

    for plain in ("urban_mix", "det_000003", "a.b-c_D9"):
        assert safe_file_stem(plain) == plain
    odd = ["../escape", "/abs/path", "..", ".", "", ".hidden", "a b", "a_b-x", "base[v=1]", "base[v=2]",
           "base[v=1.5]", "ünïcode", "new\nline", "C:\\win\\path", "x" * 500, "x" * 501]
    stems = [safe_file_stem(n) for n in odd]
    for name, stem in zip(odd, stems, strict=True):
        assert stem and len(stem) <= MAX_STEM and not stem.startswith("."), (name, stem)
        assert all(c.isascii() and (c.isalnum() or c in "._-") for c in stem), (name, stem)
        assert stem not in (".", "..")
    assert len(set(stems)) == len(stems)  # distinct names, distinct stems (brackets of sweep variants too)
    assert safe_file_stem("base[v=1]").startswith("base_v_1_-")


def test_inside_refuses_a_path_outside_the_root(tmp_path):
    from lookahead.tools.sinks.rundir import OutputError, inside

    assert inside(tmp_path, tmp_path / "a" / "b") == tmp_path / "a" / "b"
    for bad in (tmp_path / ".." / "x", Path("/abs/path"), tmp_path / "a" / ".." / ".." / "y"):
        with pytest.raises(OutputError, match="outside the output directory"):
            inside(tmp_path, bad)


@pytest.mark.parametrize("fmt", FORMATS)
def test_scenario_names_with_paths_or_odd_characters_write_only_under_out(short, tmp_path: Path, fmt: str) -> None:
    abs_target = tmp_path / "abs" / "target"
    names = ["../../escape", str(abs_target), "odd name[v=1] é;|*"]
    scenarios = [short.model_copy(update={"name": n, "duration": 0.3}) for n in names]
    out = tmp_path / "deep" / "ds"
    res = export_scenarios(scenarios, fmt, 1, out, render=False)  # labels only: fast
    assert [s["name"] for s in res["sequences"]] == names and res["frames"] > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep"]  # nothing beside --out
    assert sorted(p.name for p in (tmp_path / "deep").iterdir()) == ["ds"]
    assert not abs_target.exists()
    files = [p for p in out.rglob("*") if p.is_file()]
    assert files and all(p.resolve().is_relative_to(out.resolve()) for p in files)
    assert not any(c in str(p.relative_to(out)) for p in files for c in " []|*;é")


def test_a_generator_name_and_split_names_write_only_under_out(tmp_path: Path) -> None:
    gen = tmp_path / "gen.yaml"
    gen.write_text('generator:\n  name: "../../../evil"\n  duration: 0.5\n  camera: {width: 64, height: 48}\n'
                   '  splits:\n    "../up": {seeds: [0, 1]}\n    "/abs/split": {seeds: [1, 2]}\n')
    out = tmp_path / "o" / "ds"
    res = export_dataset_cli(gen, out)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gen.yaml", "o"] and not Path("/abs/split").exists()
    files = [p for p in out.rglob("*") if p.is_file()]
    assert len([p for p in files if p.name == "annotations.json"]) == 2
    assert all(p.resolve().is_relative_to(out.resolve()) for p in files)


def export_dataset_cli(source: Path, out: Path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    return CliRunner().invoke(app, ["export-dataset", str(source), "--format", "coco", "--out", str(out)])


def test_names_that_would_share_a_file_name_are_refused(short, tmp_path: Path) -> None:
    scenarios = [short.model_copy(update={"name": n, "duration": 0.3}) for n in ("Urban", "urban")]
    with pytest.raises(ValueError, match="distinct file names"):
        export_scenarios(scenarios, "mot", 1, tmp_path / "ds", render=False)
    assert not (tmp_path / "ds").exists()
