"""The malformed-input corpus of ``lookahead`` (issue "hostile input, killed processes and long runs").

Every case is one invocation of the installed command line that a user's mistake (or a hostile
file) makes; the README's promise is that each ends with exit code 2 and ONE line on stderr naming
the file (and line / field where known), no traceback. ``tests/tools/test_malformed_corpus.py``
runs them as real subprocesses (``run_cli``: timeout, peak RSS of the child).

The table is ``CASES``: ``Case(id, argv, what, ...)``. ``argv`` holds placeholders, filled per case
(``Ctx.fill``):

``{f}``        the malformed input: ``file`` (under tests/data/malformed/) or what ``make`` built
``{out}``      a fresh output path in the case's own temporary directory
``{tmp}``      the case's own temporary directory
``{sc}``       a valid 1 s scenario (tests/data/malformed/valid/base.yaml)
``{suite1}``   a valid suite of that one scenario
``{run}``      a valid recorded run directory of it (built once per session)
``{coco}``     a valid one-image COCO split
``{model}``    the shipped ONNX detector
``{gt}``       a valid MOTChallenge gt file
``{under_file}`` a path below a regular file (cannot be created: NotADirectoryError)
``{devnull}``  a path below /dev/null (cannot be created)
``{ds}``       a valid detector dataset (train/ and val/ COCO splits)
``{repo}``     the repository (for its shipped files)
``{corpus}``   tests/data/malformed/

Small corpus files live in git under tests/data/malformed/; big and hostile ones (100 MB files,
20000-level nesting, billion laughs, ONNX models with hostile metadata, broken copies of the run
directory) are generated at test time in the case's temporary directory (``make``).
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

CORPUS = Path(__file__).resolve().parents[1] / "data" / "malformed"
REPO = Path(__file__).resolve().parents[2]
LOOKAHEAD = Path(sys.executable).with_name("lookahead")  # the installed console script
SHIPPED_MODEL = REPO / "models" / "lookahead-det.onnx"
TIMEOUT_S = 10.0
MEMORY_LIMIT_BYTES = 1 << 30  # peak RSS per child
ADDRESS_SPACE_CAP = 8 << 30  # RLIMIT_AS of every child: a bomb cannot take the shared machine down
HUGE_BYTES = 100 * (1 << 20)


# ----------------------------------------------------------------------------------- running


@dataclass
class Result:
    argv: list[str]
    returncode: int | None  # None: killed at the timeout
    stdout: str
    stderr: str
    wall_s: float
    maxrss_bytes: int
    cpu_s: float = 0.0  # user + system of the child (and the children it waited for)
    note: str = ""

    @property
    def timed_out(self) -> bool:
        return self.returncode is None

    @property
    def lines(self) -> list[str]:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]


#: Runs the command as ITS child and writes that child's rusage to the file named in argv[1].
#: Linux hands a child the high-water RSS of the process it was forked from (``ru_maxrss``
#: starts at the forker's RSS at fork time), so a child forked from a large pytest process
#: reads hundreds of MB it never used: the command is forked from this small launcher instead.
LAUNCHER = """
import os, subprocess, sys
p = subprocess.Popen(sys.argv[2:])
_, status, ru = os.wait4(p.pid, 0)
with open(sys.argv[1], "w") as f:
    f.write(f"{ru.ru_maxrss} {ru.ru_utime + ru.ru_stime}")
sys.exit(os.waitstatus_to_exitcode(status) % 256)
"""


def _limit_child() -> None:  # runs in the child between fork and exec
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_CAP, ADDRESS_SPACE_CAP))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def run_cli(args: list[str], cwd: Path, timeout: float = TIMEOUT_S) -> Result:
    """``lookahead *args`` as a child process: its exit code, output, wall time and peak RSS
    (``os.wait4``'s ``ru_maxrss``, which covers the child and the children it waited for).
    Killed (with its process group) at ``timeout``."""
    argv = [str(LOOKAHEAD), *args]
    usage_file = cwd / ".rusage"
    usage_file.unlink(missing_ok=True)
    env = {**os.environ, "COLUMNS": "120", "NO_COLOR": "1", "PYTHONWARNINGS": "ignore::DeprecationWarning"}
    env.pop("FORCE_COLOR", None)
    with open(cwd / ".stdout", "w+b") as out, open(cwd / ".stderr", "w+b") as err:
        t0 = time.monotonic()
        proc = subprocess.Popen([sys.executable, "-I", "-S", "-c", LAUNCHER, str(usage_file), *argv], cwd=cwd, stdin=subprocess.DEVNULL, stdout=out, stderr=err, env=env,
                                start_new_session=True, preexec_fn=_limit_child)
        status, rusage = None, None
        while True:
            pid, st, ru = os.wait4(proc.pid, os.WNOHANG)
            if pid == proc.pid:
                status, rusage = st, ru
                break
            if time.monotonic() - t0 > timeout:
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                _, st, ru = os.wait4(proc.pid, 0)
                rusage = ru
                break
            time.sleep(0.01)
        wall = time.monotonic() - t0
        proc.returncode = os.waitstatus_to_exitcode(status) if status is not None else -9
        try:  # workers the command left behind (its process group)
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        out.seek(0)
        err.seek(0)
        stdout = out.read().decode("utf-8", "replace")
        stderr = err.read().decode("utf-8", "replace")
    try:  # the command's own rusage, as the launcher measured it
        maxrss_kb, cpu_s = usage_file.read_text().split()
        maxrss, cpu = int(maxrss_kb) * 1024, float(cpu_s)
    except (OSError, ValueError):  # killed at the timeout: the launcher's view (command and launcher)
        maxrss, cpu = rusage.ru_maxrss * 1024, rusage.ru_utime + rusage.ru_stime
    return Result(argv=argv, returncode=None if status is None else proc.returncode, stdout=stdout, stderr=stderr,
                  wall_s=wall, maxrss_bytes=maxrss, cpu_s=cpu)


# ----------------------------------------------------------------------------------- context


@dataclass
class Bases:
    """Valid inputs every case may use (built once per session by the test module)."""

    root: Path
    sc: Path
    suite1: Path
    run: Path
    coco: Path
    gt: Path
    huge_yaml: Path  # 100 MB, shared read-only by the huge-file cases
    ds: Path  # a valid detector dataset: train/ and val/, each a copy of ``coco``


@dataclass
class Ctx:
    bases: Bases
    dir: Path  # the case's own directory

    def fill(self, case: Case) -> list[str]:
        f = case.input_path(self)
        afile = self.dir / "afile"
        afile.write_text("a regular file\n")
        values = {
            "f": str(f) if f is not None else "", "out": str(self.dir / "out"), "tmp": str(self.dir),
            "sc": str(self.bases.sc), "suite1": str(self.bases.suite1), "run": str(self.bases.run),
            "coco": str(self.bases.coco), "model": str(SHIPPED_MODEL), "gt": str(self.bases.gt),
            "under_file": str(afile / "out"), "devnull": "/dev/null/out", "corpus": str(CORPUS),
            "repo": str(REPO), "ds": str(self.bases.ds),
        }
        return [a.format(**values) for a in case.argv]


@dataclass
class Case:
    id: str
    argv: list[str]
    what: str
    file: str | None = None  # under tests/data/malformed/
    make: Callable[[Ctx], Path] | None = None  # builds the input in ctx.dir
    names: str | None = None  # what stderr must name; default: the input's basename
    bomb: bool = False  # also in the strict (fast, small) test
    _made: dict = field(default_factory=dict, repr=False, compare=False)

    def input_path(self, ctx: Ctx) -> Path | None:
        if self.file is not None:
            return CORPUS / self.file
        if self.make is not None:
            key = str(ctx.dir)
            if key not in self._made:
                self._made[key] = self.make(ctx)
            return self._made[key]
        return None

    def expected_name(self, ctx: Ctx) -> str:
        if self.names is not None:
            return self.names
        p = self.input_path(ctx)
        assert p is not None, f"{self.id}: give names= for a case without an input file"
        return p.name


# ----------------------------------------------------------------------------------- generators


def laughs(levels: int = 9, width: int = 10) -> tuple[str, str]:
    """(anchor definitions, the alias of the top one): ``width ** levels`` leaves from ~1 KB."""
    lines = [f"  l0: &l0 [{', '.join(['lol'] * width)}]"]
    for i in range(1, levels):
        lines.append(f"  l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]")
    return "\n".join(lines) + "\n", f"*l{levels - 1}"


def _write(ctx: Ctx, name: str, data: str | bytes) -> Path:
    p = ctx.dir / name
    p.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode("utf-8")
    p.write_bytes(data)
    return p


def bomb_scenario(ctx: Ctx) -> Path:
    defs, top = laughs()
    return _write(ctx, "laughs_scenario.yaml",
                  f"name: bomb\nx-laughs:\n{defs}description: x\nintent: {{lol: {top}}}\nego: {{profile: {top}}}\n")


def bomb_suite(ctx: Ctx) -> Path:
    defs, top = laughs()
    return _write(ctx, "laughs_suite.yaml", f"name: bomb\nx-laughs:\n{defs}scenarios: {top}\n")


def bomb_sweep(ctx: Ctx) -> Path:
    defs, top = laughs()
    return _write(ctx, "laughs_sweep.yaml",
                  f"name: bomb\nx-laughs:\n{defs}scenario: {ctx.bases.sc}\n"
                  f"grid: {{description: [{top}]}}\nset: {{'actors[target].subtype': {top}}}\n")


def bomb_replay(ctx: Ctx) -> Path:
    defs, top = laughs()
    return _write(ctx, "laughs_replay.yaml", f"x-laughs:\n{defs}tracker: {top}\nintent: {{lol: {top}}}\n")


def deep(kind: str, head: str) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        n = 20000
        nest = "[" * n + "]" * n if kind == "flow_seq" else "{a: " * n + "1" + "}" * n
        return _write(ctx, f"deep_{kind}.yaml", head + nest + "\n")
    make.__name__ = f"deep_{kind}"
    return make


def deep_block(ctx: Ctx) -> Path:  # block style: 1500 indentation levels (1.1 MB; 20000 would be 200 MB)
    lines = ["name: deep", "intent:"] + [" " * i + "a:" for i in range(1, 1501)]
    return _write(ctx, "deep_block.yaml", "\n".join(lines) + " 1\n")


def huge_yaml(ctx: Ctx) -> Path:
    return ctx.bases.huge_yaml


def huge_line_det(ctx: Ctx) -> Path:
    p = ctx.dir / "huge_line_det.txt"
    with p.open("wb") as fh:
        fh.write(b"1,1,")
        chunk = b"9" * (1 << 20)
        for _ in range(100):
            fh.write(chunk)
        fh.write(b",10,20,20,1,-1,-1,-1\n")
    return p


def sparse_zeros(name: str) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        p = ctx.dir / name
        with p.open("wb") as fh:
            fh.truncate(HUGE_BYTES)
        return p
    make.__name__ = f"sparse_{name}"
    return make


def copy_corpus(rel: str, name: str | None = None) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        return Path(shutil.copy(CORPUS / rel, ctx.dir / (name or Path(rel).name)))
    return make


def a_directory(ctx: Ctx) -> Path:
    p = ctx.dir / "a_directory.yaml"
    p.mkdir()
    return p


def broken_symlink(ctx: Ctx) -> Path:
    p = ctx.dir / "dangling.yaml"
    p.symlink_to(ctx.dir / "nowhere.yaml")
    return p


def fifo(ctx: Ctx) -> Path:
    p = ctx.dir / "a_fifo.yaml"
    os.mkfifo(p)
    return p


def missing(name: str) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        return ctx.dir / name
    return make


def hostile_onnx(imgsz: str, name: str) -> Callable[[Ctx], Path]:
    """The shipped model with its ``imgsz`` metadata replaced (dynamic input: the metadata decides
    the input size)."""

    def make(ctx: Ctx) -> Path:
        import onnx

        m = onnx.load(str(SHIPPED_MODEL))
        for p in m.metadata_props:
            if p.key == "imgsz":
                p.value = imgsz
        p = ctx.dir / name
        onnx.save(m, str(p))
        return p
    make.__name__ = f"hostile_onnx_{name}"
    return make


def onnx_rank2_input(ctx: Ctx) -> Path:
    """A loadable ONNX model whose input is not [1, 3, H, W]: x -> Identity -> y, shape [N, 4]."""
    import onnx
    from onnx import TensorProto, helper

    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, ["N", 4])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, ["N", 4])
    graph = helper.make_graph([helper.make_node("Identity", ["x"], ["y"])], "rank2", [x], [y])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    p = ctx.dir / "rank2.onnx"
    onnx.save(model, str(p))
    return p


def truncated_onnx(ctx: Ctx) -> Path:
    data = SHIPPED_MODEL.read_bytes()
    return _write(ctx, "truncated.onnx", data[: len(data) // 3])


# --- copies of the valid run / suite / COCO split with one thing broken -----------------------


def run_copy(ctx: Ctx, name: str = "run") -> Path:
    dst = ctx.dir / name
    shutil.copytree(ctx.bases.run, dst)
    return dst


def broken_run(fname: str, content: str | bytes | Callable[[str], str], label: str) -> Callable[[Ctx], Path]:
    """A copy of the valid run whose ``fname`` is replaced (``content``: text, bytes, or a function
    of the old text). The case names ``fname``'s basename by default."""

    def make(ctx: Ctx) -> Path:
        d = run_copy(ctx, f"run_{label}")
        p = d / fname
        if callable(content):
            p.write_text(content(p.read_text()))
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)
        return d
    make.__name__ = f"broken_run_{label}"
    return make


def run_without(fname: str) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        d = run_copy(ctx, f"run_no_{fname.replace('.', '_')}")
        (d / fname).unlink()
        return d
    make.__name__ = f"run_without_{fname}"
    return make


def _runjson_edit(edit: Callable[[dict], None]) -> Callable[[str], str]:
    def apply(text: str) -> str:
        doc = json.loads(text)
        edit(doc)
        return json.dumps(doc)
    return apply


def _set_actor_x_nan(doc: dict) -> None:
    doc["scenario"]["actors"][0]["start"] = {"x": float("nan"), "y": 0.0, "lane": None, "s": None}


def _scenario_list(doc: dict) -> None:
    doc["scenario"] = [1, 2, 3]


def _ticks_first_line(new: str) -> Callable[[str], str]:
    def apply(text: str) -> str:
        lines = text.splitlines()
        return "\n".join([new, *lines[1:]]) + "\n"
    return apply


def _ticks_edit(edit: Callable[[dict], None]) -> Callable[[str], str]:
    def apply(text: str) -> str:
        lines = text.splitlines()
        rec = json.loads(lines[0])
        edit(rec)
        return "\n".join([json.dumps(rec), *lines[1:]]) + "\n"
    return apply


def _gt_range_nan(rec: dict) -> None:
    rec["ground_truth"]["range"] = ["NaN-string"]


def _frame_huge(rec: dict) -> None:
    rec["frame"] = 10_000_000_000


def _gt_box_wrong_shape(rec: dict) -> None:
    rec["ground_truth"]["visible"] = [[1, 2]]


def _dets_missing(rec: dict) -> None:
    rec["detections"] = {"xyxy": [[1, 2, 3, 4]], "score": [], "class_id": [], "source_id": []}


def run_with_corpus_file(rel: str) -> Callable[[Ctx], Path]:
    """A copy of the valid run with one file replaced by the corpus file ``rel`` (same basename)."""

    def make(ctx: Ctx) -> Path:
        d = run_copy(ctx, "run_" + Path(rel).parent.name)
        shutil.copy(CORPUS / rel, d / Path(rel).name)
        return d
    make.__name__ = f"run_with_{Path(rel).parent.name}"
    return make


def suite_dir_with(summary: str) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        d = ctx.dir / "suite_dir"
        d.mkdir()
        (d / "summary.json").write_text(summary)
        return d
    return make


def coco_copy(ctx: Ctx, name: str = "split") -> Path:
    dst = ctx.dir / name
    shutil.copytree(ctx.bases.coco, dst)
    return dst


def coco_from_corpus(rel: str) -> Callable[[Ctx], Path]:
    """A corpus COCO split directory copied into the case dir (its annotations.json is named)."""

    def make(ctx: Ctx) -> Path:
        dst = ctx.dir / Path(rel).name
        shutil.copytree(CORPUS / rel, dst)
        return dst
    make.__name__ = f"coco_{Path(rel).name}"
    return make


def coco_edit(label: str, edit: Callable[[dict], None]) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        d = coco_copy(ctx, f"split_{label}")
        p = d / "annotations.json"
        doc = json.loads(p.read_text())
        edit(doc)
        p.write_text(json.dumps(doc))
        return d
    make.__name__ = f"coco_{label}"
    return make


def _ann_bbox_nan(doc: dict) -> None:
    doc["annotations"][0]["bbox"] = [float("nan"), 1.0, float("inf"), 5.0]


def _ann_category_huge(doc: dict) -> None:
    doc["annotations"][0]["category_id"] = 10**12


def _ann_no_range(doc: dict) -> None:
    del doc["annotations"][0]["attributes"]


def _image_size_huge(doc: dict) -> None:
    doc["images"][0]["width"] = 60000
    doc["images"][0]["height"] = 60000


def _mkdir(ctx: Ctx, name: str) -> Path:
    p = ctx.dir / name
    p.mkdir()
    return p


def copy_dir(rel: str) -> Callable[[Ctx], Path]:
    def make(ctx: Ctx) -> Path:
        dst = ctx.dir / Path(rel).name
        shutil.copytree(CORPUS / rel, dst)
        return dst
    make.__name__ = f"copy_{Path(rel).name}"
    return make


def _train_dataset(ctx: Ctx) -> Path:
    d = ctx.dir / "dataset"
    (d / "train").mkdir(parents=True)
    (d / "train" / "annotations.json").write_text("{\"images\": [")
    return d


# ----------------------------------------------------------------------------------- the table

S = "scenario/"
OUT = ["--out", "{out}"]


def image_folder(ctx: Ctx) -> Path:
    """A valid one-image source for ``watch`` (640x360 PNG) at ``{tmp}/imgs``."""
    import cv2
    import numpy as np

    folder = ctx.dir / "imgs"
    folder.mkdir(exist_ok=True)
    cv2.imwrite(str(folder / "f0.png"), np.full((360, 640, 3), 90, np.uint8))
    return folder


def watch_input(name: str, data: str | bytes) -> Callable[[Ctx], Path]:
    """``name`` (a calibration file or speed log) with ``data``, beside a valid image folder."""
    def make(ctx: Ctx) -> Path:
        image_folder(ctx)
        return _write(ctx, name, data)
    return make


CALIBRATION_OK = ("version: 1\nimage: {width: 640, height: 360}\nintrinsics: {fov_h_deg: 90}\n"
                  "mount: {x: -1.5, height: 1.4}\n")


def _c(id: str, argv: list[str], what: str, **kw) -> Case:
    return Case(id=id, argv=argv, what=what, **kw)


SCENARIO_FILES: list[tuple[str, str]] = [  # (file under scenario/, what is wrong): validate-batch
        ("empty.yaml", "an empty file"),
        ("comments_only.yaml", "only comments (YAML null)"),
        ("tabs.yaml", "tab indentation"),
        ("unclosed_bracket.yaml", "unclosed flow mapping"),
        ("unclosed_list.yaml", "unclosed flow sequence"),
        ("unclosed_quote.yaml", "unterminated quoted scalar"),
        ("duplicate_keys.yaml", "the key 'name' twice at the top level"),
        ("duplicate_nested_keys.yaml", "ego.speed twice"),
        ("top_list.yaml", "top level is a list"),
        ("top_scalar.yaml", "top level is a string"),
        ("top_null.yaml", "top level is null"),
        ("unknown_field.yaml", "unknown top-level field"),
        ("unknown_nested.yaml", "unknown field ego.speeed"),
        ("wrong_type_duration.yaml", "duration is a string"),
        ("wrong_type_actors.yaml", "actors is a mapping"),
        ("wrong_type_lanes.yaml", "road.lanes is a list"),
        ("missing_actor_type.yaml", "actor without type"),
        ("unknown_actor_type.yaml", "actor type unicorn"),
        ("nan_duration.yaml", "duration .nan"),
        ("inf_duration.yaml", "duration .inf"),
        ("tiny_duration.yaml", "duration 1e-300 s (no tick)"),
        ("tiny_rate.yaml", "simulation and camera rate 1e-300 Hz"),
        ("nan_actor_x.yaml", "actor start x .nan"),
        ("inf_actor_y.yaml", "actor start y .inf"),
        ("ninf_actor_x.yaml", "actor start x -.inf"),
        ("huge_actor_x.yaml", "actor start x 1e308"),
        ("nan_heading.yaml", "actor heading .nan"),
        ("ninf_heading.yaml", "actor heading -.inf"),
        ("huge_heading.yaml", "actor heading 1e308 deg"),
        ("nan_speed.yaml", "actor speed .nan"),
        ("nan_ego_speed.yaml", "ego.speed .nan"),
        ("nan_offset.yaml", "actor start.offset .nan"),
        ("nan_waypoints.yaml", "script waypoint with .nan"),
        ("inf_waypoints.yaml", "script waypoint [.inf, -.inf]"),
        ("nan_action_heading.yaml", "script do.heading .nan"),
        ("inf_action_lateral.yaml", "script do.lateral .inf"),
        ("nan_trigger_speed.yaml", "trigger actor.speed_gt .nan"),
        ("inf_before_ttc.yaml", "expect alert.before_ttc .inf"),
        ("nan_metric_min.yaml", "expect metric.min .nan"),
        ("seed_2pow32.yaml", "seed 2**32 (> 2**32-1)"),
        ("seed_negative.yaml", "seed -1"),
        ("seed_huge.yaml", "seed 10**30"),
        ("seed_float.yaml", "seed 1.5"),
        ("traffic_speed_reversed.yaml", "traffic.speed range [30, 10]"),
        ("traffic_speed_nan.yaml", "traffic.speed [.nan, 10]"),
        ("profile_inf.yaml", "ego.profile time .inf"),
        ("ego_speed_string.yaml", "ego.speed 'fast'"),
        ("camera_huge.yaml", "camera 60000x60000"),
        ("intent_unknown.yaml", "unknown intent override"),
        ("tracker_unknown.yaml", "unknown perception.tracker override"),
        ("nul_bytes.yaml", "a NUL byte in the text"),
        ("latin1.yaml", "Latin-1, not UTF-8"),
        ("utf16.yaml", "UTF-16 with BOM"),
        ("empty_name.yaml", "name ''"),
        ("name_mapping.yaml", "name is a mapping"),
        ("alias_merge_bad.yaml", "merge key << of a sequence"),
        ("undefined_alias.yaml", "alias of an undefined anchor"),
        ("python_tag.yaml", "!!python/object/apply tag"),
]

# one invocation each for a few of them (the rest: one batched validate, test_validate_batch)
VALIDATE_SINGLE = ("tabs.yaml", "unclosed_bracket.yaml", "duplicate_keys.yaml", "top_list.yaml",
                   "unknown_field.yaml", "nan_actor_x.yaml", "huge_actor_x.yaml", "seed_2pow32.yaml",
                   "traffic_speed_reversed.yaml", "tiny_rate.yaml", "latin1.yaml", "python_tag.yaml")

CASES: list[Case] = [
    # ===== validate: scenario YAML files =====================================================
    *[_c(f"validate-{Path(f).stem}", ["validate", "{f}"], what, file=S + f) for f, what in SCENARIO_FILES
      if f in VALIDATE_SINGLE],
    _c("validate-binary-random", ["validate", "{f}"], "512 random bytes", file="binary/random.bin"),
    _c("validate-binary-png", ["validate", "{f}"], "PNG header and random bytes", file="binary/png_header.yaml"),
    _c("validate-missing", ["validate", "{f}"], "no such file", make=missing("no_such_scenario.yaml")),
    _c("validate-directory", ["validate", "{f}"], "a directory, not a file", make=a_directory),
    _c("validate-dangling-symlink", ["validate", "{f}"], "a dangling symlink", make=broken_symlink),
    _c("validate-fifo", ["validate", "{f}"], "a FIFO nobody writes to", make=fifo),
    _c("validate-huge", ["validate", "{f}"], "a 100 MB scenario file", make=huge_yaml, bomb=True),
    _c("validate-sparse-zeros", ["validate", "{f}"], "100 MB of NUL bytes", make=sparse_zeros("zeros.yaml")),
    _c("validate-deep-seq", ["validate", "{f}"], "20000 nested flow sequences",
       make=deep("flow_seq", "name: deep\ndescription: "), bomb=True),
    _c("validate-deep-map", ["validate", "{f}"], "20000 nested flow mappings",
       make=deep("flow_map", "name: deep\nintent: ")),
    _c("validate-deep-block", ["validate", "{f}"], "1500 nested block mappings", make=deep_block),
    _c("validate-laughs", ["validate", "{f}"], "billion laughs (9 levels of 10 aliases)", make=bomb_scenario,
       bomb=True),
    # ===== run ===============================================================================
    _c("run-nan-x", ["run", "{f}", *OUT, "--no-render"], "actor x .nan, run", file=S + "nan_actor_x.yaml"),
    _c("run-tabs", ["run", "{f}", *OUT, "--no-render"], "tab indentation, run", file=S + "tabs.yaml"),
    _c("run-binary", ["run", "{f}", *OUT, "--no-render"], "random bytes, run", file="binary/random.bin"),
    _c("run-missing", ["run", "{f}", *OUT], "no such scenario file or name", make=missing("no_such.yaml")),
    _c("run-laughs", ["run", "{f}", *OUT, "--no-render"], "billion laughs, run", make=bomb_scenario, bomb=True),
    _c("run-tiny-rate", ["run", "{f}", *OUT, "--no-render"], "rate 1e-300, run", file=S + "tiny_rate.yaml"),
    _c("run-renderer-vulkan", ["run", "{sc}", *OUT, "--renderer", "vulkan"], "unknown renderer",
       names="vulkan"),
    _c("run-aeb-maybe", ["run", "{sc}", *OUT, "--aeb", "maybe"], "--aeb maybe", names="--aeb"),
    _c("run-detector-yolo", ["run", "{sc}", *OUT, "--detector", "yolo"], "unknown detector kind",
       names="--detector"),
    _c("run-lang-fr", ["run", "{sc}", *OUT, "--no-render", "--lang", "fr"], "unknown video language",
       names="--lang"),
    _c("run-unknown-option", ["run", "{sc}", *OUT, "--turbo"], "unknown option", names="--turbo"),
    _c("run-no-out", ["run", "{sc}"], "required --out missing", names="--out"),
    _c("run-model-text", ["run", "{sc}", *OUT, "--model", "{f}"], "--model is a text file",
       file="model/text.onnx"),
    _c("run-model-missing", ["run", "{sc}", *OUT, "--model", "{f}"], "--model does not exist",
       make=missing("nope.onnx")),
    _c("run-model-imgsz", ["run", "{sc}", *OUT, "--model", "{f}"], "ONNX imgsz metadata 60000x60000",
       make=hostile_onnx("[60000, 60000]", "imgsz_huge.onnx")),
    _c("run-out-under-file", ["run", "{sc}", "--out", "{under_file}", "--no-render"],
       "--out below a regular file", names="afile"),
    _c("run-out-devnull", ["run", "{sc}", "--out", "{devnull}", "--no-render"], "--out below /dev/null",
       names="/dev/null"),
    _c("run-db-under-file", ["run", "{sc}", *OUT, "--no-render", "--db", "{under_file}"],
       "--db below a regular file", names="afile"),
    _c("run-video-devnull", ["run", "{sc}", *OUT, "--video", "/dev/null/a.mp4"], "--video below /dev/null",
       names="/dev/null"),
    # ===== watch ==============================================================================
    _c("watch-missing-source", ["watch", "{f}", *OUT], "no such video file", make=missing("clip.mp4")),
    _c("watch-garbage-video", ["watch", "{f}", *OUT], "a text file named .mp4",
       make=lambda ctx: _write(ctx, "clip.mp4", "not a video\n" * 50)),
    _c("watch-empty-folder", ["watch", "{f}", *OUT], "an image folder without images",
       make=lambda ctx: (ctx.dir / "noimgs").mkdir() or ctx.dir / "noimgs"),
    _c("watch-calibration-missing", ["watch", "{tmp}/imgs", *OUT, "--calibration", "{f}"], "no such calibration",
       make=lambda ctx: image_folder(ctx) and ctx.dir / "cam.yaml"),
    _c("watch-calibration-nan", ["watch", "{tmp}/imgs", *OUT, "--calibration", "{f}"], "mount height .nan",
       make=watch_input("cam.yaml", CALIBRATION_OK.replace("height: 1.4", "height: .nan"))),
    _c("watch-calibration-typo", ["watch", "{tmp}/imgs", *OUT, "--calibration", "{f}"], "mount.hieght",
       make=watch_input("cam.yaml", CALIBRATION_OK.replace("height: 1.4", "hieght: 1.4"))),
    _c("watch-calibration-laughs", ["watch", "{tmp}/imgs", *OUT, "--calibration", "{f}"], "billion laughs",
       make=watch_input("cam.yaml", "x-laughs:\n" + laughs()[0] + "version: " + laughs()[1] + "\n")),
    _c("watch-calibration-size", ["watch", "{tmp}/imgs", *OUT, "--calibration", "{f}"],
       "calibration for 1280x720, frames 640x360",
       make=watch_input("cam.yaml", CALIBRATION_OK.replace("width: 640, height: 360", "width: 1280, height: 720"))),
    _c("watch-speed-reversed", ["watch", "{tmp}/imgs", *OUT, "--ego-speed", "{f}"], "speed log times go back",
       make=watch_input("speed.csv", "t,speed\n0,10\n2,11\n1,12\n")),
    _c("watch-speed-binary", ["watch", "{tmp}/imgs", *OUT, "--ego-speed", "{f}"], "a binary speed log",
       make=watch_input("speed.csv", b"\x00\x01\xff\xfe" * 64)),
    # ===== render ============================================================================
    _c("render-every-0", ["render", "{sc}", *OUT, "--every", "0"], "--every 0", names="--every"),
    _c("render-every-negative", ["render", "{sc}", *OUT, "--every", "-3"], "--every -3", names="--every"),
    _c("render-every-nonnumber", ["render", "{sc}", *OUT, "--every", "often"], "--every often",
       names="--every"),
    _c("render-renderer-vulkan", ["render", "{sc}", *OUT, "--renderer", "vulkan"], "unknown renderer",
       names="vulkan"),
    _c("render-inf-heading", ["render", "{f}", *OUT], "actor heading -.inf, render",
       file=S + "ninf_heading.yaml"),
    _c("render-out-under-file", ["render", "{sc}", "--out", "{under_file}"], "--out below a regular file",
       names="afile"),
    # ===== suite =============================================================================
    *[_c(f"suite-{Path(f).stem}", ["suite", "{f}", *OUT], what, file="suite/" + f, **kw) for f, what, kw in [
        ("empty.yaml", "an empty suite file", {}),
        ("top_list.yaml", "top level is a list", {}),
        ("scenarios_not_list.yaml", "scenarios is a string", {}),
        ("scenarios_empty.yaml", "scenarios is empty", {}),
        ("missing_scenario.yaml", "names a scenario file that does not exist", {}),
        ("bad_scenario_nan.yaml", "names a scenario with x .nan", {"names": "nan_actor_x.yaml"}),
        ("bad_scenario_yaml.yaml", "names a scenario with malformed YAML", {"names": "unclosed_bracket.yaml"}),
        ("scenario_entry_mapping.yaml", "a scenario entry is a mapping", {}),
        ("scenario_outside.yaml", "a scenario entry ../../etc/passwd", {"names": "passwd"}),
        ("tabs.yaml", "tab indentation", {}),
        ("unclosed_bracket.yaml", "unclosed flow sequence", {}),
        ("duplicate_keys.yaml", "scenarios twice", {}),
        ("unknown_field.yaml", "unknown field workers", {}),
    ]],
    _c("suite-binary", ["suite", "{f}", *OUT], "ELF header bytes", file="binary/elf.txt"),
    _c("suite-laughs", ["suite", "{f}", *OUT], "billion laughs in scenarios", make=bomb_suite, bomb=True),
    _c("suite-deep", ["suite", "{f}", *OUT], "20000 nested sequences",
       make=deep("flow_seq", "name: deep\nscenarios: ")),
    _c("suite-huge", ["suite", "{f}", *OUT], "a 100 MB suite file", make=huge_yaml),
    _c("suite-workers-0", ["suite", "{suite1}", *OUT, "--workers", "0"], "--workers 0", names="--workers"),
    _c("suite-workers-nonnumber", ["suite", "{suite1}", *OUT, "--workers", "two"], "--workers two",
       names="--workers"),
    _c("suite-aeb-maybe", ["suite", "{suite1}", *OUT, "--aeb", "maybe"], "--aeb maybe", names="--aeb"),
    _c("suite-detector-yolo", ["suite", "{suite1}", *OUT, "--detector", "yolo"], "unknown detector kind",
       names="--detector"),
    _c("suite-out-under-file", ["suite", "{suite1}", "--out", "{under_file}"], "--out below a regular file",
       names="afile"),
    _c("suite-db-devnull", ["suite", "{suite1}", *OUT, "--db", "/dev/null/x.sqlite"], "--db below /dev/null",
       names="/dev/null"),
    # ===== regress ===========================================================================
    *[_c(f"regress-{Path(f).stem}", ["regress", "{suite1}", "--baseline", "{f}", "--workers", "1"], what,
         file="baseline/" + f) for f, what in [
        ("invalid.json", "trailing comma, unclosed object"),
        ("empty.json", "an empty baseline file"),
        ("top_list.json", "top level is a list"),
        ("metrics_list.json", "metrics is a list"),
        ("metrics_strings.json", "a metric value is a string"),
        ("metrics_nan.json", "metric values NaN and Infinity"),
        ("tolerances_bad.json", "a tolerance is a number, not a pair"),
    ]],
    _c("regress-binary", ["regress", "{suite1}", "--baseline", "{f}"], "random bytes as baseline",
       file="binary/random.bin"),
    _c("regress-missing", ["regress", "{suite1}", "--baseline", "{f}"], "no such baseline",
       make=missing("no_baseline.json")),
    _c("regress-bad-suite", ["regress", "{f}", "--baseline", "{repo}/scenarios/suites/smoke.baseline.json"],
       "malformed suite", file="suite/tabs.yaml"),
    # ===== sweep =============================================================================
    *[_c(f"sweep-{Path(f).stem}", ["sweep", "{f}", *OUT, "--dry-run"], what, file="sweep/" + f, **kw)
      for f, what, kw in [
        ("empty.yaml", "an empty sweep file", {}),
        ("top_list.yaml", "top level is a list", {}),
        ("no_scenario.yaml", "no scenario field", {}),
        ("missing_scenario.yaml", "base scenario does not exist", {}),
        ("bad_scenario.yaml", "base scenario has tabs", {"names": "tabs.yaml"}),
        ("grid_nan.yaml", "grid ego.speed [5, .nan]", {}),
        ("grid_nan_unbounded.yaml", "grid start.offset [0, .nan]", {}),
        ("grid_inf.yaml", "grid heading [-.inf, .inf]", {}),
        ("grid_wrong_type.yaml", "grid ego.speed [fast, slow]", {}),
        ("grid_not_list.yaml", "grid value is a number", {}),
        ("grid_empty_list.yaml", "grid value is an empty list", {}),
        ("grid_unknown_path.yaml", "grid parameter ego.speeed", {}),
        ("grid_unknown_actor.yaml", "grid parameter of an unknown actor", {}),
        ("set_nan.yaml", "set heading .nan", {}),
        ("samples_n_zero.yaml", "samples.n 0", {}),
        ("samples_n_huge.yaml", "samples.n 10**12", {}),
        ("uniform_reversed.yaml", "uniform [30, 10]", {}),
        ("uniform_nan.yaml", "uniform [.nan, 1]", {}),
        ("uniform_inf.yaml", "uniform [-.inf, .inf]", {}),
        ("randint_seed_huge.yaml", "randint up to 10**23 for the seed", {}),
        ("choice_empty.yaml", "choice []", {}),
        ("distribution_unknown.yaml", "distribution normal", {}),
        ("samples_seed_negative.yaml", "samples.seed -3", {}),
        ("report_unknown.yaml", "report.x names no parameter", {}),
        ("tabs.yaml", "tab indentation", {}),
        ("duplicate_keys.yaml", "grid twice", {}),
        ("unknown_field.yaml", "unknown field workers", {}),
    ]],
    _c("sweep-grid-10pow10", ["sweep", "{f}", *OUT, "--no-report"], "10 parameters x 10 values: 10^10 variants",
       file="sweep/grid_10pow10.yaml", bomb=True),
    _c("sweep-grid-nan-run", ["sweep", "{f}", *OUT, "--no-report"], "grid start.offset .nan, not a dry run",
       file="sweep/grid_nan_unbounded.yaml"),
    _c("sweep-laughs", ["sweep", "{f}", *OUT, "--dry-run"], "billion laughs in grid and set", make=bomb_sweep,
       bomb=True),
    _c("sweep-deep", ["sweep", "{f}", *OUT, "--dry-run"], "20000 nested mappings in grid",
       make=deep("flow_map", "name: deep\nscenario: x.yaml\ngrid: ")),
    _c("sweep-binary", ["sweep", "{f}", *OUT, "--dry-run"], "random bytes", file="binary/random.bin"),
    _c("sweep-workers-0", ["sweep", "aeb_stationary_car", *OUT, "--workers", "0"],
       "--workers 0", names="--workers"),
    _c("sweep-aeb-maybe", ["sweep", "aeb_stationary_car", *OUT, "--aeb", "maybe", "--dry-run"], "--aeb maybe",
       names="--aeb"),
    _c("sweep-out-under-file", ["sweep", "aeb_stationary_car", "--out", "{under_file}"],
       "--out below a regular file", names="afile"),
    # ===== replay ============================================================================
    *[_c(f"replay-config-{Path(f).stem}", ["replay", "{run}", *OUT, "--config", "{f}"], what, file="replay/" + f)
      for f, what in [
        ("not_mapping.yaml", "config is a list"),
        ("unknown_section.yaml", "unknown section trackerr"),
        ("tracker_unknown_key.yaml", "unknown tracker knob"),
        ("tracker_nan.yaml", "tracker.max_age .nan"),
        ("alerts_wrong_type.yaml", "alerts.off_frames 'many'"),
        ("tabs.yaml", "tab indentation"),
        ("unclosed.yaml", "unclosed flow mapping"),
    ]],
    _c("replay-config-missing", ["replay", "{run}", *OUT, "--config", "{f}"], "no such config",
       make=missing("no_config.yaml")),
    _c("replay-config-binary", ["replay", "{run}", *OUT, "--config", "{f}"], "binary config",
       file="binary/png_header.yaml"),
    _c("replay-config-laughs", ["replay", "{run}", *OUT, "--config", "{f}"], "billion laughs config",
       make=bomb_replay, bomb=True),
    _c("replay-config-deep", ["replay", "{run}", *OUT, "--config", "{f}"], "20000 nested sequences",
       make=deep("flow_seq", "tracker: ")),
    _c("replay-config-huge", ["replay", "{run}", *OUT, "--config", "{f}"], "a 100 MB config", make=huge_yaml),
    _c("replay-source-missing", ["replay", "{f}", *OUT], "no such run directory", make=missing("no_run")),
    _c("replay-runjson-invalid", ["replay", "{f}", *OUT], "run.json is not JSON", names="run.json",
       make=broken_run("run.json", "{\"complete\": true,", "invalid")),
    _c("replay-runjson-scenario-nan", ["replay", "{f}", *OUT], "run.json scenario with x NaN", names="run.json",
       make=broken_run("run.json", _runjson_edit(_set_actor_x_nan), "nan")),
    _c("replay-runjson-scenario-list", ["replay", "{f}", *OUT], "run.json scenario is a list",
       names="run.json", make=broken_run("run.json", _runjson_edit(_scenario_list), "sclist")),
    _c("replay-ticks-garbage", ["replay", "{f}", *OUT], "ticks.jsonl first line not JSON", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", _ticks_first_line("{this is not json"), "garbage")),
    _c("replay-ticks-binary", ["replay", "{f}", *OUT], "ticks.jsonl random bytes", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", bytes(range(256)) * 4, "binary")),
    _c("replay-dets-mismatch", ["replay", "{f}", *OUT], "detections arrays of different lengths",
       names="ticks.jsonl", make=broken_run("ticks.jsonl", _ticks_edit(_dets_missing), "dets")),
    _c("replay-jitter-negative", ["replay", "{run}", *OUT, "--jitter", "-1"], "--jitter -1", names="--jitter"),
    _c("replay-jitter-nan", ["replay", "{run}", *OUT, "--jitter", "nan"], "--jitter nan", names="--jitter"),
    _c("replay-miss-rate-2", ["replay", "{run}", *OUT, "--miss-rate", "2"], "--miss-rate 2",
       names="--miss-rate"),
    _c("replay-seed-negative", ["replay", "{run}", *OUT, "--seed", "-1"], "--seed -1", names="--seed"),
    _c("replay-out-under-file", ["replay", "{run}", "--out", "{under_file}"], "--out below a regular file",
       names="afile"),
    # ===== score =============================================================================
    _c("score-missing", ["score", "{f}"], "no such run directory", make=missing("no_run")),
    _c("score-file-not-dir", ["score", "{f}"], "a file, not a run directory", file="valid/base.yaml"),
    _c("score-empty-dir", ["score", "{f}"], "an empty directory", make=lambda ctx: _mkdir(ctx, "empty_run")),
    _c("score-runjson-invalid", ["score", "{f}"], "run.json is not JSON", names="run.json",
       make=run_with_corpus_file("rundir/invalid_json/run.json")),
    _c("score-runjson-list", ["score", "{f}"], "run.json is a list", names="run.json",
       make=run_with_corpus_file("rundir/top_list/run.json")),
    _c("score-runjson-empty", ["score", "{f}"], "run.json is empty", names="run.json",
       make=run_with_corpus_file("rundir/empty_runjson/run.json")),
    _c("replay-runjson-no-scenario", ["replay", "{f}", *OUT], "run.json without scenario", names="run.json",
       make=run_with_corpus_file("rundir/no_scenario/run.json")),
    _c("score-runjson-binary", ["score", "{f}"], "run.json random bytes", names="run.json",
       make=broken_run("run.json", bytes(range(256)) * 2, "binbin")),
    _c("score-no-ticks", ["score", "{f}"], "ticks.jsonl missing", names="ticks.jsonl",
       make=run_without("ticks.jsonl")),
    _c("score-ticks-garbage", ["score", "{f}"], "ticks.jsonl first line not JSON", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", _ticks_first_line("{this is not json"), "garbage")),
    _c("score-ticks-list-line", ["score", "{f}"], "ticks.jsonl first line is a list", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", _ticks_first_line("[1, 2, 3]"), "listline")),
    _c("score-ticks-gt-string", ["score", "{f}"], "ground_truth.range is a string", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", _ticks_edit(_gt_range_nan), "gtstring")),
    _c("score-ticks-box-shape", ["score", "{f}"], "ground_truth.visible boxes of 2 values",
       names="ticks.jsonl", make=broken_run("ticks.jsonl", _ticks_edit(_gt_box_wrong_shape), "boxshape")),
    _c("score-ticks-frame-1e10", ["score", "{f}"], "a tick with frame 10^10", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", _ticks_edit(_frame_huge), "frame")),
    _c("score-ticks-binary", ["score", "{f}"], "ticks.jsonl random bytes", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", bytes(range(256)) * 4, "tbin")),
    # ===== report ============================================================================
    _c("report-missing", ["report", "{f}"], "no such directory", make=missing("no_run")),
    _c("report-empty-dir", ["report", "{f}"], "an empty directory", make=lambda ctx: _mkdir(ctx, "empty_dir")),
    _c("report-runjson-invalid", ["report", "{f}"], "run.json is not JSON", names="run.json",
       make=broken_run("run.json", "{\"complete\": tru", "invalid")),
    _c("report-ticks-garbage", ["report", "{f}"], "ticks.jsonl first line not JSON", names="ticks.jsonl",
       make=broken_run("ticks.jsonl", _ticks_first_line("]]]"), "garbage")),
    _c("report-metrics-invalid", ["report", "{f}"], "metrics.json is not JSON", names="metrics.json",
       make=broken_run("metrics.json", "{\"detection\": ", "metrics")),
    _c("report-summary-invalid", ["report", "{f}"], "suite summary.json is not JSON", names="summary.json",
       make=copy_dir("suitedir/invalid_summary")),
    _c("report-summary-list", ["report", "{f}"], "suite summary.json is a list", names="summary.json",
       make=copy_dir("suitedir/summary_list")),
    _c("report-summary-runs-list", ["report", "{f}"], "summary.json runs is a list", names="summary.json",
       make=copy_dir("suitedir/runs_not_mapping")),
    # ===== query =============================================================================
    _c("query-text-db", ["query", "{f}", "alerts"], "a text file as database", file="db/text.sqlite"),
    _c("query-json-db", ["query", "{f}", "summary"], "a JSON file as database", file="db/json.sqlite"),
    _c("query-binary-db", ["query", "{f}", "tracks"], "random bytes as database", file="binary/random.bin"),
    _c("query-missing-db", ["query", "{f}", "alerts"], "no such database", make=missing("no.sqlite")),
    _c("query-empty-db", ["query", "{f}", "alerts"], "a 0-byte file (no tables)",
       make=lambda ctx: _write(ctx, "empty.sqlite", b"")),
    _c("query-dir-db", ["query", "{f}", "alerts"], "a directory as database", make=a_directory),
    _c("query-what-bogus", ["query", "{run}/run.sqlite", "everything"], "unknown report kind",
       names="everything"),
    _c("query-format-xml", ["query", "{run}/run.sqlite", "alerts", "--format", "xml"], "--format xml",
       names="xml"),
    _c("query-run-nonnumber", ["query", "{run}/run.sqlite", "alerts", "--run", "first"], "--run first",
       names="--run"),
    # ===== export-dataset ====================================================================
    _c("export-nan-scenario", ["export-dataset", "{f}", *OUT, "--no-render"], "actor x .nan",
       file=S + "nan_actor_x.yaml"),
    _c("export-format-pascal", ["export-dataset", "{sc}", *OUT, "--format", "pascal"], "--format pascal",
       names="pascal"),
    _c("export-every-0", ["export-dataset", "{sc}", *OUT, "--every", "0"], "--every 0", names="--every"),
    _c("export-weather-snow", ["export-dataset", "detector", *OUT, "--weather", "snow", "--split", "val",
                              "--no-render"], "--weather snow", names="snow"),
    _c("export-camera-zero", ["export-dataset", "{sc}", *OUT, "--camera", "0x0"], "--camera 0x0",
       names="--camera"),
    _c("export-camera-huge", ["export-dataset", "detector", *OUT, "--camera", "60000x60000", "--split", "val"],
       "--camera 60000x60000", names="--camera", bomb=True),
    _c("export-camera-words", ["export-dataset", "{sc}", *OUT, "--camera", "wide"], "--camera wide",
       names="--camera"),
    _c("export-seeds-reversed", ["export-dataset", "detector", *OUT, "--split", "train", "--seeds", "10", "5",
                                 "--no-render"], "--seeds 10 5", names="--seeds"),
    _c("export-seeds-negative", ["export-dataset", "detector", *OUT, "--split", "train", "--seeds", "-5", "3",
                                 "--no-render"], "--seeds -5 3", names="--seeds"),
    _c("export-split-bogus", ["export-dataset", "detector", *OUT, "--split", "holdout", "--no-render"],
       "--split holdout", names="holdout"),
    _c("export-out-under-file", ["export-dataset", "{sc}", "--out", "{under_file}", "--no-render"],
       "--out below a regular file", names="afile"),
    *[_c(f"export-generator-{Path(f).stem}", ["export-dataset", "{f}", *OUT, "--no-render"], what,
         file="generator/" + f) for f, what in [
        ("seeds_reversed.yaml", "split seeds [30, 10]"),
        ("duration_nan.yaml", "generator duration .nan"),
        ("unknown_field.yaml", "unknown generator field"),
        ("not_mapping.yaml", "generator is a list"),
    ]],
    # ===== eval-detector =====================================================================
    _c("evaldet-model-text", ["eval-detector", "{f}", "{coco}"], "model is a text file", file="model/text.onnx"),
    _c("evaldet-model-empty", ["eval-detector", "{f}", "{coco}"], "model is empty", file="model/empty.onnx"),
    _c("evaldet-model-json", ["eval-detector", "{f}", "{coco}"], "model is JSON", file="model/json.onnx"),
    _c("evaldet-model-missing", ["eval-detector", "{f}", "{coco}"], "no such model", make=missing("no.onnx")),
    _c("evaldet-model-dir", ["eval-detector", "{f}", "{coco}"], "model is a directory", make=a_directory),
    _c("evaldet-model-truncated", ["eval-detector", "{f}", "{coco}"], "first third of the shipped model",
       make=truncated_onnx),
    _c("evaldet-model-rank2", ["eval-detector", "{f}", "{coco}"], "ONNX model whose input is [N, 4]",
       make=onnx_rank2_input),
    _c("evaldet-model-imgsz", ["eval-detector", "{f}", "{coco}"], "ONNX imgsz metadata 60000x60000",
       make=hostile_onnx("[60000, 60000]", "imgsz_huge.onnx"), bomb=True),
    _c("evaldet-model-imgsz-32", ["eval-detector", "{f}", "{coco}"],
       "ONNX imgsz metadata 59968x59968 (multiples of 32: a 43 GB input tensor)",
       make=hostile_onnx("[59968, 59968]", "imgsz_huge32.onnx"), bomb=True),
    _c("evaldet-split-missing", ["eval-detector", "{model}", "{f}"], "no such split", make=missing("no_split")),
    _c("evaldet-split-no-annotations", ["eval-detector", "{model}", "{f}"], "split without annotations.json",
       make=lambda ctx: _mkdir(ctx, "bare_split"), names="annotations.json"),
    *[_c(f"evaldet-coco-{Path(d).name}", ["eval-detector", "{model}", "{f}"], what, make=coco_from_corpus(d),
         names="annotations.json") for d, what in [
        ("coco/invalid_json", "annotations.json not JSON"),
        ("coco/top_list", "annotations.json is a list"),
        ("coco/no_images_key", "annotations.json without images"),
        ("coco/images_not_list", "images is a number"),
        ("coco/image_missing_fields", "an image without file_name / width / height"),
    ]],
    _c("evaldet-coco-image-missing", ["eval-detector", "{model}", "{f}"], "an image file that does not exist",
       make=coco_from_corpus("coco/image_file_missing"), names="nope.png"),
    _c("evaldet-coco-image-text", ["eval-detector", "{model}", "{f}"], "an image file that is text",
       make=coco_from_corpus("coco/image_not_image"), names="a.png"),
    _c("evaldet-coco-image-outside", ["eval-detector", "{model}", "{f}"], "file_name ../../etc/passwd",
       make=coco_from_corpus("coco/image_outside"), names="passwd"),
    _c("evaldet-coco-bbox-nan", ["eval-detector", "{model}", "{f}"], "bbox [NaN, 1, Infinity, 5]",
       make=coco_edit("bboxnan", _ann_bbox_nan), names="annotations.json"),
    _c("evaldet-coco-category-huge", ["eval-detector", "{model}", "{f}"], "category_id 10**12",
       make=coco_edit("cat", _ann_category_huge), names="annotations.json"),
    _c("evaldet-coco-no-attributes", ["eval-detector", "{model}", "{f}"], "annotation without attributes",
       make=coco_edit("noattr", _ann_no_range), names="annotations.json"),
    _c("evaldet-coco-image-size-huge", ["eval-detector", "{model}", "{f}"], "image declared 60000x60000",
       make=coco_edit("imgsize", _image_size_huge), names="annotations.json"),
    _c("evaldet-windows-garbage", ["eval-detector", "{model}", "{coco}", "--windows", "[[0, 0, 1"],
       "--windows malformed YAML", names="--windows"),
    _c("evaldet-windows-nan", ["eval-detector", "{model}", "{coco}", "--windows", "[[.nan, 0, 1, 1]]"],
       "--windows with .nan", names="--windows"),
    _c("evaldet-preprocess-bogus", ["eval-detector", "{model}", "{coco}", "--preprocess", "[{{op: sharpen9000}}]"],
       "--preprocess unknown op", names="--preprocess"),
    _c("evaldet-conf-nan", ["eval-detector", "{model}", "{coco}", "--conf", "nan"], "--conf nan",
       names="--conf"),
    _c("evaldet-conf-5", ["eval-detector", "{model}", "{coco}", "--conf", "5"], "--conf 5 (not a probability)",
       names="--conf"),
    _c("evaldet-min-box-negative", ["eval-detector", "{model}", "{coco}", "--min-box", "-1"], "--min-box -1",
       names="--min-box"),
    _c("evaldet-out-devnull", ["eval-detector", "{model}", "{coco}", "--out", "/dev/null/m.json"],
       "--out below /dev/null", names="/dev/null"),
    # ===== train-detector / soup-detector ====================================================
    _c("train-data-missing", ["train-detector", "{f}", *OUT], "no such dataset", make=missing("no_dataset")),
    _c("train-annotations-invalid", ["train-detector", "{f}", *OUT, "--epochs", "1"],
       "train/annotations.json not JSON", names="annotations.json", make=lambda ctx: _train_dataset(ctx)),
    _c("train-crop-33", ["train-detector", "{ds}", *OUT, "--crop", "33", "33"], "--crop not multiples of 32",
       names="--crop"),
    _c("train-scale-reversed", ["train-detector", "{ds}", *OUT, "--scale", "2", "1"], "--scale 2 1",
       names="--scale"),
    _c("train-epochs-0", ["train-detector", "{ds}", *OUT, "--epochs", "0"], "--epochs 0", names="--epochs"),
    _c("train-init-text", ["train-detector", "{ds}", *OUT, "--init", "{f}", "--epochs", "1"], "--init is a text file",
       file="model/text.pt"),
    _c("soup-text-checkpoints", ["soup-detector", "{f}", "{f}", *OUT], "checkpoints are text files",
       file="model/text.pt"),
    _c("soup-missing", ["soup-detector", "{f}", "{f}", *OUT], "no such checkpoint", make=missing("no.pt")),
    _c("soup-weights-words", ["soup-detector", "{corpus}/model/text.pt", "{corpus}/model/text.pt", *OUT,
                              "--weights", "half,half"], "--weights half,half", names="--weights"),
    _c("soup-weights-count", ["soup-detector", "{corpus}/model/text.pt", "{corpus}/model/text.pt", *OUT,
                              "--weights", "1"], "one weight for two checkpoints", names="--weights"),
    # ===== track / eval-mot ==================================================================
    *[_c(f"track-{Path(f).stem}", ["track", "--det", "{f}", *OUT, "--frame-rate", "10"], what, file="mot/" + f,
         **kw) for f, what, kw in [
        ("garbage.txt", "not a MOT file", {}),
        ("wrong_columns.txt", "4 columns", {}),
        ("non_numeric.txt", "a non-numeric value", {}),
        ("nan_box.txt", "a NaN box coordinate", {}),
        ("inf_box.txt", "an inf box width", {}),
        ("frame_zero.txt", "frame 0", {}),
        ("frame_negative.txt", "frame -5", {}),
        ("frame_float.txt", "frame 1.5", {}),
        ("frame_1e10.txt", "frame 10^10", {"bomb": True}),
        ("frame_1e300.txt", "frame 1e300", {}),
        ("id_huge.txt", "id 1e300", {}),
    ]],
    _c("track-binary", ["track", "--det", "{f}", *OUT], "random bytes", file="binary/random.bin"),
    _c("track-missing", ["track", "--det", "{f}", *OUT], "no such det file", make=missing("det.txt")),
    _c("track-huge-line", ["track", "--det", "{f}", *OUT, "--frame-rate", "10"], "one 100 MB line",
       make=huge_line_det),
    _c("track-seqinfo-bad-rate", ["track", "--det", "{corpus}/mot/seqinfo_bad/det.txt", *OUT],
       "seqinfo.ini frameRate=fast beside det.txt", names="seqinfo.ini"),
    _c("track-seqinfo-garbage", ["track", "--det", "{corpus}/mot/seqinfo_garbage/det.txt", *OUT],
       "seqinfo.ini is not an INI file", names="seqinfo.ini"),
    _c("track-frame-rate-0", ["track", "--det", "{gt}", *OUT, "--frame-rate", "0"], "--frame-rate 0",
       names="--frame-rate"),
    _c("track-frame-rate-word", ["track", "--det", "{gt}", *OUT, "--frame-rate", "fast"], "--frame-rate fast",
       names="--frame-rate"),
    _c("track-out-devnull", ["track", "--det", "{gt}", "--out", "/dev/null/t.txt", "--frame-rate", "10"],
       "--out below /dev/null", names="/dev/null"),
    *[_c(f"evalmot-gt-{Path(f).stem}", ["eval-mot", "--gt", "{f}", "--tracks", "{gt}"], what, file="mot/" + f,
         **kw) for f, what, kw in [
        ("garbage.txt", "gt is not a MOT file", {}),
        ("nan_box.txt", "gt with a NaN coordinate", {}),
        ("frame_1e10.txt", "gt frame 10^10", {"bomb": True}),
        ("duplicate_ids.txt", "gt with a repeated id in a frame", {}),
        ("negative_size.txt", "gt box of negative size", {}),
    ]],
    _c("evalmot-tracks-frame-1e10", ["eval-mot", "--gt", "{gt}", "--tracks", "{f}"], "tracks frame 10^10",
       file="mot/frame_1e10.txt"),
    _c("evalmot-tracks-binary", ["eval-mot", "--gt", "{gt}", "--tracks", "{f}"], "tracks random bytes",
       file="binary/random.bin"),
    _c("evalmot-gt-missing", ["eval-mot", "--gt", "{f}", "--tracks", "{gt}"], "no such gt file",
       make=missing("gt.txt")),
    _c("evalmot-format-xml", ["eval-mot", "--gt", "{gt}", "--tracks", "{gt}", "--format", "xml"],
       "--format xml", names="--format"),
    # ===== ncap ==============================================================================
    _c("ncap-only-bogus", ["ncap", *OUT, "--only", "NOPE-99"], "--only names no case", names="NOPE-99"),
    _c("ncap-speeds-words", ["ncap", *OUT, "--speeds", "fast,slow"], "--speeds fast,slow", names="--speeds"),
    _c("ncap-speeds-negative", ["ncap", *OUT, "--speeds", "-10", "--only", "CCRs"], "--speeds -10",
       names="--speeds"),
    _c("ncap-speeds-nan", ["ncap", *OUT, "--speeds", "nan", "--only", "CCRs"], "--speeds nan", names="--speeds"),
    _c("ncap-aeb-maybe", ["ncap", *OUT, "--aeb", "maybe"], "--aeb maybe", names="--aeb"),
    _c("ncap-detector-yolo", ["ncap", *OUT, "--detector", "yolo"], "--detector yolo", names="--detector"),
    _c("ncap-workers-0", ["ncap", *OUT, "--workers", "0"], "--workers 0", names="--workers"),
    _c("ncap-out-under-file", ["ncap", "--out", "{under_file}", "--only", "CCRs", "--speeds", "20"],
       "--out below a regular file", names="afile"),
    # ===== schema / catalogue / demo / top level =============================================
    _c("schema-out-devnull", ["schema", "--out", "/dev/null/schema.json"], "--out below /dev/null",
       names="/dev/null"),
    _c("schema-out-under-file", ["schema", "--out", "{under_file}"], "--out below a regular file",
       names="afile"),
    _c("schema-out-directory", ["schema", "--out", "{tmp}"], "--out is a directory",
       names="schema-out-directory"),
    _c("catalogue-unknown-option", ["catalogue", "--all"], "unknown option", names="--all"),
    _c("demo-out-under-file", ["demo", "--out", "{under_file}"], "--out below a regular file", names="afile"),
    _c("toplevel-unknown-command", ["frobnicate"], "no such command", names="frobnicate"),
    _c("toplevel-missing-argument", ["validate"], "no scenario given", names="SCENARIOS"),
    # ===== bench =============================================================================
    _c("bench-sim-ticks-negative", ["bench", "sim", *OUT, "--ticks", "-1"], "--ticks -1", names="--ticks"),
    _c("bench-sim-scenario-bad", ["bench", "sim", *OUT, "--scenario", "{f}"], "malformed scenario",
       file=S + "tabs.yaml"),
    _c("bench-detect-model-text", ["bench", "detect", *OUT, "--model", "{f}"], "model is a text file",
       file="model/text.onnx"),
    _c("bench-detect-model-imgsz", ["bench", "detect", *OUT, "--model", "{f}"], "ONNX imgsz 60000x60000",
       make=hostile_onnx("[60000, 60000]", "imgsz_huge.onnx")),
    _c("bench-detect-camera-words", ["bench", "detect", *OUT, "--camera", "huge"], "--camera huge",
       names="--camera"),
    _c("bench-detect-windows-garbage", ["bench", "detect", *OUT, "--windows", "{{oops"], "--windows malformed",
       names="--windows"),
    _c("bench-env-steps-negative", ["bench", "env", *OUT, "--steps", "-5"], "--steps -5", names="--steps"),
    _c("bench-sinks-repeats-0", ["bench", "sinks", *OUT, "--repeats", "0"], "--repeats 0", names="--repeats"),
    _c("bench-track-repeats-negative", ["bench", "track", *OUT, "--repeats", "-1"], "--repeats -1",
       names="--repeats"),
    _c("bench-all-repeats-0", ["bench", "all", *OUT, "--repeats", "0"], "--repeats 0", names="--repeats"),
    _c("bench-sweep-bad", ["bench", "sweep", *OUT, "--sweep", "{f}"], "malformed sweep",
       file="sweep/grid_nan.yaml"),
    _c("bench-sweep-variants-0", ["bench", "sweep", *OUT, "--variants", "0"], "--variants 0",
       names="--variants"),
]


BOMBS: list[Case] = [c for c in CASES if c.bomb]

# The default run (``CORE``) is every case not listed here: at least one of each kind of mistake for
# every command, all bombs, and the cases that found a bug. These (164 more of the same kinds) run
# only with LOOKAHEAD_MALFORMED_ALL=1: each child costs 1-3 s of CPU (Python start-up and imports),
# and the whole table would take ~5 min of two cores.
EXTENDED: frozenset[str] = frozenset("""
    validate-unclosed_bracket validate-duplicate_keys validate-top_list validate-unknown_field
    validate-tiny_rate validate-huge_actor_x validate-traffic_speed_reversed validate-latin1
    validate-python_tag validate-binary-png validate-directory validate-dangling-symlink validate-fifo
    validate-sparse-zeros validate-deep-map validate-deep-block run-nan-x run-tabs run-binary
    run-missing run-tiny-rate run-detector-yolo run-lang-fr run-model-text run-model-missing
    run-out-under-file run-out-devnull run-db-under-file render-inf-heading render-out-under-file
    suite-empty suite-top_list suite-scenarios_not_list suite-scenarios_empty suite-bad_scenario_yaml
    suite-scenario_entry_mapping suite-tabs suite-unclosed_bracket suite-duplicate_keys suite-binary
    suite-deep suite-huge suite-detector-yolo suite-out-under-file suite-db-devnull regress-invalid
    regress-empty regress-top_list regress-metrics_list regress-binary regress-missing sweep-empty
    sweep-top_list sweep-no_scenario sweep-missing_scenario sweep-bad_scenario sweep-grid_nan_unbounded
    sweep-grid_wrong_type sweep-grid_not_list sweep-grid_empty_list sweep-grid_unknown_actor
    sweep-samples_n_zero sweep-uniform_reversed sweep-uniform_inf sweep-randint_seed_huge
    sweep-choice_empty sweep-distribution_unknown sweep-samples_seed_negative sweep-report_unknown
    sweep-tabs sweep-duplicate_keys sweep-unknown_field sweep-grid-nan-run sweep-deep sweep-binary
    sweep-out-under-file replay-config-not_mapping replay-config-unknown_section
    replay-config-tracker_unknown_key replay-config-tracker_nan replay-config-alerts_wrong_type
    replay-config-tabs replay-config-missing replay-config-binary replay-config-deep replay-config-huge
    replay-source-missing replay-runjson-scenario-nan replay-runjson-scenario-list replay-ticks-garbage
    replay-ticks-binary replay-out-under-file score-missing score-file-not-dir score-empty-dir
    score-no-ticks score-ticks-garbage score-ticks-list-line score-ticks-gt-string score-ticks-box-shape
    score-ticks-binary report-missing report-empty-dir report-metrics-invalid report-summary-invalid
    report-summary-runs-list query-json-db query-missing-db query-empty-db query-dir-db query-what-bogus
    query-format-xml export-format-pascal export-weather-snow export-camera-zero export-camera-words
    export-seeds-negative export-split-bogus export-out-under-file export-generator-duration_nan
    export-generator-unknown_field export-generator-not_mapping evaldet-model-text evaldet-model-empty
    evaldet-model-missing evaldet-model-dir evaldet-model-truncated evaldet-split-missing
    evaldet-split-no-annotations evaldet-coco-top_list evaldet-coco-no_images_key
    evaldet-coco-images_not_list evaldet-coco-image_missing_fields evaldet-coco-image-missing
    evaldet-coco-image-text evaldet-coco-image-outside evaldet-coco-bbox-nan evaldet-coco-no-attributes
    evaldet-coco-image-size-huge evaldet-windows-garbage evaldet-windows-nan evaldet-preprocess-bogus
    train-annotations-invalid train-scale-reversed soup-missing soup-weights-words soup-weights-count
    track-inf_box track-frame_negative track-frame_float track-id_huge track-huge-line
    track-seqinfo-bad-rate ncap-speeds-negative ncap-speeds-nan ncap-aeb-maybe ncap-detector-yolo
    ncap-out-under-file schema-out-devnull schema-out-under-file bench-sim-scenario-bad
    bench-detect-camera-words bench-detect-windows-garbage bench-sweep-bad
""".split())
CORE: list[Case] = [c for c in CASES if c.id not in EXTENDED]

BY_ID: dict[str, Case] = {c.id: c for c in CASES}
