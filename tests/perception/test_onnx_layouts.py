"""OnnxDetector's output layouts beyond YOLOv5/v8: raw YOLOX (grid-decoded) and end2end (NMS-free),
and how the layout is chosen (``layout=``, metadata, shape and class count), on real tiny ONNX
models run by onnxruntime."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from onnx import TensorProto, helper, numpy_helper
from pydantic import ValidationError
from support.onnx_models import constant_output_model, save_model

from lookahead.intent.stack import build_detector
from lookahead.perception.config import DetectorSpec
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.detectors import ModelError, OnnxDetector
from lookahead.perception.detectors.onnx_detector import yolox_grid, yolox_strides
from lookahead.perception.letterbox import letterbox, letterbox_boxes

# A non-square image into a non-square fixed input: scale 0.768, pad (0, 13) px
IMAGE = np.zeros((300, 500, 3), dtype=np.uint8)
IN_HW = (256, 384)
GRID_N = 32 * 48 + 16 * 24 + 8 * 12  # 2016 rows of a raw YOLOX output for IN_HW
META_NAMES = "{0: 'car', 1: 'pedestrian', 2: 'traffic light', 3: 'bus'}"
NC = 4

# (xyxy in original pixels, model class index, score)
CANDIDATES = [
    ((100, 50, 200, 150), 0, 0.9),  # A car: kept
    ((104, 52, 204, 152), 0, 0.8),  # B car, IoU ~0.9 with A: suppressed by NMS (kept end2end)
    ((110, 60, 190, 150), 1, 0.7),  # C pedestrian over A: other class, kept
    ((300, 100, 360, 160), 0, 0.1),  # D below conf_threshold
    ((250, 20, 270, 60), 2, 0.95),  # E traffic light: unknown to us, dropped
    ((380, 180, 480, 280), 3, 0.6),  # F bus: kept
    ((450, 240, 520, 320), 0, 0.5),  # G car beyond the image's bottom-right corner: clipped
]
A, B, C, F, G = ([100, 50, 200, 150], [104, 52, 204, 152], [110, 60, 190, 150], [380, 180, 480, 280],
                 [450, 240, 500, 300])
CAR, PED, BUS = CLASS_ID["car"], CLASS_ID["pedestrian"], CLASS_ID["bus"]


def _input_boxes(hw: tuple[int, int] = IN_HW) -> tuple[np.ndarray, float, tuple[float, float]]:
    _, scale, pad = letterbox(IMAGE, hw)
    boxes = letterbox_boxes(np.array([c[0] for c in CANDIDATES], dtype=float), scale, pad)
    assert scale == pytest.approx(0.768) and pad == (0.0, 13.0)
    return boxes, scale, pad


def yolox_raw_output(n_classes: int = NC) -> np.ndarray:
    """[1, GRID_N, 5+C]: each candidate in a cell of its own (strides 8, 16, 32 in turn), as offsets
    and log sizes in cells; objectness and class score sqrt(score) each; other rows all zero."""
    boxes, _, _ = _input_boxes()
    out = np.zeros((1, GRID_N, 5 + n_classes), dtype=np.float32)
    offsets = {8: 0, 16: 48 * 32, 32: 48 * 32 + 24 * 16}
    used = set()
    for i, ((x0, y0, x1, y1), (_, cls, score)) in enumerate(zip(boxes, CANDIDATES, strict=True)):
        s = (8, 16, 32)[i % 3]
        cx, cy, w, h = (x0 + x1) / 2 / s, (y0 + y1) / 2 / s, (x1 - x0) / s, (y1 - y0) / s
        gx, gy = int(cx), int(cy)
        row = offsets[s] + gy * (IN_HW[1] // s) + gx
        assert row not in used
        used.add(row)
        out[0, row, :5] = [cx - gx, cy - gy, np.log(w), np.log(h), np.sqrt(score)]
        out[0, row, 5 + cls] = np.sqrt(score)
    return out


def end2end_output(n_rows: int = 300) -> np.ndarray:
    """[1, n_rows, 6]: x1, y1, x2, y2, score, class id in input pixels; then a class id 7 (none of
    the model's 4) and empty rows (score 0) as max_det padding."""
    boxes, _, _ = _input_boxes()
    out = np.zeros((1, n_rows, 6), dtype=np.float32)
    for i, (box, (_, cls, score)) in enumerate(zip(boxes, CANDIDATES, strict=True)):
        out[0, i] = [*box, score, cls]
    out[0, len(CANDIDATES)] = [10, 10, 50, 50, 0.8, 7]
    return out


def const_model(
    path: Path,
    output: np.ndarray,
    names: str | None = META_NAMES,
    metadata: dict[str, str] | None = None,
    producer: str | None = None,
    dynamic_output: bool = False,
    input_hw: tuple[int, int] = IN_HW,
) -> Path:
    """A model whose output is ``output`` whatever ``images`` holds. ``dynamic_output``: its shape is
    unknown until run time (reported as ["b", "n", "f"])."""
    props = dict(metadata or {}) | ({} if names is None else {"names": names})
    return constant_output_model(path, output, [1, 3, *input_hw], props, producer,
                                 dynamic_output=["b", "n", "f"] if dynamic_output else None)


def pooled_yolox_model(path: Path, box: float, level_gain: tuple[float, ...] = (1.0, 0.9, 0.8)) -> Path:
    """A raw-YOLOX-shaped model on a dynamic input that computes its output from the image:
    per stride s (8, 16, 32) the max of each s x s cell gives objectness (red), car (green) and
    pedestrian (blue) scores, objectness times ``level_gain`` of the stride; each cell's box is
    centred on the cell (offset 0.5) and ``box`` input px a side (log(box / s) cells)."""
    nodes, levels = [], []
    for s, gain in zip((8, 16, 32), level_gain, strict=True):
        consts = {
            f"xywh{s}": np.array([[[0.5, 0.5, np.log(box / s), np.log(box / s)]]], np.float32),
            f"gain{s}": np.array([[[gain, 1.0, 1.0]]], np.float32),
            f"zero{s}": np.zeros((1, 1, 1), np.float32),
            f"flat{s}": np.array([1, 3, -1], np.int64),
        }
        nodes += [helper.make_node("Constant", [], [n], value=numpy_helper.from_array(v, n)) for n, v in consts.items()]
        nodes += [
            helper.make_node("MaxPool", ["images"], [f"pool{s}"], kernel_shape=[s, s], strides=[s, s]),
            helper.make_node("Reshape", [f"pool{s}", f"flat{s}"], [f"cells{s}"]),
            helper.make_node("Transpose", [f"cells{s}"], [f"rgb{s}"], perm=[0, 2, 1]),  # [1, n_s, 3]
            helper.make_node("Mul", [f"rgb{s}", f"gain{s}"], [f"scores{s}"]),
            helper.make_node("ReduceMax", [f"rgb{s}"], [f"any{s}"], axes=[2], keepdims=1),  # [1, n_s, 1]
            helper.make_node("Mul", [f"any{s}", f"zero{s}"], [f"nil{s}"]),
            helper.make_node("Add", [f"nil{s}", f"xywh{s}"], [f"box{s}"]),  # [1, n_s, 4]
            helper.make_node("Concat", [f"box{s}", f"scores{s}"], [f"level{s}"], axis=2),
        ]
        levels.append(f"level{s}")
    nodes.append(helper.make_node("Concat", levels, ["output0"], axis=1))
    graph = helper.make_graph(
        nodes, "pooled",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, ["batch", 3, "height", "width"])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, [1, "n", 7])],
    )
    return save_model(path, graph, {"names": "{0: 'car', 1: 'pedestrian'}", "model_type": "yolox-s"}, None)


# ------------------------------------------------------------------ raw YOLOX


def test_yolox_grid_matches_yolox_demo_postprocess_layout() -> None:
    assert yolox_strides(IN_HW, GRID_N) == (8, 16, 32)
    assert yolox_strides((1280, 1280), 160 * 160 + 80 * 80 + 40 * 40 + 20 * 20) == (8, 16, 32, 64)
    assert yolox_strides(IN_HW, 3 * GRID_N) is None  # a YOLOv5 anchor count: 3 per cell
    cells, stride = yolox_grid(IN_HW, (8, 16, 32))
    assert cells.shape == (GRID_N, 2) and stride.shape == (GRID_N, 1)
    # stride 8 first, row-major with x fastest, as np.meshgrid(arange(w), arange(h)) in YOLOX
    assert cells[:3].tolist() == [[0, 0], [1, 0], [2, 0]] and cells[48].tolist() == [0, 1]
    assert cells[1536].tolist() == [0, 0] and stride[1536, 0] == 16 and stride[-1, 0] == 32
    assert cells[-1].tolist() == [11, 7]


@pytest.mark.parametrize(
    "how",
    [
        {"layout": "yolox"},
        {"metadata": {"model_type": "YOLOX-s"}},
        {"metadata": {"layout": "yolox"}},
        {"producer": "YOLOX exporter"},
    ],
)
def test_raw_yolox_is_decoded_on_its_grid_with_nms_into_original_pixels(tmp_path: Path, how: dict) -> None:
    path = const_model(tmp_path / "x.onnx", yolox_raw_output(), metadata=how.get("metadata"),
                       producer=how.get("producer"))
    det = OnnxDetector(path, layout=how.get("layout", "auto"))
    assert det.layout == "yolox" and det.num_classes == NC and det.input_hw == IN_HW
    dets = det.detect(IMAGE)
    np.testing.assert_allclose(dets.xyxy, [A, C, F, G], atol=5e-3)  # B suppressed, G clipped
    np.testing.assert_allclose(dets.score, [0.9, 0.7, 0.6, 0.5], atol=1e-5)
    assert dets.class_id.tolist() == [CAR, PED, BUS, CAR]
    assert det.dropped_unknown == 1  # the traffic light


def test_a_raw_yolox_output_is_not_guessed_from_its_shape(tmp_path: Path) -> None:
    """Without metadata or layout=, [1, N, 5+C] is yolov5 (a decoded YOLOX export reads that way)."""
    det = OnnxDetector(const_model(tmp_path / "x.onnx", yolox_raw_output()))
    assert det.layout == "v5"
    decoded = OnnxDetector(const_model(tmp_path / "d.onnx", yolox_raw_output(),
                                       metadata={"model_type": "yolox", "decode_in_inference": "True"}))
    assert decoded.layout == "v5"


def test_metadata_yolox_with_a_non_grid_n_falls_back_to_the_shape(tmp_path: Path, caplog) -> None:
    out = np.zeros((1, 3 * GRID_N, 5 + NC), np.float32)  # YOLOv5's 3 anchors per cell
    with caplog.at_level(logging.WARNING):
        det = OnnxDetector(const_model(tmp_path / "x.onnx", out, metadata={"model_type": "yolox"}))
    assert det.layout == "v5" and "does not fit metadata model_type='yolox'" in caplog.text


def test_raw_yolox_on_a_dynamic_input_follows_the_frame_size(tmp_path: Path) -> None:
    """The pooled model's output has one row per cell of the actual input, which depends on the
    frame: 480 x 640 at scale 0.5 is 240 x 320, padded to 256 x 320 (pad_y 8): N = 1680."""
    image = np.zeros((480, 640, 3), dtype=np.uint8)
    image[68:76, 164:172] = (255, 204, 0)  # input px x 82..85, y 42..45: stride-8 cell (10, 5)
    det = OnnxDetector(pooled_yolox_model(tmp_path / "p.onnx", box=64.0), input_size=320)
    assert det.layout == "yolox" and det.num_classes == 2  # chosen at load; N checked per run
    tensor, scale, pad = det.preprocess(image)
    assert tensor.shape == (1, 3, 256, 320) and scale == 0.5 and pad == (0.0, 8.0)
    assert det.infer(tensor).shape == (1, 1680, 7)
    dets = det.detect(image)
    # stride 8 wins (gain 1.0): centre (10.5, 5.5) * 8 = (84, 44) input px, 64 px a side ->
    # x (84 -+ 32) / 0.5, y (44 -+ 32 - 8) / 0.5; the stride 16 and 32 cells' boxes (IoU 0.78) are suppressed
    np.testing.assert_allclose(dets.xyxy, [[104, 8, 232, 136]], atol=1e-3)
    np.testing.assert_allclose(dets.score, [0.8], atol=1e-6)
    assert dets.class_id.tolist() == [CAR]
    # a wider frame: another input size, another N, still decoded on its own grid
    wide = np.zeros((240, 640, 3), dtype=np.uint8)
    wide[72:80, 164:172] = (255, 0, 204)  # pedestrian; 120 x 320 padded to 128 x 320, pad_y 4
    dets = det.detect(wide)
    assert det.infer(det.preprocess(wide)[0]).shape == (1, 16 * 40 + 8 * 20 + 4 * 10, 7)
    assert dets.class_id.tolist() == [PED]
    # input y 40..43 -> stride-8 cell (10, 5): centre (84, 44) -> x 104..232, y (44 -+ 32 - 4) / 0.5
    np.testing.assert_allclose(dets.xyxy, [[104, 16, 232, 144]], atol=1e-3)


def test_raw_yolox_with_a_dynamic_output_is_resolved_at_run_time(tmp_path: Path) -> None:
    path = const_model(tmp_path / "x.onnx", yolox_raw_output(), metadata={"model_type": "yolox"},
                       dynamic_output=True)
    det = OnnxDetector(path)
    assert det.layout is None
    np.testing.assert_allclose(det.detect(IMAGE).xyxy, [A, C, F, G], atol=5e-3)
    assert det.layout == "yolox"


def test_explicit_yolox_with_a_wrong_n_is_a_one_line_error(tmp_path: Path) -> None:
    path = const_model(tmp_path / "x.onnx", np.zeros((1, 100, 5 + NC), np.float32))
    with pytest.raises(ModelError) as info:
        OnnxDetector(path, layout="yolox")
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg
    assert "output shape [1, 100, 9] does not fit layout='yolox'" in msg
    assert "N = 2016 (strides 8, 16, 32)" in msg and "256x384 input" in msg and "C=4" in msg


def test_explicit_yolox_on_a_dynamic_output_errors_at_run_time_naming_the_grid(tmp_path: Path) -> None:
    path = const_model(tmp_path / "x.onnx", np.zeros((1, 100, 5 + NC), np.float32), dynamic_output=True)
    det = OnnxDetector(path, layout="yolox")
    with pytest.raises(ModelError, match=r"output shape \[1, 100, 9\] does not fit layout='yolox': expected "
                                         r"\[1, N, 5\+C\] with N = 2016"):
        det.detect(IMAGE)


# ------------------------------------------------------------------ end2end


@pytest.mark.parametrize(
    ("names", "how"),
    [
        (META_NAMES, {}),  # 6 columns, 4 class names: end2end by the class count
        (META_NAMES, {"layout": "end2end"}),
        (META_NAMES, {"metadata": {"end2end": "True"}}),  # Ultralytics
        (META_NAMES, {"metadata": {"args": "{'batch': 1, 'nms': True}"}}),  # Ultralytics nms=True
        (META_NAMES, {"metadata": {"model_type": "yolov10n"}}),
    ],
)
def test_end2end_rows_are_taken_as_they_are_without_nms(tmp_path: Path, names: str, how: dict) -> None:
    path = const_model(tmp_path / "e.onnx", end2end_output(), names=names, metadata=how.get("metadata"))
    det = OnnxDetector(path, layout=how.get("layout", "auto"))
    assert det.layout == "end2end" and det.num_classes == NC
    dets = det.detect(IMAGE)
    # B overlaps A (IoU ~0.9) and is kept: the model already deduplicated; highest score first
    np.testing.assert_allclose(dets.xyxy, [A, B, C, F, G], atol=1e-3)
    np.testing.assert_allclose(dets.score, [0.9, 0.8, 0.7, 0.6, 0.5], atol=1e-6)
    assert dets.class_id.tolist() == [CAR, CAR, PED, BUS, CAR]
    assert det.dropped_unknown == 2  # the traffic light and the class id 7


def test_end2end_keeps_max_det_and_raw_ids_without_names(tmp_path: Path) -> None:
    det = OnnxDetector(const_model(tmp_path / "e.onnx", end2end_output(), names=None), layout="end2end",
                       max_det=3)
    assert det.names is None and det.num_classes is None
    dets = det.detect(IMAGE)
    # E (0.95), A (0.9), B (0.8, before the class id 7 row of equal score): raw ids, none out of range
    assert dets.class_id.tolist() == [2, 0, 0]
    np.testing.assert_allclose(dets.score, [0.95, 0.9, 0.8], atol=1e-6)
    np.testing.assert_allclose(dets.xyxy[1:], [A, B], atol=1e-3)
    assert det.dropped_unknown == 0


def test_six_columns_with_one_class_name_or_none_read_as_yolov5(tmp_path: Path, caplog) -> None:
    """[1, N, 6] is also YOLOv5 with one class: one class name (or none) keeps that reading unless
    the metadata or layout= say end2end."""
    out = end2end_output()
    one = const_model(tmp_path / "one.onnx", out, names="{0: 'car'}")
    assert OnnxDetector(one).layout == "v5"
    assert OnnxDetector(one, layout="end2end").layout == "end2end"
    with caplog.at_level(logging.WARNING):
        assert OnnxDetector(const_model(tmp_path / "none.onnx", out, names=None)).layout == "v5"
    assert "layout='end2end'" in caplog.text
    flagged = const_model(tmp_path / "flag.onnx", out, names="{0: 'car'}", metadata={"end2end": "True"})
    det = OnnxDetector(flagged)
    assert det.layout == "end2end"
    dets = det.detect(IMAGE)  # only class 0 rows are in range: A, B, D (below threshold), G
    np.testing.assert_allclose(dets.xyxy, [A, B, G], atol=1e-3)


def test_end2end_with_a_dynamic_output_is_resolved_at_run_time(tmp_path: Path) -> None:
    det = OnnxDetector(const_model(tmp_path / "e.onnx", end2end_output(), dynamic_output=True))
    assert det.layout is None
    np.testing.assert_allclose(det.detect(IMAGE).xyxy, [A, B, C, F, G], atol=1e-3)
    assert det.layout == "end2end"


def test_explicit_end2end_with_a_wrong_shape_is_a_one_line_error(tmp_path: Path) -> None:
    path = const_model(tmp_path / "e.onnx", np.zeros((1, 300, 7), np.float32))
    with pytest.raises(ModelError) as info:
        OnnxDetector(path, layout="end2end")
    msg = str(info.value)
    assert "\n" not in msg and "output shape [1, 300, 7] does not fit layout='end2end': expected [1, N, 6]" in msg


# ------------------------------------------------------------------ every layout alike


def _centre_box_output(layout: str) -> np.ndarray:
    """One car 26 input px a side at the centre (208, 208) of a 416 x 416 input, in ``layout``."""
    if layout == "v8":
        out = np.zeros((1, 4 + NC, 50), np.float32)
        out[0, :5, 0] = [208, 208, 26, 26, 0.9]
    elif layout == "v5":
        out = np.zeros((1, 50, 5 + NC), np.float32)
        out[0, 0, :6] = [208, 208, 26, 26, 1.0, 0.9]
    elif layout == "yolox":  # stride 8 cell (26, 26) is row 26 * 52 + 26
        out = np.zeros((1, 52 * 52 + 26 * 26 + 13 * 13, 5 + NC), np.float32)
        out[0, 26 * 52 + 26, :6] = [0, 0, np.log(26 / 8), np.log(26 / 8), 1.0, 0.9]
    else:
        out = np.zeros((1, 100, 6), np.float32)
        out[0, 0] = [195, 195, 221, 221, 0.9, 0]
    return out


@pytest.mark.parametrize("layout", ["v5", "v8", "yolox", "end2end"])
def test_zoom_windows_work_alike_for_every_layout(tmp_path: Path, layout: str) -> None:
    """As test_onnx_detector's window test: a 360 x 640 frame at scale 0.65 (pad_y 91) puts the box
    at (320, 180), 40 px a side; the centre window's crop at scale 1.3 puts it there, 20 px a side,
    and the window's box replaces the frame's."""
    image = np.zeros((360, 640, 3), np.uint8)
    path = const_model(tmp_path / "m.onnx", _centre_box_output(layout), input_hw=(416, 416))
    arg = {"v5": "yolov5", "v8": "yolov8"}.get(layout, layout)
    whole = OnnxDetector(path, layout=arg)
    assert whole.layout == layout
    np.testing.assert_allclose(whole.detect(image).xyxy, [[300, 160, 340, 200]], atol=1e-3)
    det = OnnxDetector(path, layout=arg, windows=[(0.25, 0.25, 0.75, 0.75)])
    dets = det.detect(image)
    np.testing.assert_allclose(dets.xyxy, [[310, 170, 330, 190]], atol=1e-3)
    np.testing.assert_allclose(dets.score, [0.9], atol=1e-6)
    assert dets.class_id.tolist() == [CAR] and det.last_timing_ms["views"] == 2


def test_a_shape_no_layout_fits_names_every_layout_expected(tmp_path: Path) -> None:
    path = const_model(tmp_path / "bad.onnx", np.zeros((1, 10, 100), np.float32))
    with pytest.raises(ModelError) as info:
        OnnxDetector(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert "output shape [1, 10, 100] is neither [1, N, 5+C] nor [1, 4+C, N] nor [1, N, 6] with C=4" in msg
    assert "yolov5" in msg and "yolov8" in msg and "end2end" in msg


def test_an_unknown_layout_argument_is_a_model_error(tmp_path: Path) -> None:
    path = const_model(tmp_path / "e.onnx", end2end_output())
    with pytest.raises(ModelError, match=r"layout 'yolov99' is not one of auto, yolov5, yolov8, yolox, end2end"):
        OnnxDetector(path, layout="yolov99")


# ------------------------------------------------------------------ settings


def test_detector_spec_layout_reaches_the_detector(tmp_path: Path) -> None:
    path = const_model(tmp_path / "x.onnx", yolox_raw_output())
    assert DetectorSpec().layout == "auto"
    spec = DetectorSpec(kind="onnx", model=str(path), layout="yolox", windows=[])
    det = build_detector(spec, seed=0)
    assert isinstance(det, OnnxDetector) and det.layout == "yolox"
    assert build_detector(spec.model_copy(update={"layout": "auto"}), seed=0).layout == "v5"
    with pytest.raises(ValidationError, match="layout"):
        DetectorSpec(layout="yolov4")
