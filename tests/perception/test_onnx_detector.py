"""OnnxDetector on real tiny ONNX models whose raw output is a known constant."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from support.onnx_models import constant_output_model

from lookahead.perception.detections import CLASS_ID
from lookahead.perception.detectors import Detector, ModelError, OnnxDetector
from lookahead.perception.letterbox import letterbox, letterbox_boxes

S = 416  # model input side: scale 0.65, pad_y 91 px for a 360 x 640 image
IMAGE = np.zeros((360, 640, 3), dtype=np.uint8)
META_NAMES = "{0: 'car', 1: 'pedestrian', 2: 'traffic light', 3: 'bus'}"

# (xyxy in original pixels, model class index, score)
CANDIDATES = [
    ((100, 50, 200, 150), 0, 0.9),  # A car: kept
    ((104, 52, 204, 152), 0, 0.8),  # B car, IoU ~0.9 with A: suppressed
    ((110, 60, 190, 150), 1, 0.7),  # C pedestrian over A: other class, kept
    ((400, 200, 500, 300), 0, 0.1),  # D below conf_threshold
    ((300, 100, 320, 140), 2, 0.95),  # E traffic light: unknown to us
    ((500, 250, 630, 340), 3, 0.6),  # F bus: kept
    ((600, 300, 660, 380), 0, 0.5),  # G car beyond the image edge: clipped
]
N_ANCHORS = 20
NC = 4


def _lb_rows(size: int | tuple[int, int] = S) -> np.ndarray:
    """(N_ANCHORS, 4 + NC) rows cx, cy, w, h, class scores in pixels letterboxed to ``size``."""
    _, scale, pad = letterbox(IMAGE, size)
    rows = np.zeros((N_ANCHORS, 4 + NC), dtype=np.float32)
    for i, (box, cls, score) in enumerate(CANDIDATES):
        x0, y0, x1, y1 = letterbox_boxes(np.array(box, dtype=float), scale, pad)[0]
        rows[i, :4] = [(x0 + x1) / 2, (y0 + y1) / 2, x1 - x0, y1 - y0]
        rows[i, 4 + cls] = score
    return rows


def v8_output(size: int | tuple[int, int] = S) -> np.ndarray:
    return _lb_rows(size).T[None].copy()  # [1, 4+C, N]


def v5_output() -> np.ndarray:
    rows = _lb_rows()
    obj = rows[:, 4:].max(axis=1, keepdims=True)
    cls = np.where(rows[:, 4:] > 0, 1.0, 0.0).astype(np.float32)
    obj[::2] = np.sqrt(obj[::2])  # every other row: score = obj * cls with both < 1
    cls[::2] *= obj[::2]
    return np.concatenate([rows[:, :4], obj, cls], axis=1)[None].copy()  # [1, N, 5+C]


def make_model(
    path: Path,
    output: np.ndarray,
    names: str | None = META_NAMES,
    input_shape: list[int | str] | None = None,
    dynamic_output: bool = False,
    metadata: dict[str, str] | None = None,
) -> Path:
    """Save an ONNX model whose output is ``output`` whatever ``images`` holds (``dynamic_output``:
    its shape unknown until run time, reported as ["b", "f", "n"])."""
    props = dict(metadata or {}) | ({} if names is None else {"names": names})
    return constant_output_model(path, output, input_shape or [1, 3, S, S], props,
                                 dynamic_output=["b", "f", "n"] if dynamic_output else None)


EXPECTED_XYXY = np.array(
    [[100, 50, 200, 150], [110, 60, 190, 150], [500, 250, 630, 340], [600, 300, 640, 360]]
)
EXPECTED_SCORE = np.array([0.9, 0.7, 0.6, 0.5])


@pytest.mark.parametrize(("make_output", "layout"), [(v8_output, "v8"), (v5_output, "v5")])
def test_decode_letterbox_nms_and_class_mapping(tmp_path: Path, make_output, layout: str) -> None:
    det = OnnxDetector(make_model(tmp_path / "m.onnx", make_output()))
    assert isinstance(det, Detector)
    assert det.layout == layout and det.num_classes == NC and det.input_hw == (S, S)
    assert det.names == ["car", "pedestrian", "traffic light", "bus"]
    assert "CPUExecutionProvider" in det.session.get_providers()
    dets = det.detect(IMAGE)
    np.testing.assert_allclose(dets.xyxy, EXPECTED_XYXY, atol=1e-3)
    np.testing.assert_allclose(dets.score, EXPECTED_SCORE, atol=1e-6)
    assert dets.class_id.tolist() == [
        CLASS_ID["car"],
        CLASS_ID["pedestrian"],
        CLASS_ID["bus"],
        CLASS_ID["car"],
    ]
    assert det.dropped_unknown == 1  # the traffic light
    assert set(det.last_timing_ms) == {"preprocess", "infer", "postprocess", "views"}


def test_split_pipeline_matches_detect(tmp_path: Path) -> None:
    det = OnnxDetector(make_model(tmp_path / "m.onnx", v8_output()))
    img = IMAGE.copy()
    img[..., 0] = 255
    tensor, scale, pad = det.preprocess(img)
    assert tensor.shape == (1, 3, S, S) and tensor.dtype == np.float32
    assert scale == pytest.approx(0.65) and pad == (0.0, 91.0)
    assert tensor[0, 0, 200, 200] == 1.0 and tensor[0, 1, 200, 200] == 0.0  # RGB order kept
    assert tensor[0, 1, 0, 0] == pytest.approx(114 / 255)  # grey padding
    raw = det.infer(tensor)
    np.testing.assert_array_equal(raw, v8_output())
    dets = det.postprocess(raw, scale, pad, img.shape[:2])
    np.testing.assert_allclose(dets.xyxy, det.detect(img).xyxy)


def test_unknown_names_keep_raw_indices(tmp_path: Path) -> None:
    path = make_model(tmp_path / "m.onnx", v8_output(), names="{0: 'a', 1: 'b', 2: 'c', 3: 'd'}")
    dets = OnnxDetector(path).detect(IMAGE)
    assert dets.class_id.tolist() == [2, 0, 1, 3, 0]  # E (0.95) now kept; B still suppressed
    np.testing.assert_allclose(dets.score, [0.95, 0.9, 0.7, 0.6, 0.5], atol=1e-6)


@pytest.mark.parametrize("kind", ["list", "txt", "yaml", "json", "sidecar", "none"])
def test_names_sources(tmp_path: Path, kind: str) -> None:
    path = make_model(tmp_path / "m.onnx", v5_output(), names=None)
    ours = ["car", "pedestrian", "traffic light", "bus"]
    names: object = None
    if kind == "list":
        names = ours
    elif kind == "txt":
        names = tmp_path / "classes.txt"
        names.write_text("\n".join(ours) + "\n")
    elif kind == "yaml":
        names = tmp_path / "data.yaml"
        names.write_text("names:\n  0: car\n  1: pedestrian\n  2: traffic light\n  3: bus\n")
    elif kind == "json":
        names = tmp_path / "names.json"
        names.write_text('["car", "pedestrian", "traffic light", "bus"]')
    elif kind == "sidecar":
        (tmp_path / "m.names").write_text("\n".join(ours))
    det = OnnxDetector(path, names=names)
    dets = det.detect(IMAGE)
    if kind == "none":  # class count from the shape, raw indices
        assert det.names is None and det.num_classes == NC
        assert dets.class_id.tolist() == [2, 0, 1, 3, 0]
    else:
        assert det.names == ours
        assert dets.class_id.tolist() == [4, 0, 6, 4]


def test_coco_aliases_map_to_our_classes(tmp_path: Path) -> None:
    path = make_model(
        tmp_path / "m.onnx", v8_output(), names="{0: 'person', 1: 'bicycle', 2: 'dog', 3: 'kite'}"
    )
    det = OnnxDetector(path)
    assert det.class_map.tolist() == [0, 1, 7, -1]


def test_dynamic_input_fits_the_frame_into_input_size_padded_only_to_a_multiple_of_32(tmp_path: Path) -> None:
    rect = (256, S)  # 360 x 640 at 0.65 is 234 x 416 px, padded to 256 x 416
    dynamic = ["batch", 3, "height", "width"]
    path = make_model(tmp_path / "m.onnx", v8_output(rect), input_shape=dynamic)
    det = OnnxDetector(path, input_size=S)
    assert det.dynamic_input and det.input_hw == (S, S)
    tensor, scale, pad = det.preprocess(IMAGE)
    assert tensor.shape == (1, 3, *rect) and scale == pytest.approx(0.65) and pad == (0.0, 11.0)
    np.testing.assert_allclose(det.detect(IMAGE).xyxy, EXPECTED_XYXY, atol=1e-3)
    assert OnnxDetector(path).input_hw == (640, 640)  # no size given, none in the metadata
    sized = make_model(tmp_path / "s.onnx", v8_output(rect), input_shape=dynamic, metadata={"imgsz": "[384, 640]"})
    assert OnnxDetector(sized).input_hw == (384, 640)


def test_a_zoom_magnifies_exactly_on_a_dynamic_input_and_is_capped_by_a_fixed_one(tmp_path: Path) -> None:
    crop = IMAGE[:100, :200]
    dynamic = OnnxDetector(make_model(tmp_path / "d.onnx", v8_output(), input_shape=["batch", 3, "h", "w"]))
    tensor, scale, pad = dynamic.preprocess(crop, zoom=3.0)
    assert tensor.shape == (1, 3, 320, 608) and scale == 3.0 and pad == (4.0, 10.0)
    fixed = OnnxDetector(make_model(tmp_path / "f.onnx", v8_output()))
    tensor, scale, _ = fixed.preprocess(crop, zoom=3.0)
    assert tensor.shape == (1, 3, S, S) and scale == pytest.approx(S / 200)
    assert fixed.preprocess(crop, zoom=1.5)[1] == 1.5


def test_dynamic_output_resolved_at_run_time(tmp_path: Path) -> None:
    path = make_model(tmp_path / "m.onnx", v8_output(), dynamic_output=True)
    det = OnnxDetector(path)
    assert det.layout is None
    np.testing.assert_allclose(det.detect(IMAGE).xyxy, EXPECTED_XYXY, atol=1e-3)
    assert det.layout == "v8"
    bad = OnnxDetector(
        make_model(tmp_path / "bad.onnx", np.zeros((1, 10, 100), np.float32), dynamic_output=True)
    )
    with pytest.raises(ModelError, match=r"bad\.onnx: output shape \[1, 10, 100\] is neither"):
        bad.detect(IMAGE)


def _error(path: Path, **kwargs) -> str:
    with pytest.raises(ModelError) as info:
        OnnxDetector(path, **kwargs)
    msg = str(info.value)
    assert isinstance(info.value, ValueError)
    assert str(path) in msg and "\n" not in msg
    return msg


def test_missing_file(tmp_path: Path) -> None:
    assert "not found" in _error(tmp_path / "nope.onnx")


def test_garbage_file(tmp_path: Path) -> None:
    path = tmp_path / "garbage.onnx"
    path.write_bytes(b"\x00\x01not a model\xff" * 10)
    assert "not a loadable ONNX model" in _error(path)


def test_output_shape_fits_no_layout(tmp_path: Path) -> None:
    msg = _error(make_model(tmp_path / "flat.onnx", np.zeros((1, 7), np.float32)))
    assert "output shape [1, 7] is neither [1, N, 5+C] nor [1, 4+C, N]" in msg
    msg = _error(make_model(tmp_path / "c.onnx", np.zeros((1, 10, 100), np.float32)))
    assert "[1, 10, 100]" in msg and "C=4" in msg


def test_image_required(tmp_path: Path) -> None:
    det = OnnxDetector(make_model(tmp_path / "m.onnx", v8_output()))
    with pytest.raises(ValueError, match="needs an image"):
        det.detect(None)


def test_a_zoom_window_runs_the_model_on_its_crop_and_its_boxes_land_in_image_pixels(tmp_path):
    # one box at the middle of the 416 x 416 input, 26 px a side, whatever the input holds
    out = np.zeros((1, 4 + NC, N_ANCHORS), dtype=np.float32)
    out[0, :4, 0] = [208, 208, 26, 26]
    out[0, 4, 0] = 0.9
    path = make_model(tmp_path / "m.onnx", out)
    whole = OnnxDetector(path).detect(IMAGE)
    # whole frame: scale 0.65, pad_y 91 -> centre (320, 180), 40 px a side
    np.testing.assert_allclose(whole.xyxy, [[300, 160, 340, 200]], atol=1e-4)
    det = OnnxDetector(path, windows=[(0.25, 0.25, 0.75, 0.75)])
    assert [(c.shape[:2], x, y) for c, x, y, _ in det.views(IMAGE)] == [((360, 640), 0, 0), ((180, 320), 160, 90)]
    dets = det.detect(IMAGE)
    # the window's crop 160..480 x 90..270 at scale 1.3, pad_y 91 -> centre (320, 180), 20 px a side;
    # it lies inside the window, so it replaces the whole frame's box there
    np.testing.assert_allclose(dets.xyxy, [[310, 170, 330, 190]], atol=1e-4)
    assert det.last_timing_ms["views"] == 2


def test_a_bad_zoom_window_is_a_model_error_naming_it(tmp_path):
    path = make_model(tmp_path / "m.onnx", v8_output())
    with pytest.raises(ModelError, match=r"m.onnx: window 0: fractions of the image"):
        OnnxDetector(path, windows=[(0.5, 0.2, 0.4, 0.9)])


HOSTILE = (  # a model's metadata asking for what would allocate gigabytes, or not be parsed at all
    ({"imgsz": "[60000, 60000]"}, "metadata imgsz 60000x60000"),
    ({"imgsz": "60000"}, "metadata imgsz 60000x60000"),
    ({"imgsz": "[640, 100]"}, "metadata imgsz 640x100"),
    ({"imgsz": "[400, 640]"}, "multiple of 32"),
    ({"imgsz": "[0, -32]"}, "metadata imgsz 0x-32"),
    ({"names": "{0: 'car', " + "1: 'x' " * 20000 + "}"}, "metadata 'names' is"),
)


@pytest.mark.parametrize(("metadata", "message"), HOSTILE)
def test_hostile_metadata_is_a_model_error(tmp_path: Path, metadata: dict[str, str], message: str) -> None:
    dynamic = ["batch", 3, "height", "width"]
    path = make_model(tmp_path / "hostile.onnx", v8_output(), input_shape=dynamic, names=None, metadata=metadata)
    assert message in _error(path)


def test_unparsable_imgsz_is_ignored(tmp_path: Path) -> None:
    dynamic = ["batch", 3, "height", "width"]
    for value in ("[1e400, 1]", "nonsense", "[" * 5000):
        path = make_model(tmp_path / "m.onnx", v8_output(), input_shape=dynamic, metadata={"imgsz": value})
        assert OnnxDetector(path).input_hw == (640, 640)


def test_a_huge_input_size_or_static_input_is_a_model_error(tmp_path: Path) -> None:
    dynamic = ["batch", 3, "height", "width"]
    path = make_model(tmp_path / "d.onnx", v8_output(), input_shape=dynamic)
    assert "input_size 60000x60000" in _error(path, input_size=60000)
    assert "larger than 4096 px" in _error(make_model(tmp_path / "s.onnx", v8_output(), input_shape=[1, 3, 60000, 60000]))


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="peak RSS read from /proc")
def test_a_60000_px_imgsz_is_refused_fast_and_small(tmp_path: Path) -> None:
    """The hostile model is refused in well under 2 s and 300 MB (a fresh process, so its peak RSS is the load's)."""
    dynamic = ["batch", 3, "height", "width"]
    path = make_model(tmp_path / "hostile.onnx", v8_output(), input_shape=dynamic, metadata={"imgsz": "[60000, 60000]"})
    # peak RSS from /proc (VmHWM starts afresh at exec; ru_maxrss would carry this pytest's own peak)
    script = (
        "import re, sys, time\n"
        "from lookahead.perception.detectors import ModelError, OnnxDetector\n"
        "import onnxruntime\n"
        "t0 = time.perf_counter()\n"
        "try:\n"
        "    OnnxDetector(sys.argv[1]).detect(__import__('numpy').zeros((360, 640, 3), 'uint8'))\n"
        "except ModelError as e:\n"
        "    hwm = re.search(r'VmHWM:\\s+(\\d+) kB', open('/proc/self/status').read()).group(1)\n"
        "    print(time.perf_counter() - t0, hwm, e)\n"
    )
    res = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    seconds, max_rss_kb, message = res.stdout.split(" ", 2)
    assert "metadata imgsz 60000x60000" in message
    assert float(seconds) < 2.0 and int(max_rss_kb) < 300 * 1024
