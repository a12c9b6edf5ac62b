"""COCO splits as the detector tools read them: a broken annotations file is one line naming it
(and the field), for ``eval-detector`` and ``train-detector`` alike."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.perception.detections import CLASSES
from lookahead.tools.detector.data import DatasetError, load_split

ROOT = Path(__file__).resolve().parents[3]
MODEL = ROOT / "models" / "lookahead-det.onnx"

IMAGE = {"id": 1, "file_name": "images/0.png", "height": 36, "width": 64}
ANNOTATION = {"id": 1, "image_id": 1, "bbox": [4, 5, 10, 20], "category_id": 5, "occlusion": 0.25,
              "attributes": {"range_m": 12.0}}

BROKEN = [  # annotations.json content (bytes), what the one line must say
    (b"not json at all", "not a COCO annotations file (not JSON"),
    (b"\x00\xff\xfe\x80binary", "not a COCO annotations file (not JSON"),
    (b"[1, 2, 3]", "a JSON object expected, got list"),
    (json.dumps({"annotations": []}).encode(), "no 'images' key"),
    (json.dumps({"images": []}).encode(), "no 'annotations' key"),
    (json.dumps({"images": {}, "annotations": []}).encode(), "images: a list expected, got dict"),
    (json.dumps({"images": [5], "annotations": []}).encode(), "images[0]: a JSON object expected, got int"),
    (json.dumps({"images": [{"id": 1}], "annotations": []}).encode(), "images[0]: no 'file_name' key"),
    (json.dumps({"images": [{**IMAGE, "width": "wide"}], "annotations": []}).encode(), "images[0].width"),
    (json.dumps({"images": [IMAGE], "annotations": [{"image_id": 1}]}).encode(), "annotations[0]: no 'category_id' key"),
    (json.dumps({"images": [IMAGE], "annotations": [{**ANNOTATION, "bbox": [1, 2]}]}).encode(), "annotations[0].bbox"),
    (json.dumps({"images": [IMAGE], "annotations": [{**ANNOTATION, "attributes": {}}]}).encode(),
     "annotations[0].attributes: a mapping with range_m"),
    (json.dumps({"images": [IMAGE], "annotations": [{**ANNOTATION, "category_id": 10**12}]}).encode(),
     f"annotations[0].category_id: a class id 1..{len(CLASSES)} expected"),
    (b'{"images": [], "annotations": [{"image_id": 1, "category_id": 1, "bbox": [0, 0, NaN, 1], '
     b'"occlusion": 0, "attributes": {"range_m": 1}}]}', "annotations[0].bbox"),
]


def _split(root: Path, content: bytes) -> Path:
    (root / "images").mkdir(parents=True)
    (root / "annotations.json").write_bytes(content)
    return root


@pytest.mark.parametrize(("content", "needle"), BROKEN)
def test_a_broken_annotations_file_is_a_dataset_error_naming_it(tmp_path, content, needle):
    split = _split(tmp_path / "s", content)
    with pytest.raises(DatasetError) as err:
        load_split(split)
    msg = str(err.value)
    assert msg.startswith(f"{split / 'annotations.json'}: ") and needle in msg and "\n" not in msg, msg


def _one_line(capsys, code: int, *needles: str) -> None:
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.mark.skipif(not MODEL.is_file(), reason="no shipped model")
@pytest.mark.parametrize(("content", "needle"), [BROKEN[0], BROKEN[4], BROKEN[9]])
def test_eval_detector_on_a_broken_split_is_one_line_and_exit_2(tmp_path, capsys, lookahead, content, needle):
    split = _split(tmp_path / "s", content)
    code = lookahead("eval-detector", MODEL, split)
    _one_line(capsys, code, str(split / "annotations.json"), needle)


@pytest.mark.parametrize("which", ["train", "val"])
def test_train_detector_on_a_broken_split_is_one_line_and_exit_2(tmp_path, capsys, lookahead, which):
    pytest.importorskip("torch")
    data = tmp_path / "data"
    good = {"images": [], "annotations": []}
    _split(data / "train", json.dumps(good).encode() if which == "val" else b"{broken")
    _split(data / "val", b'{"images": []}' if which == "val" else json.dumps(good).encode())
    code = lookahead("train-detector", data, "--out", tmp_path / "m.onnx", "--epochs", 1)
    needle = "not JSON" if which == "train" else "no 'annotations' key"
    _one_line(capsys, code, str(data / which / "annotations.json"), needle)
    assert not (tmp_path / "m.onnx").exists()
