"""The detector's training side: targets and the exported decoder agree; a real training run
exports an ONNX model that ``OnnxDetector`` runs unchanged; AP and recall-at-precision on paper cases."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lookahead.perception.detections import CLASS_ID, CLASSES  # noqa: E402
from lookahead.perception.detectors.onnx_detector import OnnxDetector  # noqa: E402
from lookahead.tools.detector.data import STRIDE, encode  # noqa: E402
from lookahead.tools.detector.evaluate import evaluate_split, recall_at_precision  # noqa: E402
from lookahead.tools.detector.model import CenterDet, Decoded  # noqa: E402
from lookahead.tools.detector.train import TrainConfig, focal_loss, train  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]


class _Oracle(torch.nn.Module):
    """Stands in for ``CenterDet``: returns fixed heat logits and regression maps."""

    num_classes = 8

    def __init__(self, heat: torch.Tensor, reg: torch.Tensor) -> None:
        super().__init__()
        self.heat, self.reg = heat, reg

    def forward(self, x):
        return self.heat, self.reg


def test_decoder_inverts_the_targets():
    hw = (128, 192)
    boxes = np.array([[10.3, 20.7, 18.9, 44.1], [100.0, 50.0, 160.5, 90.25], [60.2, 60.2, 63.9, 66.0]], np.float32)
    classes = np.array([0, 4, 7])
    t = encode(boxes, classes, np.ones(3, bool), hw, 8)
    gh, gw = hw[0] // STRIDE, hw[1] // STRIDE
    heat = torch.full((1, 8, gh, gw), -10.0)
    reg = torch.zeros(1, 4, gh * gw)
    for k in np.flatnonzero(t.valid):  # 4 regression cells per object, the centre cell first
        i = int(t.index[k])
        if k % 4 == 0:
            heat[0, classes[k // 4], i // gw, i % gw] = 10.0
        u = np.clip((t.reg[k, :2] + 0.5) / 2.0, 1e-6, 1 - 1e-6)  # cell_offset = 2 sigmoid - 0.5
        reg[0, :2, i] = torch.from_numpy(np.log(u / (1 - u)))
        reg[0, 2:, i] = torch.from_numpy(t.reg[k, 2:])  # log size in cells; the decoder gives px
    out = Decoded(_Oracle(heat, reg.reshape(1, 4, gh, gw)))(torch.zeros(1, 3, *hw))[0].numpy()
    assert out.shape == (12, gh * gw)
    keep = out[4:].max(axis=0) > 0.5
    got = out[:4, keep].T
    cxcywh = np.stack([(boxes[:, 0] + boxes[:, 2]) / 2, (boxes[:, 1] + boxes[:, 3]) / 2,
                       boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]], axis=1)
    np.testing.assert_allclose(got[np.argsort(got[:, 0])], cxcywh[np.argsort(cxcywh[:, 0])], atol=1e-3)
    assert sorted(out[4:, keep].argmax(axis=0).tolist()) == sorted(classes.tolist())


def test_ignored_objects_are_masked_not_taught():
    boxes = np.array([[10, 10, 30, 40], [60, 60, 70, 64]], np.float32)
    t = encode(boxes, np.array([1, 2]), np.array([True, False]), (128, 128), 8)
    assert t.heat[1].max() == 1.0 and t.heat[2].max() == 0.0
    assert t.mask[15, 15] == 0.0 and t.mask[5, 5] == 1.0
    assert t.valid.sum() == 4  # the trained object's 2 x 2 regression cells
    assert np.all((t.reg[:4, :2] >= -0.5) & (t.reg[:4, :2] < 1.5))
    logits = torch.full((1, 8, 32, 32), -3.0)
    base = focal_loss(logits, torch.from_numpy(t.heat)[None], torch.from_numpy(t.mask)[None, None])
    logits[0, 2, 15, 15] = 5.0  # a confident "detection" inside the ignored box costs nothing
    same = focal_loss(logits, torch.from_numpy(t.heat)[None], torch.from_numpy(t.mask)[None, None])
    assert float(same) == pytest.approx(float(base))


def test_recall_at_precision_and_ap_on_paper():
    # ranked: TP TP FP TP FP, 4 objects: precision 1, 1, .67, .75, .6 -> at p >= .95 recall is 2/4
    score = np.array([0.9, 0.8, 0.7, 0.6, 0.5])
    tp = np.array([True, True, False, True, False])
    assert recall_at_precision(score, tp, 4, 0.95) == pytest.approx(0.5)
    assert recall_at_precision(score, tp, 4, 0.7) == pytest.approx(0.75)


def test_each_object_not_found_is_told_apart_as_wrong_class_loose_or_missed():
    from lookahead.tools.detector.data import Split

    gt = np.array([[10, 10, 50, 90], [100, 10, 140, 90], [200, 10, 240, 90], [260, 10, 300, 90]], np.float32)
    split = Split(images=np.zeros((1, 120, 320, 3), np.uint8), boxes=[gt], classes=[np.array([0, 0, 4, 4])],
                  visible=[np.ones(4, np.float32)], ranges=[np.array([7.0, 15.0, 25.0, 45.0])], names=["a.png"])

    def detect(img):  # found; right box, wrong class; right class, box too far off; nothing near the 4th
        xyxy = np.array([[10, 10, 50, 90], [100, 10, 140, 90], [218, 10, 258, 90]], np.float64)
        return xyxy, np.array([0.9, 0.8, 0.7]), np.array([0, 1, 4])

    m = evaluate_split(split, detect, min_size=0)
    out = m["outcomes"]
    assert out["by_class"]["pedestrian"] == {"gt": 2, "found": 1, "wrong_class": 1, "loose": 0, "missed": 0}
    assert out["by_class"]["car"] == {"gt": 2, "found": 0, "wrong_class": 0, "loose": 1, "missed": 1}
    assert [v["found"] for v in out["by_range"].values()] == [1, 0, 0, 0, 0]
    assert [v["gt"] for v in out["by_range"].values()] == [1, 1, 1, 0, 1]
    assert out["by_height"]["40-inf"] == {"gt": 4, "found": 1, "wrong_class": 1, "loose": 1, "missed": 1}
    assert sum(v["gt"] for v in out["by_height"].values()) == 4
    assert sum(v["found"] for v in out["by_class"].values()) == round(m["recall"] * m["gt"])


def test_each_false_positive_is_told_apart_and_what_removing_its_kind_would_gain():
    from lookahead.tools.detector.data import Split

    gt = np.array([[10, 10, 50, 90], [100, 10, 140, 90]], np.float32)  # a pedestrian, a car
    split = Split(images=np.zeros((1, 120, 320, 3), np.uint8), boxes=[gt], classes=[np.array([0, 4])],
                  visible=[np.ones(2, np.float32)], ranges=[np.array([10.0, 20.0])], names=["a.png"])
    boxes = np.array([
        [10, 10, 50, 90],    # 0.90 pedestrian: found
        [100, 10, 140, 90],  # 0.30 car: found, ranked last
        [11, 10, 51, 90],    # 0.85 pedestrian again: a duplicate
        [100, 10, 140, 90],  # 0.80 cyclist on the car: wrong class
        [30, 10, 70, 90],    # 0.95 pedestrian half off the pedestrian: badly boxed, ranked first
        [120, 10, 160, 90],  # 0.60 truck half off the car: wrong class and box
        [250, 10, 290, 90],  # 0.50 animal on nothing: background
    ], np.float64)
    score = np.array([0.9, 0.3, 0.85, 0.8, 0.95, 0.6, 0.5])
    cls = np.array([0, 4, 0, 1, 0, 5, 7])

    m = evaluate_split(split, lambda img: (boxes, score, cls), conf=0.25, min_size=0)
    fp = m["false_positives"]
    assert [fp[k]["count"] for k in ("duplicate", "wrong_class", "badly_boxed", "wrong_class_and_box",
                                     "background")] == [1, 1, 1, 1, 1]
    assert fp["all"]["count"] == 5 and m["fp"] == 5
    # the pedestrian's AP is halved by the loose box ranked above it (the duplicate ranks below):
    # AP50 mean (0.5 + 1) / 2; the classes the other false positives carry have no objects
    assert m["ap50"] == 0.75 and fp["badly_boxed"]["ap50"] == 1.0 and fp["duplicate"]["ap50"] == 0.75
    # pooled, the loose box ranks first: while it counts, precision never reaches 0.95
    assert m["recall_at_p95"] == 0.0 and fp["background"]["recall_at_p95"] == 0.0
    assert fp["all"]["ap50"] == 1.0 and fp["all"]["recall_at_p95"] == 1.0


def test_a_minimum_height_makes_shorter_objects_and_detections_dont_care_as_kitti_does():
    from lookahead.tools.detector.data import Split

    gt = np.array([[10, 10, 50, 90], [100, 40, 104, 50], [200, 40, 204, 50]], np.float32)  # 80, 10, 10 px tall
    split = Split(images=np.zeros((1, 120, 320, 3), np.uint8), boxes=[gt], classes=[np.array([0, 0, 0])],
                  visible=[np.ones(3, np.float32)], ranges=[np.array([10.0, 40.0, 40.0])], names=["a.png"])

    def detect(img):  # the tall one; one short one found; a short box and a tall box on nothing
        xyxy = np.array([[10, 10, 50, 90], [100, 40, 104, 50], [250, 40, 254, 50], [260, 10, 300, 90]], np.float64)
        return xyxy, np.array([0.9, 0.8, 0.7, 0.6]), np.array([0, 0, 0, 0])

    every = evaluate_split(split, detect, min_size=0)
    assert every["gt"] == 3 and every["tp"] == 2 and every["fp"] == 2
    assert every["outcomes"]["by_height"]["8-12"] == {"gt": 2, "found": 1, "wrong_class": 0, "loose": 0, "missed": 1}
    tall = evaluate_split(split, detect, min_size=0, min_height=25)
    # the short one found and the short box on nothing are neither TP nor FP; the tall false box stays false
    assert tall["gt"] == 1 and tall["tp"] == 1 and tall["fp"] == 1
    assert tall["false_positives"]["background"]["count"] == 1
    assert tall["recall"] == 1.0 and tall["ap50"] == 1.0 and tall["min_height_px"] == 25


def test_a_split_reads_its_images_when_used_and_names_a_bad_one(tmp_path):
    import cv2

    from lookahead.tools.detector.data import load_split

    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (36, 64, 3), dtype=np.uint8) for _ in range(3)]
    (tmp_path / "images").mkdir()
    doc = {"images": [], "annotations": [], "categories": []}
    for i, f in enumerate(frames):
        cv2.imwrite(str(tmp_path / "images" / f"{i}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
        doc["images"].append({"id": i + 1, "file_name": f"images/{i}.png", "height": 36, "width": 64})
    doc["annotations"].append({"id": 1, "image_id": 2, "bbox": [4, 5, 10, 20], "category_id": 5,
                               "occlusion": 0.25, "attributes": {"range_m": 12.0}})
    (tmp_path / "annotations.json").write_text(json.dumps(doc))
    split = load_split(tmp_path)
    assert len(split.images) == 3 and split.classes[1].tolist() == [4] and split.visible[1][0] == 0.75
    np.testing.assert_array_equal(split.images[1], frames[1])  # RGB, as written
    np.testing.assert_array_equal(split.boxes[1], [[4, 5, 14, 25]])
    assert len(load_split(tmp_path, limit=2).images) == 2
    cv2.imwrite(str(tmp_path / "images" / "2.png"), np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match=r"2\.png: 10x10 px, the split's first image is 64x36"):
        split.images[2]
    (tmp_path / "images" / "0.png").unlink()
    with pytest.raises(FileNotFoundError, match=r"0\.png: no such image \(1 of 3 missing\)"):
        load_split(tmp_path)


def _write_split(root: Path, frames: list[np.ndarray], category: int) -> None:
    import cv2

    (root / "images").mkdir(parents=True)
    doc = {"images": [], "annotations": [], "categories": []}
    for i, f in enumerate(frames):
        cv2.imwrite(str(root / "images" / f"{i}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
        h, w = f.shape[:2]
        doc["images"].append({"id": i + 1, "file_name": f"images/{i}.png", "height": h, "width": w})
        doc["annotations"].append({"id": i + 1, "image_id": i + 1, "bbox": [4, 5, 10, 20], "category_id": category,
                                   "occlusion": 0.0, "attributes": {"range_m": 12.0}})
    (root / "annotations.json").write_text(json.dumps(doc))


def test_several_splits_read_as_one_in_order_and_a_limit_counts_across_them(tmp_path):
    from lookahead.tools.detector.data import load_splits

    rng = np.random.default_rng(1)
    a = [rng.integers(0, 256, (36, 64, 3), dtype=np.uint8) for _ in range(2)]
    b = [rng.integers(0, 256, (36, 64, 3), dtype=np.uint8) for _ in range(3)]
    _write_split(tmp_path / "a", a, category=5)
    _write_split(tmp_path / "b", b, category=8)
    both = load_splits([tmp_path / "a", tmp_path / "b"])
    assert len(both.images) == 5 and [c.tolist() for c in both.classes] == [[4], [4], [7], [7], [7]]
    np.testing.assert_array_equal(both.images[2], b[0])
    assert len(load_splits([tmp_path / "a", tmp_path / "b"], limit=3).images) == 3
    assert len(load_splits([tmp_path / "a", tmp_path / "b"], limit=2).names) == 2  # b not needed
    _write_split(tmp_path / "c", [np.zeros((48, 64, 3), np.uint8)], category=5)
    with pytest.raises(ValueError, match=r"c: 64x48 px images, .*a's are 64x36"):
        load_splits([tmp_path / "a", tmp_path / "c"])


def test_evaluate_split_counts_by_range_and_visibility():
    from lookahead.tools.detector.data import Split

    gt = np.array([[10, 10, 50, 90], [100, 10, 140, 90], [200, 10, 240, 90]], np.float32)
    split = Split(images=np.zeros((1, 120, 320, 3), np.uint8), boxes=[gt], classes=[np.array([0, 0, 4])],
                  visible=[np.array([1.0, 0.3, 1.0], np.float32)], ranges=[np.array([20.0, 20.0, 70.0])],
                  names=["a.png"])

    def detect(img):  # finds the evaluated one, the occluded one (don't care) and a false one
        xyxy = np.array([[10, 10, 50, 90], [100, 10, 140, 90], [260, 10, 300, 90]], np.float64)
        return xyxy, np.array([0.9, 0.8, 0.7]), np.array([0, 0, 0])

    m = evaluate_split(split, detect)
    assert m["gt"] == 1 and m["tp"] == 1 and m["fp"] == 1  # the far car is don't care (70 m)
    assert m["recall"] == 1.0 and m["precision"] == 0.5 and m["ap50"] == 1.0


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory) -> Path:
    """Four training and two validation frames exported from the scene generator."""
    from lookahead.tools.dataset.export import export_generated

    root = tmp_path_factory.mktemp("det")
    gen = root / "gen.yaml"
    gen.write_text("generator:\n  duration: 1.0\n  splits:\n    train: {seeds: [0, 2]}\n    val: {seeds: [900, 901]}\n")
    export_generated(gen, "coco", 1, root / "ds")
    return root / "ds"


def test_a_real_training_run_exports_a_model_the_detector_runs(tiny_dataset, tmp_path):
    doc = json.loads((tiny_dataset / "train" / "annotations.json").read_text())
    assert len(doc["images"]) == 4 and doc["annotations"]
    out = tmp_path / "m.onnx"
    result = train(tiny_dataset, out, TrainConfig(epochs=2, batch=2, warmup_steps=1, eval_every=0))
    assert result["history"][-1]["loss"] < result["history"][0]["loss"] * 1.5
    assert "val" in result["history"][-1]
    det = OnnxDetector(out)
    assert det.layout == "v8" and det.num_classes == len(CLASSES) and det.input_hw == (384, 640)
    assert det.dynamic_input  # zoom windows run at their own size
    assert det.names[0] == "pedestrian" and det.class_map is not None
    d = det.detect(np.zeros((360, 640, 3), np.uint8))
    assert d.xyxy.shape[1] == 4
    assert det.infer(det.preprocess(np.zeros((96, 320, 3), np.uint8), zoom=3.0)[0]).shape == (1, 4 + len(CLASSES), 72 * 240)
    net = CenterDet()
    assert sum(p.numel() for p in net.parameters()) < 2_000_000


def test_an_interrupted_run_resumes_to_the_weights_of_an_uninterrupted_one(tiny_dataset, tmp_path):
    from lookahead.tools.detector.train import ResumeError, state_path

    cfg = TrainConfig(epochs=3, batch=2, warmup_steps=1, eval_every=2)
    whole = train(tiny_dataset, tmp_path / "whole.onnx", cfg)

    class Crash(Exception):
        pass

    def crash_in_epoch_3(fraction):  # after the first step of the third epoch (2 steps per epoch)
        if fraction > 2 / 3:
            raise Crash

    cut = tmp_path / "cut.onnx"
    with pytest.raises(Crash):
        train(tiny_dataset, cut, cfg, progress=crash_in_epoch_3)
    assert state_path(cut).is_file()
    with pytest.raises(ResumeError, match=r"cut\.state\.pt: written by a different run: lr=0\.002 \(now 0\.001\)"):
        train(tiny_dataset, cut, TrainConfig(epochs=3, batch=2, warmup_steps=1, eval_every=2, lr=1e-3), resume=True)
    resumed = train(tiny_dataset, cut, cfg, resume=True)
    a = torch.load(tmp_path / "whole.pt", weights_only=True)
    b = torch.load(tmp_path / "cut.pt", weights_only=True)
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert [e["loss"] for e in resumed["history"]] == [e["loss"] for e in whole["history"]]
    assert resumed["history"][1]["val"] == whole["history"][1]["val"]  # epoch 2's validation, from before the cut
    with pytest.raises(ResumeError, match="nothing to resume, all 3 epochs are done"):
        train(tiny_dataset, cut, cfg, resume=True)
    with pytest.raises(FileNotFoundError, match="no training state to resume"):
        train(tiny_dataset, tmp_path / "never.onnx", cfg, resume=True)


def test_an_exported_model_loads_back_for_fine_tuning(tmp_path):
    # the shipped ONNX (BatchNorm folded) back into a CenterDet: same outputs when re-exported,
    # and train-mode BatchNorm on calibration-like batches changes the function only slightly
    import onnxruntime as ort

    from lookahead.perception.detectors.onnx_detector import ModelError
    from lookahead.tools.detector.from_onnx import load_exported
    from lookahead.tools.detector.train import export_onnx

    shipped = ROOT / "models" / "lookahead-det.onnx"
    rng = np.random.default_rng(0)
    base = rng.uniform(0.2, 0.8, (1, 3, 1, 1)) + np.linspace(-0.2, 0.2, 640)[None, None, None, :]
    x = np.clip(base + rng.normal(0, 0.05, (1, 3, 384, 640)), 0, 1).astype(np.float32)
    calib = [torch.from_numpy(x[:, :, 64:320, 128:512].copy()) for _ in range(2)]
    net = CenterDet(num_classes=OnnxDetector(shipped).num_classes)  # the shipped file's class count
    load_exported(net, shipped, calib)
    out = export_onnx(net, tmp_path / "again.onnx", {})
    a = ort.InferenceSession(str(shipped)).run(None, {"images": x})[0]
    b = ort.InferenceSession(str(out)).run(None, {"images": x})[0]
    # class scores: equal but where the graph's 3 x 3 peak test flips between two near-equal
    # neighbouring cells (one side then reads 0); such flips are rare
    off = np.abs(b[0, 4:] - a[0, 4:]) > 1e-4
    assert off.mean() < 1e-4
    assert np.all((a[0, 4:][off] == 0) | (b[0, 4:][off] == 0))
    np.testing.assert_allclose(b[0, :4], a[0, :4], atol=0.05)  # boxes, px
    net.train()
    with torch.no_grad():
        train_heat = net(calib[0])[0]
        net.eval()
        eval_heat = net(calib[0])[0]
    assert float((train_heat - eval_heat).abs().mean()) < 0.01
    with pytest.raises(ModelError, match="convolution"):
        load_exported(CenterDet(widths=(16, 32, 64, 96, 128)), shipped, calib)


def test_resume_without_a_state_is_one_line_and_exit_2(tiny_dataset, tmp_path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    res = CliRunner().invoke(app, ["train-detector", str(tiny_dataset), "--out", str(tmp_path / "m.onnx"), "--resume"])
    assert res.exit_code == 2
    assert "m.state.pt: no training state to resume" in res.output and "Traceback" not in res.output


def _randomised(net):
    """``net`` with BatchNorm statistics and affine parameters away from their defaults."""
    g = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for m in net.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.copy_(torch.randn(m.num_features, generator=g) * 0.1)
                m.running_var.copy_(torch.rand(m.num_features, generator=g) + 0.5)
                m.weight.copy_(torch.rand(m.num_features, generator=g) + 0.5)
                m.bias.copy_(torch.randn(m.num_features, generator=g) * 0.1)
    return net


def test_a_network_grows_into_a_wider_one_that_computes_the_same_function():
    from lookahead.tools.detector.growth import grow
    from lookahead.tools.detector.train import reg_loss

    small = _randomised(CenterDet(widths=(8, 16, 24, 32, 40), neck=16, head=8))
    wide = grow(small, CenterDet(widths=(12, 16, 32, 48, 40), neck=24, head=16))
    assert wide.arch == {"widths": (12, 16, 32, 48, 40), "neck": 24, "head": 16, "blocks": (0, 0, 0, 0),
                         "num_classes": len(CLASSES)}
    x = torch.rand(2, 3, 64, 96, generator=torch.Generator().manual_seed(2))
    for mode in ("eval", "train"):  # train mode: batch statistics, the same for the old channels
        small.train(mode == "train")
        wide.train(mode == "train")
        with torch.no_grad():
            for a, b in zip(small(x), wide(x), strict=True):
                torch.testing.assert_close(b, a, rtol=0, atol=1e-6)
    # the grown channels are read by nothing yet, and the first gradient reaches what reads them
    assert torch.count_nonzero(wide.heat.weight[:, 8:]) == 0
    heat, reg = wide(x)
    loss = focal_loss(heat, torch.zeros_like(heat), torch.ones_like(heat)) + reg_loss(
        reg, torch.zeros(2, 1, dtype=torch.long), torch.zeros(2, 1, 4), torch.ones(2, 1))
    loss.backward()
    assert float(wide.heat.weight.grad[:, 8:].abs().sum()) > 0
    assert float(wide.f4[0].weight.grad[8:].abs().sum()) == 0  # rows feeding only zero columns: not yet


def test_a_model_of_fewer_classes_starts_one_of_more_that_finds_what_it_found(tmp_path):
    """An eight-class model (before ``obstacle``) starts a nine-class network: the old classes'
    heat maps and the boxes are its own, the new class starts at the focal-loss prior, and the
    exported file reads back as nine classes with the new one named."""
    import torch

    from lookahead.tools.detector.growth import architecture, grow
    from lookahead.tools.detector.train import export_onnx, model_metadata

    torch.manual_seed(0)
    old = CenterDet(num_classes=8, widths=(8, 16, 24, 32, 40), neck=16, head=8).eval()
    with torch.no_grad():  # a trained head: not the all-equal initial biases
        old.heat.bias.copy_(torch.linspace(-3.0, -1.0, 8))
    assert architecture({k: tuple(v.shape) for k, v in old.state_dict().items()})["num_classes"] == 8
    new = grow(old, CenterDet(widths=(8, 16, 24, 32, 40), neck=16, head=8)).eval()
    x = torch.rand(1, 3, 64, 96)
    (h0, r0), (h1, r1) = old(x), new(x)
    torch.testing.assert_close(h1[:, :8], h0)
    torch.testing.assert_close(r1, r0)
    assert h1.shape[1] == len(CLASSES) == 9
    assert float(torch.sigmoid(h1[:, CLASS_ID["obstacle"]]).mean()) < 0.1  # finds no obstacle yet
    path = export_onnx(new, tmp_path / "nine.onnx", model_metadata(None, None), input_hw=(64, 96))
    det = OnnxDetector(path)
    assert det.num_classes == 9 and det.names[CLASS_ID["obstacle"]] == "obstacle"


def test_a_network_grows_into_a_deeper_one_that_computes_the_same_function():
    from lookahead.tools.detector.growth import grow
    from lookahead.tools.detector.train import reg_loss

    small = _randomised(CenterDet(widths=(8, 16, 24, 32, 40), neck=16, head=8))
    deep = grow(small, CenterDet(widths=(8, 16, 24, 32, 40), neck=16, head=8, blocks=(1, 1, 2, 1)))
    assert sum(p.numel() for p in deep.parameters()) > sum(p.numel() for p in small.parameters())
    x = torch.rand(2, 3, 64, 96, generator=torch.Generator().manual_seed(3))
    for mode in ("eval", "train"):
        small.train(mode == "train")
        deep.train(mode == "train")
        with torch.no_grad():
            for a, b in zip(small(x), deep(x), strict=True):
                torch.testing.assert_close(b, a, rtol=0, atol=1e-6)
    # the added blocks add nothing yet; the first gradient reaches the scale that lets them
    heat, reg = deep(x)
    loss = focal_loss(heat, torch.zeros_like(heat), torch.ones_like(heat)) + reg_loss(
        reg, torch.zeros(2, 1, dtype=torch.long), torch.zeros(2, 1, 4), torch.ones(2, 1))
    loss.backward()
    added = deep.s16[3].b[1].weight  # the second block added at stride 16
    assert torch.count_nonzero(added) == 0 and float(added.grad.abs().sum()) > 0


def test_the_architecture_is_read_back_from_weights_and_a_network_never_shrinks(tmp_path):
    from lookahead.tools.detector.arch import ArchitectureError
    from lookahead.tools.detector.from_onnx import exported_architecture
    from lookahead.tools.detector.growth import architecture, grow
    from lookahead.tools.detector.train import export_onnx

    shipped = ROOT / "models" / "lookahead-det.onnx"
    assert exported_architecture(shipped) == CenterDet(num_classes=OnnxDetector(shipped).num_classes).arch
    arch = {"widths": (8, 16, 24, 32, 40), "neck": 16, "head": 8, "blocks": (1, 0, 2, 1), "num_classes": len(CLASSES)}
    net = CenterDet(**arch)
    assert architecture({k: tuple(v.shape) for k, v in net.state_dict().items()}) == arch
    assert exported_architecture(export_onnx(net, tmp_path / "small.onnx", {}, input_hw=(64, 96))) == arch
    with pytest.raises(ArchitectureError, match="grown, not shrunk"):
        grow(CenterDet(), net)
    with pytest.raises(ArchitectureError, match="grown, not shrunk"):  # fewer blocks
        grow(net, CenterDet(**{**arch, "blocks": (0, 0, 2, 1)}))
    with pytest.raises(ArchitectureError, match="no parameter 's2.0.weight'"):
        architecture({"conv.weight": (8, 3, 3, 3)})


def test_a_larger_network_fine_tunes_from_a_smaller_model_and_exports(tiny_dataset, tmp_path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app
    from lookahead.tools.detector.from_onnx import exported_architecture

    small = tmp_path / "small.onnx"
    cfg = dict(epochs=1, batch=2, warmup_steps=1, eval_every=0, widths=(8, 16, 24, 32, 40), neck=16, head=8)
    train(tiny_dataset, small, TrainConfig(**cfg))
    grown = tmp_path / "grown.onnx"
    train(tiny_dataset, grown, TrainConfig(**{**cfg, "neck": 24, "head": 16, "blocks": (0, 1, 0, 2),
                                              "init": str(small)}))
    assert exported_architecture(grown) == {"widths": (8, 16, 24, 32, 40), "neck": 24, "head": 16,
                                            "blocks": (0, 1, 0, 2), "num_classes": len(CLASSES)}
    assert OnnxDetector(grown).detect(np.zeros((360, 640, 3), np.uint8)).xyxy.shape[1] == 4
    res = CliRunner().invoke(app, ["train-detector", str(tiny_dataset), "--out", str(tmp_path / "m.onnx"),
                                   "--init", str(grown), "--widths", "8", "16", "24", "32", "40",
                                   "--neck", "16", "--head", "8", "--epochs", "1"])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert "grown, not shrunk" in res.output and "grown.onnx" in res.output


def test_scale_jitter_magnifies_training_frames_as_a_zoom_window_does(tiny_dataset):
    from lookahead.tools.detector.data import TrainSampler, load_split

    split = load_split(tiny_dataset / "train")
    i = int(np.argmax([len(b) for b in split.boxes]))
    native = TrainSampler(split, (256, 384), 8, seed=0, scale_range=(1.0, 1.0))
    zoomed = TrainSampler(split, (256, 384), 8, seed=0, scale_range=(2.0, 2.0))
    # the same draws, so the same object centres the crop; whole objects are twice the size
    sizes = []
    for s in (native, zoomed):
        crop, tgt = s.sample(i)
        assert crop.shape == (256, 384, 3)
        sizes.append(np.exp(tgt.reg[tgt.valid > 0][:, 2:]).max())
    assert sizes[1] == pytest.approx(2 * sizes[0], rel=0.05)


def test_a_frame_larger_than_the_input_is_magnified_from_its_own_pixels(monkeypatch):
    # a 1280 x 720 frame is half-size at the model input; scale 2 shows it at its own
    # resolution, so a 1-px checkerboard stays one, not the grey that resizing to 640 wide
    # first would leave; object sizes are those of the run-time letterbox times the scale
    from lookahead.tools.detector import data
    from lookahead.tools.detector.data import Split, TrainSampler

    monkeypatch.setattr(data, "_photometric", lambda img, rng: img)  # no blur or noise drawn

    board = ((np.indices((720, 1280)).sum(axis=0) % 2) * 255).astype(np.uint8)
    split = Split(images=np.repeat(board[None, :, :, None], 3, axis=3),
                  boxes=[np.array([[600, 300, 640, 380]], np.float32)], classes=[np.array([0])],
                  visible=[np.ones(1, np.float32)], ranges=[np.array([20.0])], names=["a.png"])
    for scale, height in ((1.0, 40.0), (2.0, 80.0)):
        crop, tgt = TrainSampler(split, (256, 384), 8, seed=0, scale_range=(scale, scale)).sample(0)
        assert crop.shape == (256, 384, 3)
        assert np.exp(tgt.reg[tgt.valid > 0][:, 3]).max() * 4 == pytest.approx(height, rel=0.02)
        contrast = np.abs(np.diff(crop[:, :, 0].astype(int), axis=1)).mean()
        assert contrast > 200 if scale == 2.0 else contrast < 30


def test_a_reversed_scale_range_is_one_line_and_exit_2(tiny_dataset, tmp_path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    res = CliRunner().invoke(app, ["train-detector", str(tiny_dataset), "--out", str(tmp_path / "m.onnx"),
                                   "--scale", "2", "1"])
    assert res.exit_code == 2 and "--scale: LO <= HI expected" in res.output and "Traceback" not in res.output


def test_a_run_from_an_exported_model_keeps_its_start_to_average_with(tiny_dataset, tmp_path):
    # the unfolded start (.init.pt) computes the exported model's function; a soup of it and
    # the run's own weights at (1, 0) is the start again
    import onnxruntime as ort

    from lookahead.tools.detector.soup import soup
    from lookahead.tools.detector.train import init_checkpoint

    cfg = {"epochs": 1, "batch": 2, "warmup_steps": 1, "eval_every": 0}
    first = tmp_path / "first.onnx"
    train(tiny_dataset, first, TrainConfig(**cfg))
    assert not init_checkpoint(first).exists()  # a run from random weights has no start to keep
    second = tmp_path / "second.onnx"
    train(tiny_dataset, second, TrainConfig(**cfg, init=str(first), seed=1))
    start = torch.load(init_checkpoint(second), weights_only=True)
    assert init_checkpoint(second) == tmp_path / "second.init.pt"
    again = soup([init_checkpoint(second), tmp_path / "second.pt"], tmp_path / "again.onnx", [1.0, 0.0])
    x = np.random.default_rng(0).uniform(0, 1, (1, 3, 384, 640)).astype(np.float32)
    a = ort.InferenceSession(str(first)).run(None, {"images": x})[0]
    b = ort.InferenceSession(str(again)).run(None, {"images": x})[0]
    np.testing.assert_allclose(b[0, :4], a[0, :4], atol=0.05)  # boxes, px
    assert np.mean(np.abs(b[0, 4:] - a[0, 4:]) > 1e-4) < 1e-3  # class scores (peak-test flips aside)
    assert any(not torch.equal(start[k], v) for k, v in torch.load(tmp_path / "second.pt", weights_only=True).items())


def test_balance_centres_crops_on_rare_classes_as_often_as_on_common_ones():
    from lookahead.tools.detector.data import Split, TrainSampler

    # one frame: nine cars at the left, one animal at the far right, out of reach of a car-centred crop
    cars = np.array([[20 + 12 * k, 150, 50 + 12 * k, 175] for k in range(9)], dtype=np.float32)
    boxes = np.vstack([cars, [[600, 160, 624, 180]]]).astype(np.float32)
    classes = np.array([4] * 9 + [7])
    split = Split(np.full((1, 360, 640, 3), 90, np.uint8), [boxes], [classes], [np.ones(10, np.float32)],
                  [np.full(10, 20.0, np.float32)], ["f.png"])

    def animal_share(balance: float) -> float:
        sampler = TrainSampler(split, (256, 384), 8, seed=3, balance=balance, scale_range=(1.0, 1.0))
        return np.mean([sampler.sample(0)[1].heat[7].max() == 1.0 for _ in range(400)])

    # 70 % of crops centre on an object: 1 in 10 of them on the animal at balance 0, 1 in 2 at balance 1
    even, by_class = animal_share(0.0), animal_share(1.0)
    assert by_class - even == pytest.approx(0.7 * (0.5 - 0.1), abs=0.08)


def test_balance_out_of_range_is_one_line_and_exit_2(tiny_dataset, tmp_path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    res = CliRunner().invoke(app, ["train-detector", str(tiny_dataset), "--out", str(tmp_path / "m.onnx"),
                                   "--balance", "1.5"])
    assert res.exit_code == 2 and "--balance" in res.output and "Traceback" not in res.output


def test_a_run_trains_on_several_datasets_at_once_and_names_them(tiny_dataset, tmp_path):
    import onnx
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    second = tmp_path / "more"
    (second / "train").mkdir(parents=True)
    (second / "train" / "images").symlink_to(tiny_dataset / "train" / "images")
    (second / "train" / "annotations.json").write_text((tiny_dataset / "train" / "annotations.json").read_text())
    out, log = tmp_path / "m.onnx", tmp_path / "log.json"
    res = CliRunner().invoke(app, ["train-detector", str(tiny_dataset), str(second), "--out", str(out),
                                   "--epochs", "1", "--batch", "2", "--log", str(log)])
    assert res.exit_code == 0, res.output
    assert json.loads(log.read_text())["images"] == 8  # four frames from each
    meta = {p.key: p.value for p in onnx.load(str(out)).metadata_props}
    assert meta["train_data"] == f"{tiny_dataset},{second}"
    res = CliRunner().invoke(app, ["train-detector", str(tiny_dataset), str(tmp_path / "none"), "--out", str(out)])
    assert res.exit_code == 2 and "none" in res.output and "Traceback" not in res.output


class _Planted:
    """Stands in for a pickled object that would run code when loaded."""

    def __reduce__(self):
        return (print, ("code from a data file ran",))


def test_resume_never_unpickles_code(tiny_dataset, tmp_path, capsys):
    from lookahead.tools.detector.train import ResumeError, state_path

    out = tmp_path / "planted.onnx"
    torch.save({"run": {}, "epoch": 0, "payload": _Planted()}, state_path(out))
    with pytest.raises(ResumeError, match=r"planted\.state\.pt: not a training state this tool wrote"):
        train(tiny_dataset, out, TrainConfig(epochs=2, batch=2, warmup_steps=1), resume=True)
    assert "code from a data file ran" not in capsys.readouterr().out
