"""The preprocessing chain (``perception.preprocess``): operators on real rendered frames, gate, registry, hooks."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import lookahead.perception.preprocess as pp
from lookahead.perception.preprocess import (
    GateConfig,
    LowContrastGate,
    Op,
    OpParams,
    PreprocessChain,
    PreprocessConfig,
    cuda_available,
    gamma_lut,
    grey_span,
    make_op,
    register,
    registered_ops,
)
from lookahead.sim.scenario import DetectorSpec, ScenarioError, load_scenario, parse_scenario

FULL = {
    "chain": [{"op": "clahe", "clip_limit": 2.0, "tile": 8}, {"op": "median", "ksize": 3}, {"op": "gamma", "gamma": 0.8}],
    "gate": {"span_above": 100, "percentiles": [1, 99]},
    "device": "cpu",
}


def haze(rgb: np.ndarray, beta: float, airlight=(205, 208, 212), horizon: float = 0.48) -> np.ndarray:
    """Atmospheric scattering I = J t + A (1 - t), t = exp(-beta d), d a horizon depth proxy in [0.3, 1]."""
    h = rgb.shape[0]
    y = np.arange(h, dtype=np.float64)[:, None]
    yh = horizon * h
    d = np.where(y > yh + 1, (h - yh) / np.maximum(y - yh, 1.0), 1e9)  # ~1 / (y - y_horizon), far above it
    d = 0.3 + 0.7 * np.clip(np.log1p(d) / np.log1p(30.0), 0, 1)
    t = np.exp(-beta * d)[..., None]
    out = rgb * t + np.asarray(airlight, np.float64) * (1 - t)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def grey(rgb: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float64)


def local_contrast(rgb: np.ndarray) -> float:
    return float(np.abs(cv2.Laplacian(grey(rgb), cv2.CV_64F)).mean())


@pytest.fixture(scope="module")
def rendered():
    """A short rendered 320x180 run of a shipped scenario with the full chain (no gate) in the loop."""
    from lookahead.sim.records import RecordCollector
    from lookahead.sim.runner import Runner

    sc = load_scenario("scenarios/ped_crossing_nearside.yaml")
    pre = PreprocessConfig.model_validate({"chain": FULL["chain"], "device": "cpu"})
    sc = sc.model_copy(update={
        "duration": 0.35,
        # EGL's shading, as the shipped scenarios render at 640x360 (auto may pick TinyRenderer at this size)
        "camera": sc.camera.model_copy(update={"width": 320, "height": 180, "renderer": "egl"}),
        "perception": sc.perception.model_copy(
            update={"preprocess": pre, "detector": DetectorSpec(kind="gt")}  # no model file needed
        ),
    })
    sink = RecordCollector()
    runner = Runner(sc, sinks=[sink])
    runner.run()
    return runner, sink.records


@pytest.fixture(scope="module")
def frame(rendered) -> np.ndarray:
    return rendered[1][-1].frame.image


# --------------------------------------------------------------------------- operators


def test_clahe_raises_contrast_of_hazy_frame_and_keeps_hue(frame):
    hazy = haze(frame, beta=1.0)
    out = make_op("clahe", clip_limit=2.0, tile=8)(hazy)
    assert local_contrast(out) > 1.5 * local_contrast(hazy)
    assert grey_span(out) >= grey_span(hazy) + 8
    assert grey(out).std() > grey(hazy).std()
    h0 = cv2.cvtColor(hazy, cv2.COLOR_RGB2HSV_FULL).astype(int)
    h1 = cv2.cvtColor(out, cv2.COLOR_RGB2HSV_FULL).astype(int)
    coloured = (h0[..., 1] > 20) & (h1[..., 1] > 20)
    assert coloured.sum() > 1000
    dhue = np.abs((h1[..., 0] - h0[..., 0] + 128) % 256 - 128) * 360 / 256
    assert np.median(dhue[coloured]) < 5 and np.percentile(dhue[coloured], 90) < 15


@pytest.mark.parametrize("space", ["ycrcb", "lab"])
def test_clahe_spreads_a_compressed_frame(frame, space):
    flat = (frame.astype(np.float64) * 0.2 + 100).astype(np.uint8)  # all grey levels within ~50
    out = make_op("clahe", clip_limit=3.0, tile=4, space=space)(flat)
    assert grey(out).std() > 1.5 * grey(flat).std()
    assert grey_span(out) > 1.5 * grey_span(flat)


def test_median_removes_rain_streaks_and_keeps_edges():
    clean = np.full((120, 160, 3), 70, np.uint8)
    clean[:, 80:] = (170, 160, 150)  # one vertical step edge
    rainy = clean.copy()
    rng = np.random.default_rng(3)
    mask = np.zeros(clean.shape[:2], np.uint8)
    for _ in range(60):  # thin bright slanted streaks
        x, y, n = int(rng.integers(0, 160)), int(rng.integers(0, 120)), int(rng.integers(6, 16))
        cv2.line(mask, (x, y), (x + n // 4, y + n), 255, 1)
    salt = rng.random(clean.shape[:2]) < 0.01
    rainy[(mask > 0) | salt] = 255

    def err(img):
        return float(np.abs(img.astype(int) - clean.astype(int)).mean())

    out = make_op("median", ksize=3)(rainy)
    assert err(out) < 0.25 * err(rainy)
    assert err(out) < 0.5 * err(cv2.GaussianBlur(rainy, (3, 3), 0))
    assert err(out) < 0.5 * err(cv2.blur(rainy, (3, 3)))
    # the step stays a one-pixel step: median of a clean edge is the edge
    np.testing.assert_array_equal(make_op("median", ksize=5)(clean), clean)


@pytest.mark.parametrize("g", [0.4, 0.8, 1.0, 1.7, 2.2])
def test_gamma_matches_formula_on_ramp_exactly(g):
    ramp = np.repeat(np.arange(256, dtype=np.uint8)[None, :, None], 3, axis=2).repeat(4, axis=0)
    expected = np.clip(np.rint(255.0 * (np.arange(256) / 255.0) ** g), 0, 255).astype(np.uint8)
    out = make_op("gamma", gamma=g)(ramp)
    np.testing.assert_array_equal(out, np.broadcast_to(expected[None, :, None], ramp.shape))
    np.testing.assert_array_equal(gamma_lut(g), expected)
    assert gamma_lut(1.0).tolist() == list(range(256))


@pytest.mark.parametrize("shape", [(37, 53, 3), (360, 640, 3)])
def test_dtype_shape_preserved_and_input_untouched(shape):
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, shape, dtype=np.uint8)
    before = img.copy()
    for name, params in [("clahe", {}), ("clahe", {"space": "lab"}), ("median", {"ksize": 5}), ("gamma", {"gamma": 2})]:
        out = make_op(name, **params)(img)
        assert out.dtype == np.uint8 and out.shape == shape, name
    chain = PreprocessChain({"chain": FULL["chain"]})
    out = chain(img)
    assert out.dtype == np.uint8 and out.shape == shape and out is not img
    np.testing.assert_array_equal(img, before)
    with pytest.raises(ValueError, match="RGB uint8"):
        chain(img.astype(np.float32))
    with pytest.raises(ValueError, match="RGB uint8"):
        chain(img[..., 0])


def test_deterministic_and_out_param(frame):
    hazy = haze(frame, 2.0)
    a, b = PreprocessChain(FULL), PreprocessChain(FULL)
    first = a(hazy)
    np.testing.assert_array_equal(first, b(hazy))
    second = a(hazy)
    np.testing.assert_array_equal(first, second)
    assert first is not second  # results are fresh arrays callers may keep
    out = np.zeros_like(hazy)
    assert a(hazy, out=out) is out
    np.testing.assert_array_equal(out, first)
    # a chain of one op equals the op alone; four ops ping-pong through reused buffers correctly
    np.testing.assert_array_equal(PreprocessChain([{"op": "gamma", "gamma": 0.5}])(hazy), make_op("gamma", gamma=0.5)(hazy))
    four = PreprocessChain([{"op": "gamma", "gamma": 0.5}, {"op": "median"}, {"op": "gamma", "gamma": 2.0}, {"op": "median"}])
    ref = hazy
    for op in four.ops:
        ref = op(ref)
    np.testing.assert_array_equal(four(hazy), ref)


# --------------------------------------------------------------------------- gate


def test_gate_skips_contrasty_frame_and_runs_on_hazy(frame):
    chain = PreprocessChain(FULL)
    assert grey_span(frame) > 130  # a clear rendered frame
    out = chain(frame)
    assert chain.last_skipped and not chain.last_ran and out is frame
    assert chain.last_span > 100 and "gate" in chain.last_ms
    hazy = haze(frame, 2.5)
    out = chain(hazy)
    assert chain.last_ran and not chain.last_skipped and chain.last_span <= 100
    assert not np.array_equal(out, hazy)
    assert set(chain.last_ms) == {"gate", "0.clahe", "1.median", "2.gamma"}
    assert chain.stats() == {"frames": 2, "ran": 1, "skipped": 1}
    # without a gate the chain always runs
    nogate = PreprocessChain({"chain": FULL["chain"]})
    nogate(frame)
    assert nogate.last_ran and nogate.last_span is None


def test_gate_span_is_a_robust_percentile_span():
    rng = np.random.default_rng(1)
    img = rng.integers(90, 150, (90, 160, 3), dtype=np.uint8)
    g = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    lo, hi = np.percentile(g, [1, 99], method="inverted_cdf")
    assert grey_span(img, (1, 99), stride=1) == hi - lo
    assert grey_span(img, (0, 100), stride=1) == int(g.max()) - int(g.min())  # the seed's max - min
    hot = img.copy()
    hot[::30, ::40] = (255, 255, 255)  # a few specular pixels / hot pixels
    hot[5, ::50] = (0, 0, 0)
    assert grey_span(hot, (0, 100), stride=1) == 255  # max - min is fooled
    assert abs(grey_span(hot, (1, 99), stride=1) - (hi - lo)) <= 2  # the percentile span is not
    gate = LowContrastGate(GateConfig(span_above=hi - lo - 1, stride=1))
    assert gate.skip(img)[0] and not LowContrastGate(GateConfig(span_above=hi - lo, stride=1)).skip(img)[0]


# --------------------------------------------------------------------------- config and registry


@pytest.mark.parametrize(
    ("config", "expected"),
    [
        ([{"op": "dehaze"}], "preprocess.chain[0]: unknown preprocess op 'dehaze' (known: clahe, gamma, median)"),
        ([{"op": "gamma"}, {"op": "median", "ksize": 4}], "preprocess.chain[1]: median: ksize: must be odd, got 4"),
        ([{"op": "median", "kernel": 3}], "preprocess.chain[0]: median: kernel: unknown parameter (known: ksize)"),
        ([{"op": "clahe", "tile": 8.5}], "preprocess.chain[0]: clahe: tile: "),
        ([{"op": "gamma", "gamma": -1}], "preprocess.chain[0]: gamma: gamma: Input should be greater than 0, got -1"),
        ([{"ksize": 3}], "preprocess.chain[0]: a chain step needs 'op'"),
        ({"gate": {"percentiles": [99, 1]}}, "preprocess.gate.percentiles: need 0 <= low < high <= 100"),
        ({"gate": {"span_above": 300}}, "preprocess.gate.span_above: "),
        ({"device": "gpu"}, "preprocess.device: "),
    ],
)
def test_config_errors_are_one_clear_line(config, expected):
    with pytest.raises(ValueError) as e:
        PreprocessChain(config)
    msg = str(e.value)
    assert msg.startswith(expected) and "\n" not in msg


def test_make_op_errors_name_op_and_field():
    with pytest.raises(ValueError, match=r"^median: ksize: must be odd, got 6$"):
        make_op("median", ksize=6)
    with pytest.raises(ValueError, match=r"^unknown preprocess op 'blur'"):
        make_op("blur")


def test_register_custom_op(monkeypatch):
    monkeypatch.setattr(pp, "_REGISTRY", dict(pp._REGISTRY))  # keep the shipped registry (and schema) clean

    class InvertParams(OpParams):
        amount: int = 255

    @register("invert", InvertParams)
    class Invert(Op):
        def __init__(self, params: InvertParams) -> None:
            self.amount = params.amount

        def apply(self, src, dst):
            np.subtract(self.amount, src, out=dst)

    assert "invert" in registered_ops()
    img = np.full((4, 5, 3), 10, np.uint8)
    assert PreprocessChain([{"op": "invert"}])(img).max() == 245
    with pytest.raises(ValueError, match="already has a cpu implementation"):
        register("invert", InvertParams)(Invert)
    with pytest.raises(ValueError, match="registered with params InvertParams"):
        register("invert", pp.GammaParams, device="cuda")(Invert)
    with pytest.raises(ValueError, match="invert: amount: "):
        make_op("invert", amount="lots")


def test_default_is_empty_and_free():
    chain = PreprocessChain()
    img = np.zeros((8, 8, 3), np.uint8)
    assert not chain.enabled and chain(img) is img and chain(None) is None
    assert chain.stats()["frames"] == 0
    assert PreprocessConfig().model_dump() == {"chain": [], "gate": None, "device": "auto"}


def test_cuda_detection_is_guarded(monkeypatch):
    assert isinstance(cuda_available(), bool)
    monkeypatch.delattr(cv2, "cuda", raising=False)
    assert cuda_available() is False
    assert PreprocessChain(FULL | {"device": "auto"}).device == "cpu"
    with pytest.raises(ValueError, match="^preprocess.device: cuda requested"):
        PreprocessChain(FULL | {"device": "cuda"})


# --------------------------------------------------------------------------- scenario and runner


SCENARIO = """\
name: pre
perception:
  preprocess:
    gate: {span_above: 90, percentiles: [1, 99]}
    chain:
      - {op: clahe, clip_limit: 2.0, tile: 8}
      - {op: median, ksize: 3}
      - {op: gamma, gamma: 0.8}
"""


def test_scenario_with_preprocess_validates_and_round_trips():
    sc = parse_scenario(SCENARIO)
    pre = sc.perception.preprocess
    assert [s.op for s in pre.chain] == ["clahe", "median", "gamma"] and pre.gate.span_above == 90
    dumped = sc.model_dump(mode="json")["perception"]["preprocess"]
    assert dumped["chain"][1] == {"op": "median", "ksize": 3}
    assert PreprocessConfig.model_validate(dumped) == pre
    assert parse_scenario("name: plain").perception.preprocess.chain == []


def test_scenario_bad_op_is_a_scenario_error_naming_the_field():
    with pytest.raises(ScenarioError) as e:
        parse_scenario(SCENARIO.replace("op: median, ksize: 3", "op: derain"), "pre.yaml")
    msg = str(e.value)
    assert msg.startswith("pre.yaml:7: perception.preprocess.chain[1]: unknown preprocess op 'derain'")
    assert "\n" not in msg
    with pytest.raises(ScenarioError, match=r"perception\.preprocess\.chain\[2\]: gamma: gamma: "):
        parse_scenario(SCENARIO.replace("gamma: 0.8", "gamma: 0"), "pre.yaml")


def test_runner_without_rendering_passes_none_through():
    from lookahead.sim.records import RecordCollector
    from lookahead.sim.runner import STAGES, Runner

    sc = parse_scenario(SCENARIO + "duration: 0.3\n")
    sink = RecordCollector()
    runner = Runner(sc, sinks=[sink], render=False)
    assert runner.perception.preprocess.enabled
    runner.run()
    assert "preprocess" in STAGES and sink.records
    assert all("preprocess" in r.timings and r.frame.image is None for r in sink.records)
    assert runner.perception.preprocess.stats()["frames"] == 0


def test_runner_runs_the_stage_on_rendered_frames(rendered):
    runner, records = rendered
    chain = runner.perception.preprocess
    assert chain.stats() == {"frames": len(records), "ran": len(records), "skipped": 0}
    assert all(r.timings["preprocess"] > 0 for r in records)
    img = records[-1].frame.image
    assert img.shape == (180, 320, 3) and img.dtype == np.uint8
    assert not np.array_equal(chain(img), img)  # frame.image is the camera's image, not the preprocessed one
