"""Detector plug-ins (``perception.plugins``): ``module:factory``, ``file.py:factory`` and entry
points resolved, options passed, the result checked; every way a plug-in can be broken is one
``PluginError`` line naming it."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from lookahead.intent.stack import build_detector
from lookahead.perception.config import DetectorSpec, PerceptionSpec
from lookahead.perception.detections import CLASSES, Detections
from lookahead.perception.detectors.base import Detector, DetectorTruth
from lookahead.perception.plugins import (
    DETECTOR_GROUP,
    PluginDetector,
    PluginError,
    check_detections,
    installed,
    load_detector,
    load_plugin,
    resolve,
)
from lookahead.sim.scenario import ScenarioError, parse_scenario, with_detector

GOOD = '''
import numpy as np
from lookahead.perception.detections import Detections


class Boxes:
    name = "boxes"

    def __init__(self, n=1, score=0.9):
        self.n, self.score, self.calls = n, score, 0

    def detect(self, image, truth=None):
        self.calls += 1
        self.truth = truth
        xyxy = np.tile([10.0, 20.0, 30.0, 60.0], (self.n, 1))
        return Detections(xyxy=xyxy, score=np.full(self.n, self.score), class_id=np.zeros(self.n, int))


def make(**options):
    return Boxes(**options)


class ImageOnly:
    def detect(self, image):
        return Detections.empty()


def image_only():
    return ImageOnly()


def broken_factory(**options):
    raise RuntimeError("no GPU here\\nsecond line")


def a_function():
    return lambda image: Detections.empty()


def a_number():
    return 42


class Raises:
    def detect(self, image, truth=None):
        return {}["missing"]


def raises():
    return Raises()


class Returns:
    def __init__(self, what):
        self.what = what

    def detect(self, image, truth=None):
        d = Detections(xyxy=[[0, 0, 10, 10]], score=[0.5], class_id=[0])
        if self.what == "nan":
            d.xyxy[0, 2] = float("nan")
        elif self.what == "shape":
            d.xyxy = np.zeros((1, 5))
        elif self.what == "score":
            d.score = np.array([1.5])
        elif self.what == "class":
            d.class_id = np.array([99])
        elif self.what == "dtype":
            d.class_id = np.array([0.0])
        elif self.what == "list":
            d.score = [0.5]
        elif self.what == "tuple":
            return (d.xyxy, d.score, d.class_id)
        return d


def returns(what):
    return Returns(what)

not_callable = 3
'''


@pytest.fixture
def plugmod(tmp_path, monkeypatch) -> str:
    """A plug-in module ``plugmod`` on ``sys.path``; its name."""
    (tmp_path / "plugmod.py").write_text(GOOD)
    (tmp_path / "badimport.py").write_text("import numpy\nraise ImportError('libfoo.so: cannot open')\n")
    (tmp_path / "needsdep.py").write_text("import not_installed_dependency_xyz\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return "plugmod"


def _error(fn, *args, **kwargs) -> str:
    with pytest.raises(PluginError) as info:
        fn(*args, **kwargs)
    msg = str(info.value)
    assert "\n" not in msg and msg, msg
    return msg


def test_module_factory_with_options(plugmod):
    det = load_detector(f"{plugmod}:make", {"n": 3, "score": 0.7})
    assert isinstance(det, PluginDetector) and isinstance(det, Detector)
    assert det.name == "boxes"
    image = np.zeros((100, 100, 3), np.uint8)
    truth = DetectorTruth(width=100, height=100)
    d = det.detect(image, truth)
    assert len(d) == 3 and np.allclose(d.score, 0.7)
    assert det.inner.truth is truth  # a detect(image, truth) plug-in gets the truth
    only = load_detector(f"{plugmod}:image_only")
    assert len(only.detect(image, truth)) == 0  # detect(image) is called without it
    assert only.name == f"plugin:{plugmod}:image_only"
    assert load_plugin(f"{plugmod}:Boxes", DETECTOR_GROUP, {"n": 2}).n == 2  # a class is a factory too


def test_file_reference(tmp_path):
    f = tmp_path / "my_detector.py"
    f.write_text(GOOD)
    det = load_detector(f"{f}:make")
    assert len(det.detect(np.zeros((8, 8, 3), np.uint8))) == 1
    assert "no such file" in _error(load_detector, f"{tmp_path / 'nope.py'}:make")


@pytest.mark.parametrize(
    ("ref", "options", "expected"),
    [
        ("no_such_module_xyz:make", {}, "no module named 'no_such_module_xyz'"),
        ("badimport:make", {}, "importing badimport raised ImportError: libfoo.so: cannot open"),
        ("needsdep:make", {}, "importing needsdep raised ModuleNotFoundError"),
        ("plugmod:nope", {}, "module plugmod has no attribute 'nope'"),
        ("plugmod:Boxes.nope", {}, "has no attribute 'Boxes.nope'"),
        ("plugmod:not_callable", {}, "int object is not callable"),
        ("plugmod:broken_factory", {}, "its factory raised RuntimeError: no GPU here second line"),
        ("plugmod:make", {"colour": "red"}, "its factory raised TypeError"),
        ("plugmod:a_function", {}, "returned a callable without detect, expected an object with detect"),
        ("plugmod:a_number", {}, "returned an object of type int, expected an object with detect"),
        (":make", {}, "expected 'module:factory'"),
        ("plugmod:", {}, "expected 'module:factory'"),
        ("", {}, "expected 'module:factory' or an entry-point name"),
        ("no-such-plugin", {}, "no entry point of that name in group lookahead.detectors"),
    ],
)
def test_broken_plugins_are_one_line_errors(plugmod, ref, options, expected):
    msg = _error(load_detector, ref, options)
    assert expected in msg
    if ref:
        assert repr(ref) in msg  # names the plug-in


def test_exception_inside_detect_is_one_line(plugmod):
    det = load_detector(f"{plugmod}:raises")
    msg = _error(det.detect, np.zeros((4, 4, 3), np.uint8))
    assert msg == f"detector plug-in '{plugmod}:raises': detect raised KeyError: 'missing'"
    assert isinstance(_exc(det).__cause__, KeyError)  # the plug-in's own traceback stays reachable


def _exc(det: PluginDetector) -> PluginError:
    try:
        det.detect(None)
    except PluginError as e:
        return e
    raise AssertionError("no error")


@pytest.mark.parametrize(
    ("what", "expected"),
    [
        ("nan", "NaN or infinite"),
        ("shape", "xyxy of shape (1, 5), expected (N, 4)"),
        ("score", "scores outside [0, 1]"),
        ("class", f"class ids outside 0..{len(CLASSES) - 1}"),
        ("dtype", "class_id of dtype float64, expected integer"),
        ("list", "Detections.score of type list, expected a numpy array"),
        ("tuple", "returned tuple, expected perception.detections.Detections"),
    ],
)
def test_malformed_detections_mid_run_are_one_line(plugmod, what, expected):
    det = load_detector(f"{plugmod}:returns", {"what": what})
    msg = _error(det.detect, np.zeros((4, 4, 3), np.uint8))
    assert msg.startswith(f"detector plug-in '{plugmod}:returns': detect returned")
    assert expected in msg


def test_check_detections_passes_good_and_empty():
    good = Detections(xyxy=[[0, 0, 5, 5]], score=[1.0], class_id=[7])
    assert check_detections(good, "x") is good
    assert len(check_detections(Detections.empty(), "x")) == 0


def test_entry_points_found_by_name(plugmod, tmp_path, monkeypatch):
    """A distribution's entry point (here a bare dist-info on sys.path, as pip leaves one)."""
    site = tmp_path / "site"
    info = site / "fake_plugin-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fake-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        f"[{DETECTOR_GROUP}]\nfake-boxes = {plugmod}:make\nfake-broken = {plugmod}:missing\n"
    )
    monkeypatch.syspath_prepend(str(site))
    assert {"fake-boxes", "fake-broken"} <= set(installed(DETECTOR_GROUP))
    assert resolve("fake-boxes", DETECTOR_GROUP).__name__ == "make"
    det = load_detector("fake-boxes", {"n": 2})
    assert len(det.detect(np.zeros((8, 8, 3), np.uint8))) == 2
    msg = _error(load_detector, "fake-broken")
    assert "fake-broken" in msg and "loading raised AttributeError" in msg
    assert "installed: " in _error(load_detector, "fake-nothing") and "fake-boxes" in _error(load_detector, "x-y")
    # the CLI's --detector takes the installed name
    sc = with_detector(parse_scenario("name: x\n"), "fake-boxes")
    assert (sc.perception.detector.kind, sc.perception.detector.plugin) == ("plugin", "fake-boxes")


def test_detector_spec_kind_plugin_and_build_detector(plugmod):
    spec = PerceptionSpec.model_validate(
        {"detector": {"kind": "plugin", "plugin": f"{plugmod}:make", "options": {"n": 2}}}
    ).detector
    det = build_detector(spec, seed=0, render=False)  # a plug-in may run without images
    assert len(det.detect(None, DetectorTruth(width=10, height=10))) == 2
    with pytest.raises(ValueError, match="kind plugin needs plugin"):
        DetectorSpec(kind="plugin")
    with pytest.raises(ValueError, match="plugin is for kind plugin"):
        DetectorSpec(kind="gt", plugin=f"{plugmod}:make")
    with pytest.raises(ValueError, match="options are for kinds hog and plugin"):
        DetectorSpec(kind="onnx", options={"n": 1})
    with pytest.raises(PluginError, match="its factory raised"):
        build_detector(DetectorSpec(kind="plugin", plugin=f"{plugmod}:broken_factory"), seed=0)


def test_scenario_yaml_and_with_detector(plugmod):
    sc = parse_scenario(textwrap.dedent(f"""\
        name: x
        perception: {{detector: {{kind: plugin, plugin: "{plugmod}:make", options: {{n: 2}}}}}}
    """))
    assert sc.perception.detector.options == {"n": 2}
    same = with_detector(sc, f"{plugmod}:make")
    assert same.perception.detector.options == {"n": 2}  # same plug-in: its options stay
    other = with_detector(sc, f"{plugmod}:image_only")
    assert other.perception.detector.plugin == f"{plugmod}:image_only" and other.perception.detector.options == {}
    gt = with_detector(sc, "gt")
    assert (gt.perception.detector.kind, gt.perception.detector.plugin, gt.perception.detector.options) == ("gt", None, {})
    hog = with_detector(sc, "hog")
    assert hog.perception.detector.kind == "hog"
    with pytest.raises(ScenarioError, match="--detector: expected gt, onnx, hog, auto, a plug-in as module:factory"):
        with_detector(sc, "yolo")
    with pytest.raises(ScenarioError, match="--model is the onnx detector's model"):
        with_detector(sc, f"{plugmod}:make", Path("m.onnx"))
    with pytest.raises(ScenarioError, match="perception.detector"):
        parse_scenario("name: x\nperception: {detector: {kind: plugin}}\n")
