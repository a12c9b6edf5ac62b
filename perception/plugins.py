"""Plug-ins: your own detector (or, through ``intent.plugins``, your own perception stack).

A plug-in is a *factory*, a callable that takes keyword options and returns the plug-in object. It is
named by a reference, either

- ``"package.module:factory"`` (``factory`` may be a dotted attribute path, e.g. ``Class.create``;
  the module is imported from ``sys.path``), or ``"path/to/file.py:factory"`` (loaded from the file), or
- the name of an entry point in a group (``lookahead.detectors`` for detectors,
  ``lookahead.stacks`` for stacks) that an installed distribution declares, e.g. in its
  pyproject.toml::

      [project.entry-points."lookahead.detectors"]
      blobs = "my_package.detector:make_detector"

``load_plugin(ref, group, options)`` resolves the reference, calls ``factory(**options)`` and
returns what it made; ``load_detector`` also checks that it is a detector and wraps it in
``PluginDetector``, which checks every ``Detections`` it returns. Whatever goes wrong (the module
does not import, the factory is missing or raises, it returns the wrong thing, ``detect`` raises or
returns malformed detections mid-run) is a ``PluginError`` whose ``str()`` is one line naming the
plug-in and the problem. See docs/plugins.md.

A detector plug-in's object needs ``detect(image)`` or ``detect(image, truth)`` returning
``perception.detections.Detections`` (boxes xyxy in image pixels, scores in [0, 1], class ids into
``perception.detections.CLASSES``); ``image`` is the RGB uint8 (H, W, 3) camera image (None when
the run does not render), ``truth`` a ``DetectorTruth`` in the simulator (None on real video).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import sys
from collections.abc import Callable, Mapping
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

import numpy as np

from lookahead.perception.config import DetectorSpec, SettingsError
from lookahead.perception.detections import CLASSES, Detections
from lookahead.perception.detectors.base import DetectorTruth

#: Entry-point group of detector plug-ins (factory(**options) -> object with ``detect``).
DETECTOR_GROUP = "lookahead.detectors"
#: Entry-point group of perception-stack plug-ins (``intent.plugins``).
STACK_GROUP = "lookahead.stacks"

_MAX_MESSAGE = 300  # characters of a plug-in's own exception message kept in a PluginError


class PluginError(Exception):
    """A plug-in that cannot be loaded or that failed; ``str()`` is one line naming it and the problem."""

    def __init__(self, message: str) -> None:
        super().__init__(one_line(message, 2 * _MAX_MESSAGE))


def one_line(text: str, limit: int = _MAX_MESSAGE) -> str:
    """``text`` with every run of whitespace (newlines too) as one space, cut to ``limit`` characters."""
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


def describe_exception(e: BaseException) -> str:
    """``Type: message`` of ``e`` on one line (the message cut short)."""
    msg = one_line(str(e))
    return f"{type(e).__name__}: {msg}" if msg else type(e).__name__


def call_plugin(where: str, fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)``, a plug-in's method; any exception it raises becomes one ``PluginError`` line
    ``<where> raised <type>: <message>`` (the exception kept as its cause)."""
    try:
        return fn(*args)
    except PluginError:
        raise
    except Exception as e:
        raise PluginError(f"{where} raised {describe_exception(e)}") from e


def is_reference(ref: str) -> bool:
    """Whether ``ref`` is a ``module:factory`` reference (rather than an entry-point name)."""
    return ":" in ref


def installed(group: str) -> list[str]:
    """Names of the entry points in ``group`` (the installed plug-ins), sorted."""
    return sorted({ep.name for ep in entry_points(group=group)})


def _import_module(module: str, ref: str) -> Any:
    if module.endswith(".py"):  # a file: loaded under a private name, not left in sys.modules on failure
        path = Path(module)
        if not path.is_file():
            raise PluginError(f"plug-in {ref!r}: no such file {module}")
        name = f"lookahead_plugin_{abs(hash(str(path.resolve())))}"
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise PluginError(f"plug-in {ref!r}: cannot load {module} as Python")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        try:
            spec.loader.exec_module(mod)
        except BaseException as e:
            sys.modules.pop(name, None)
            if not isinstance(e, Exception):
                raise
            raise PluginError(f"plug-in {ref!r}: importing {module} raised {describe_exception(e)}") from e
        return mod
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as e:
        if e.name is not None and module.split(".")[0] == e.name.split(".")[0] and module.startswith(e.name):
            raise PluginError(f"plug-in {ref!r}: no module named {e.name!r} (is it installed, or on PYTHONPATH?)") from e
        raise PluginError(f"plug-in {ref!r}: importing {module} raised {describe_exception(e)}") from e
    except Exception as e:
        raise PluginError(f"plug-in {ref!r}: importing {module} raised {describe_exception(e)}") from e


def resolve(ref: str, group: str) -> Callable[..., Any]:
    """The factory ``ref`` names: ``module:attr.path`` imported, or the entry point ``ref`` of ``group`` loaded.

    Raises:
        PluginError: empty or malformed reference, module not importable (or raising on import),
            attribute missing, no such entry point, not callable.
    """
    ref = ref.strip() if isinstance(ref, str) else ref
    if not isinstance(ref, str) or not ref:
        raise PluginError(f"plug-in reference: expected 'module:factory' or an entry-point name, got {ref!r}")
    if is_reference(ref):
        module, _, attr = ref.rpartition(":")
        if not module or not attr:
            raise PluginError(f"plug-in {ref!r}: expected 'module:factory' (both parts)")
        obj: Any = _import_module(module, ref)
        for part in attr.split("."):
            try:
                obj = getattr(obj, part)
            except AttributeError:
                raise PluginError(f"plug-in {ref!r}: module {module} has no attribute {attr!r}") from None
    else:
        found = [ep for ep in entry_points(group=group) if ep.name == ref]
        if not found:
            names = ", ".join(installed(group)) or "none"
            raise PluginError(
                f"plug-in {ref!r}: no entry point of that name in group {group} (installed: {names}); "
                "give 'module:factory' for a module on PYTHONPATH"
            )
        try:
            obj = found[0].load()
        except Exception as e:
            raise PluginError(f"plug-in {ref!r} (entry point {found[0].value}): loading raised {describe_exception(e)}") from e
    if not callable(obj):
        raise PluginError(f"plug-in {ref!r}: {type(obj).__name__} object is not callable (expected a factory)")
    return obj


def load_plugin(ref: str, group: str, options: Mapping[str, Any] | None = None) -> Any:
    """``factory(**options)`` of the plug-in ``ref`` (``resolve``); ``PluginError`` if it raises."""
    factory = resolve(ref, group)
    try:
        return factory(**dict(options or {}))
    except Exception as e:
        raise PluginError(f"plug-in {ref!r}: its factory raised {describe_exception(e)}") from e


def _takes_truth(method: Callable[..., Any]) -> bool:
    """Whether ``method`` (bound) accepts a second positional argument (``truth``)."""
    try:
        params = list(inspect.signature(method).parameters.values())
    except (TypeError, ValueError):
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


def check_detections(dets: Any, where: str, width: int | None = None, height: int | None = None) -> Detections:
    """``dets`` if it is a well-formed ``Detections`` (cheap: a few vector checks), else ``PluginError``.

    Checked: the type; ``xyxy`` a float (N, 4) array; ``score``, ``class_id`` and ``source_id``
    (N,) arrays, ``class_id`` integer; no NaN or infinite box or score; scores in [0, 1];
    class ids into ``CLASSES``. Boxes may reach outside the image (they are clipped downstream).
    """
    if not isinstance(dets, Detections):
        raise PluginError(f"{where} returned {type(dets).__name__}, expected perception.detections.Detections")
    arrays = {"xyxy": dets.xyxy, "score": dets.score, "class_id": dets.class_id, "source_id": dets.source_id}
    for name, a in arrays.items():
        if not isinstance(a, np.ndarray):
            raise PluginError(f"{where} returned Detections.{name} of type {type(a).__name__}, expected a numpy array")
    n = len(dets.xyxy)
    if dets.xyxy.ndim != 2 or dets.xyxy.shape[1:] != (4,):
        raise PluginError(f"{where} returned Detections.xyxy of shape {dets.xyxy.shape}, expected (N, 4)")
    for name in ("score", "class_id", "source_id"):
        if arrays[name].shape != (n,):
            raise PluginError(f"{where} returned Detections.{name} of shape {arrays[name].shape}, expected ({n},)")
    if dets.xyxy.dtype.kind != "f" or dets.score.dtype.kind != "f":
        raise PluginError(f"{where} returned Detections of dtype xyxy {dets.xyxy.dtype}, score {dets.score.dtype}, expected float")
    if dets.class_id.dtype.kind not in "iu" or dets.source_id.dtype.kind not in "iu":
        raise PluginError(f"{where} returned Detections.class_id of dtype {dets.class_id.dtype}, expected integer")
    if n == 0:
        return dets
    if not (np.isfinite(dets.xyxy).all() and np.isfinite(dets.score).all()):
        raise PluginError(f"{where} returned Detections with NaN or infinite boxes or scores")
    if dets.score.min() < 0.0 or dets.score.max() > 1.0:
        raise PluginError(f"{where} returned scores outside [0, 1] (min {dets.score.min():.3g}, max {dets.score.max():.3g})")
    if dets.class_id.min() < 0 or dets.class_id.max() >= len(CLASSES):
        raise PluginError(
            f"{where} returned class ids outside 0..{len(CLASSES) - 1} (perception.detections.CLASSES): "
            f"min {dets.class_id.min()}, max {dets.class_id.max()}"
        )
    return dets


class PluginDetector:
    """A detector plug-in behind the ``Detector`` protocol: ``detect`` passes ``truth`` only when the
    plug-in's ``detect`` takes it, and turns an exception or malformed output into ``PluginError``."""

    def __init__(self, inner: Any, ref: str) -> None:
        detect = getattr(inner, "detect", None)
        if not callable(detect):
            what = "a callable without detect" if callable(inner) else f"an object of type {type(inner).__name__}"
            raise PluginError(
                f"plug-in {ref!r}: its factory returned {what}, expected an object with "
                "detect(image, truth=None) -> Detections"
            )
        self.inner = inner
        self.ref = ref
        self.name = str(getattr(inner, "name", "") or f"plugin:{ref}")
        self._detect = detect
        self._truth = _takes_truth(detect)
        self._where = f"detector plug-in {ref!r}: detect"

    def detect(self, image: np.ndarray | None, truth: DetectorTruth | None = None) -> Detections:
        out = call_plugin(self._where, self._detect, image, *((truth,) if self._truth else ()))
        return check_detections(out, self._where)

    def close(self) -> None:
        """The plug-in's ``close()``, if it has one."""
        close = getattr(self.inner, "close", None)
        if callable(close):
            close()


def load_detector(ref: str, options: Mapping[str, Any] | None = None) -> PluginDetector:
    """The detector plug-in ``ref`` (``module:factory`` or an entry point of ``lookahead.detectors``)
    made with ``options``, checked and wrapped (``PluginDetector``); ``PluginError`` otherwise."""
    return PluginDetector(load_plugin(ref, DETECTOR_GROUP, options), ref)


#: The detector kinds built in (``DetectorSpec.kind``); they win over a plug-in of the same name.
BUILTIN_DETECTORS = ("auto", "gt", "onnx", "hog")


def override_detector(spec: DetectorSpec, kind: str | None, model: str | Path | None = None) -> DetectorSpec:
    """``spec`` with the command line's ``--detector`` / ``--model`` applied (``sim.scenario.with_detector``).

    ``kind``: gt | onnx | hog | auto, or a detector plug-in (``kind: plugin``): ``module:factory``,
    ``file.py:factory`` or an installed plug-in's name (entry-point group ``lookahead.detectors``).
    The options stay when the kind (and plug-in) stays, otherwise they are dropped. ``model``: an
    ONNX file (implies ``onnx``; refused with ``hog`` or a plug-in). ``None`` for both: ``spec``.

    Raises:
        SettingsError: an unknown kind (one line, listing the installed plug-ins), or ``--model``
            with ``hog`` or a plug-in.
    """
    if kind is None and model is None:
        return spec
    update: dict[str, Any] = {}
    if kind is not None:
        kind = kind.strip()
        if kind in BUILTIN_DETECTORS:
            update["kind"], update["plugin"] = kind, None
        else:
            names = installed(DETECTOR_GROUP)
            if not (is_reference(kind) or kind in names):
                have = f"; installed plug-ins: {', '.join(names)}" if names else ""
                raise SettingsError(
                    f"--detector: expected gt, onnx, hog, auto, a plug-in as module:factory or an installed "
                    f"plug-in's name, got {kind!r}{have}"
                )
            update["kind"], update["plugin"] = "plugin", kind
        if (update["kind"], update["plugin"]) != (spec.kind, spec.plugin):
            update["options"] = {}
    if model is not None:
        update["model"] = str(model)
        update.setdefault("kind", "onnx")
        if update["kind"] in ("hog", "plugin"):
            raise SettingsError(f"--model is the onnx detector's model; --detector {kind} takes none")
    return spec.model_copy(update=update)
