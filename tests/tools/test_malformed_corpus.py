"""Hostile and malformed input to every ``lookahead`` command: exit 2, one line, no traceback.

The README promises that a user's mistake (a malformed scenario, a field of the wrong type, a
missing file, an unwritable output directory) "prints one line naming the file, field and line
and exits with code 2". The corpus (``malformed_cases.CASES``, files under tests/data/malformed/,
big and hostile ones generated at test time) holds that promise to account:

* ``test_malformed_input_refused`` -- one pytest item per case (``malformed_cases.CORE``, 129 cases;
  all of ``CASES`` with LOOKAHEAD_MALFORMED_ALL=1). The first item runs every *selected* case once
  (``-k`` narrows it), each item then checks its own result. The cases run INSIDE the test process
  (``support.inprocess_cli.invoke``: the app as the console script runs it, exit code, stdout,
  stderr incl. file descriptors 1 / 2, shown warnings and log records, an escaped exception as its
  traceback; 10 s timeout; the peak RSS the command added <= 1 GiB): a child per case would pay
  Python's start-up and the command's imports 129 times. The bombs (``case.bomb``), whose memory
  only a child's RLIMIT_AS can cap, still run as real child processes of the installed
  ``lookahead`` script (10 s timeout, peak RSS via ``os.wait4`` <= 1 GiB, RLIMIT_AS 8 GiB), one at a
  time after the in-process ones (``test_bomb_refused_fast`` checks those same runs). A case that
  fails in process is run again as such a child, whose verdict counts: the test process is not a
  fresh one (native libraries keep state earlier tests set), the user's is. A case stopped
  at the timeout is run once more (same 10 s), so that the verdict is about the command, not about
  a moment of load. The per-case wall / CPU / RSS table lands in summary.json beside them (and in
  $LOOKAHEAD_MALFORMED_SUMMARY if set).
* ``test_installed_script_matches_in_process`` -- a sample of cases through the installed script
  as child processes: exit 2, the same one stderr line as in process (the in-process run is a
  faithful stand-in for the console script).
* ``test_validate_batch`` -- every scenario file of the corpus in ONE ``lookahead validate``
  invocation (``validate`` prints one line per file): exit 2, exactly one ``bad`` line per file,
  each naming its file.
* ``test_bomb_refused_fast`` -- the bombs (billion laughs in a scenario, suite, sweep and replay
  config; the 10^10 sweep grid; hostile ONNX ``imgsz`` metadata; MOT frame 10^10; a 100 MB file;
  20000-level nesting; --camera 60000x60000) alone, one at a time: refused (exit 2, one line) in
  under 2 s of wall and CPU time and under 300 MB peak RSS, Python's start-up and the command's
  imports included (about 1 s and 125 MB: every command checks its input before it imports the
  simulator). The corpus test's run of the bomb is the first try when there is one.
* ``test_export_dataset_name_traversal`` -- a scenario named ``../../escape`` exports fine and
  writes only under ``--out`` (in process).
"""

from __future__ import annotations

import json
import os
import shutil
import time
import traceback
from pathlib import Path

import pytest
from malformed_cases import (  # tests/tools is on sys.path (rootdir-relative import)
    BOMBS,
    BY_ID,
    CASES,
    CORE,
    CORPUS,
    HUGE_BYTES,
    MEMORY_LIMIT_BYTES,
    SCENARIO_FILES,
    SHIPPED_MODEL,
    TIMEOUT_S,
    Bases,
    Case,
    Ctx,
    Result,
    run_cli,
)
from support.inprocess_cli import invoke

from lookahead.tools.cli import app

SELECTED = CASES if os.environ.get("LOOKAHEAD_MALFORMED_ALL") else CORE
BOMB_S = 2.0  # a bomb is refused in under this (wall and CPU), start-up included
BOMB_RSS_BYTES = 300 * (1 << 20)  # ... at under this peak RSS
BOMB_RETRIES = 2  # runs more of a case whose wall time alone is over (the machine's load)


# ----------------------------------------------------------------------------------- fixtures


def _build_coco(root: Path) -> Path:
    import json

    import cv2
    import numpy as np

    split = root / "coco"
    (split / "images").mkdir(parents=True)
    img = np.full((360, 640, 3), 90, np.uint8)
    cv2.rectangle(img, (300, 150), (340, 230), (30, 30, 200), -1)
    cv2.imwrite(str(split / "images" / "f0.png"), img)
    doc = {
        "images": [{"id": 1, "file_name": "images/f0.png", "width": 640, "height": 360}],
        "annotations": [{"id": 1, "image_id": 1, "bbox": [300.0, 150.0, 40.0, 80.0], "category_id": 1,
                         "occlusion": 0.0, "area": 3200.0, "iscrowd": 0, "attributes": {"range_m": 20.0}}],
        "categories": [{"id": 1, "name": "pedestrian"}],
    }
    (split / "annotations.json").write_text(json.dumps(doc))
    return split


def _build_huge(root: Path) -> Path:
    p = root / "huge.yaml"
    with p.open("wb") as fh:
        fh.write(b"name: huge\ndescription: ")
        chunk = b"a" * (1 << 20)
        for _ in range(HUGE_BYTES >> 20):
            fh.write(chunk)
        fh.write(b"\n")
    return p


@pytest.fixture(scope="module")
def bases(tmp_path_factory: pytest.TempPathFactory) -> Bases:
    root = tmp_path_factory.mktemp("malformed_bases")
    sc = root / "base.yaml"
    shutil.copy(CORPUS / "valid" / "base.yaml", sc)
    suite1 = root / "suite1.yaml"
    suite1.write_text(f"name: one\nscenarios: [{sc}]\n")
    gt = root / "gt.txt"
    shutil.copy(CORPUS / "mot" / "valid_gt.txt", gt)
    made = root / "run_cli"
    made.mkdir()
    res = invoke(app, ["run", str(sc), "--out", str(root / "run"), "--no-render", "--sqlite"], made, timeout=120)
    assert res.exit_code == 0, f"building the valid base run failed:\n{res.stderr}"
    coco = _build_coco(root)
    for split in ("train", "val"):
        shutil.copytree(coco, root / "ds" / split)
    return Bases(root=root, sc=sc, suite1=suite1, run=root / "run", coco=coco, gt=gt,
                 huge_yaml=_build_huge(root), ds=root / "ds")


_results: dict[str, tuple[Ctx, Result]] = {}


def _run_case(case: Case, bases: Bases, root: Path) -> tuple[Ctx, Result]:
    ctx = Ctx(bases=bases, dir=root / case.id)
    ctx.dir.mkdir(parents=True, exist_ok=True)
    return _run_case_in(case, ctx)


def _fill(case: Case, ctx: Ctx) -> list[str] | Result:
    try:
        return ctx.fill(case)
    except Exception:  # a broken case (the harness's fault): reported by its own item only
        return Result(argv=["lookahead", *case.argv], returncode=-999, stdout="",
                      stderr="HARNESS ERROR building the case:\n" + traceback.format_exc(), wall_s=0.0,
                      maxrss_bytes=0)


def _run_case_in(case: Case, ctx: Ctx) -> tuple[Ctx, Result]:
    """A bomb: a child process of the installed script (its memory capped by RLIMIT_AS)."""
    argv = _fill(case, ctx)
    return ctx, argv if isinstance(argv, Result) else run_cli(argv, ctx.dir)


def _run_in_process(case: Case, ctx: Ctx) -> tuple[Ctx, Result]:
    """Any other case: the app inside this process (``support.inprocess_cli.invoke``)."""
    argv = _fill(case, ctx)
    if isinstance(argv, Result):
        return ctx, argv
    res = invoke(app, argv, ctx.dir, timeout=TIMEOUT_S)
    return ctx, Result(argv=["lookahead", *argv], returncode=res.exit_code, stdout=res.stdout, stderr=res.stderr,
                       wall_s=res.wall_s, maxrss_bytes=res.peak_rss_added_bytes, cpu_s=res.cpu_s, note="in process")


@pytest.fixture(scope="module")
def corpus_results(request: pytest.FixtureRequest, bases: Bases, tmp_path_factory: pytest.TempPathFactory):
    """Runs every selected case of this module's corpus test (once); id -> (ctx, result)."""
    selected = [item.callspec.params["case"] for item in request.session.items
                if getattr(item, "originalname", None) == "test_malformed_input_refused"
                and item.module is request.module]
    root = tmp_path_factory.mktemp("malformed_cases")
    t0 = time.monotonic()
    bombs = [c for c in selected if c.bomb]
    for c in selected:  # in process, in the order of the table
        if not c.bomb:
            ctx = Ctx(bases=bases, dir=root / c.id)
            ctx.dir.mkdir(parents=True, exist_ok=True)
            _results[c.id] = _run_in_process(c, ctx)
    for c in bombs:  # then the bombs' children, one at a time (test_bomb_refused_fast reuses these runs)
        _results[c.id] = _run_case(c, bases, root)
    # A case stopped at the timeout gets a second chance (same 10 s): the verdict should be about the
    # command, not about a moment of load on the machine.
    for c in selected:
        ctx, first = _results[c.id]
        if first.timed_out:
            retry_ctx = Ctx(bases=bases, dir=root / f"{c.id}.again")
            retry_ctx.dir.mkdir()
            _, again = (_run_case_in if c.bomb else _run_in_process)(c, retry_ctx)
            again.note = f"stopped at {first.wall_s:.1f} s; again: {again.wall_s:.1f} s"
            _results[c.id] = (retry_ctx, again)
    # The test process is not a fresh one: what earlier tests left in native libraries (FFmpeg's log
    # level, fixed at its first use, prints "moov atom not found" in one) can change what a case
    # prints. A case that fails in process is judged as a child of the installed script, as a user
    # runs it; the in-process problems stay in its note.
    for c in selected:
        ctx, first = _results[c.id]
        if not c.bomb and first.returncode != -999 and problems(c, ctx, first):
            child_ctx = Ctx(bases=bases, dir=root / f"{c.id}.child")
            child_ctx.dir.mkdir()
            _, child = _run_case_in(c, child_ctx)
            child.note = f"as a child; in process: {'; '.join(problems(c, ctx, first))}"
            child.note += f" ({first.note})" if first.note != "in process" else ""
            _results[c.id] = (child_ctx, child)
    wall = time.monotonic() - t0
    cpu = sum(_results[c.id][1].cpu_s for c in selected)
    rows = [{"id": c.id, "rc": r.returncode, "wall_s": round(r.wall_s, 2), "cpu_s": round(r.cpu_s, 2),
             "rss_mb": round(r.maxrss_bytes / 2**20), "ok": not problems(c, ctx, r),
             "problems": problems(c, ctx, r), "note": r.note, "stderr": r.stderr[-600:]}
            for c in selected for ctx, r in [_results[c.id]]]
    (root / "summary.json").write_text(json.dumps(rows, indent=1))
    if os.environ.get("LOOKAHEAD_MALFORMED_SUMMARY"):  # a copy that outlives pytest's temporary dirs
        Path(os.environ["LOOKAHEAD_MALFORMED_SUMMARY"]).write_text(json.dumps(rows, indent=1))
    print(f"\nmalformed corpus: {len(selected)} cases ({len(bombs)} bombs as children) in {wall:.1f} s wall, "
          f"CPU {cpu:.0f} s; per case: {root / 'summary.json'}")
    return _results


# ----------------------------------------------------------------------------------- checks


def problems(case: Case, ctx: Ctx, res: Result, rss_limit: int = MEMORY_LIMIT_BYTES) -> list[str]:
    """What is wrong with how the command ended (empty: exit 2, one line naming the input)."""
    out: list[str] = []
    if res.timed_out:
        out.append(f"killed after {res.wall_s:.1f} s (no answer within the timeout)")
    elif res.returncode != 2:
        out.append(f"exit code {res.returncode}, expected 2")
    if "Traceback" in res.stderr or "Traceback" in res.stdout:
        out.append("a traceback")
    lines = res.lines
    if len(lines) != 1:
        out.append(f"{len(lines)} non-empty stderr lines, expected 1")
    want = case.expected_name(ctx)
    if lines and not any(want.lower() in ln.lower() for ln in lines):
        out.append(f"stderr does not name {want!r}")
    if res.maxrss_bytes > rss_limit:
        out.append(f"peak RSS {res.maxrss_bytes / 2**20:.0f} MB > {rss_limit / 2**20:.0f} MB")
    return out


def report(case: Case, res: Result, found: list[str]) -> str:
    tail = "\n".join(res.stderr.strip().splitlines()[-8:])
    return (f"{case.id}: {case.what}\n  $ {' '.join(res.argv[1:])}\n  problems: {'; '.join(found)}\n"
            + (f"  ({res.note})\n" if res.note else "")
            + f"  wall {res.wall_s:.1f} s, CPU {res.cpu_s:.1f} s, peak RSS {res.maxrss_bytes / 2**20:.0f} MB, stderr (last lines):\n"
            + "\n".join("    | " + ln for ln in tail.splitlines()))


# ----------------------------------------------------------------------------------- tests


def test_corpus_is_big_enough() -> None:
    commands = {c.argv[0] if c.argv[0] != "bench" else f"bench {c.argv[1]}" for c in CORE}
    assert len(CORE) >= 110
    assert len({c.id for c in CASES}) == len(CASES)
    for cmd in ("run", "validate", "suite", "regress", "sweep", "replay", "score", "report", "query", "render",
                "export-dataset", "eval-detector", "train-detector", "soup-detector", "track", "eval-mot", "ncap",
                "schema", "catalogue", "demo", "bench sim", "bench detect", "bench env", "bench sinks",
                "bench track", "bench all", "bench sweep"):
        assert cmd in commands, f"no malformed case for `lookahead {cmd}`"
    on_disk = {p.relative_to(CORPUS).as_posix() for p in CORPUS.rglob("*") if p.is_file()}
    assert sum(p.stat().st_size for p in CORPUS.rglob("*") if p.is_file()) < 200_000, "keep corpus files small"
    assert {f"scenario/{f}" for f, _ in SCENARIO_FILES} <= on_disk


@pytest.mark.parametrize("case", SELECTED, ids=[c.id for c in SELECTED])
def test_malformed_input_refused(case: Case, corpus_results) -> None:
    ctx, res = corpus_results[case.id]
    found = problems(case, ctx, res)
    assert not found, report(case, res, found)


PARITY = ("validate-nan_actor_x", "run-renderer-vulkan", "track-nan_box")  # a file, an option, another command


def test_installed_script_matches_in_process(bases: Bases, tmp_path: Path) -> None:
    """The in-process runs stand in for the console script: a sample of cases through the installed
    ``lookahead`` as child processes end the same way (exit 2, no traceback, the same one line)."""
    for cid in PARITY:
        case = BY_ID[cid]
        assert case in CORE and not case.bomb
        ctx = Ctx(bases=bases, dir=tmp_path / cid)
        ctx.dir.mkdir()
        argv = ctx.fill(case)
        child = run_cli(argv, ctx.dir)
        _, inproc = _run_in_process(case, ctx)
        for res in (child, inproc):
            found = problems(case, ctx, res)
            assert not found, report(case, res, found)
        assert child.lines == inproc.lines, (cid, child.lines, inproc.lines)


def test_validate_batch(tmp_path: Path) -> None:
    files = [CORPUS / "scenario" / f for f, _ in SCENARIO_FILES]
    res = run_cli(["validate", *map(str, files)], tmp_path, timeout=30)
    lines = res.lines
    msgs = []
    if res.returncode != 2:
        msgs.append(f"exit code {res.returncode}, expected 2")
    if "Traceback" in res.stderr:
        msgs.append("a traceback:\n" + res.stderr[-2000:])
    if len(lines) != len(files):
        msgs.append(f"{len(lines)} stderr lines for {len(files)} files")
    for f, what in SCENARIO_FILES:
        mine = [ln for ln in lines if f"/{f}" in ln]
        if not mine:
            msgs.append(f"{f} ({what}): no line names it")
        elif not all(ln.startswith("bad") for ln in mine):
            msgs.append(f"{f} ({what}): accepted: {mine[0]}")
    assert not msgs, "\n".join(msgs)


def startup_s(where: Path) -> float:
    """Wall time of ``lookahead --help`` now (the best of three): Python, typer and the CLI module."""
    walls = []
    for _ in range(3):
        res = run_cli(["--help"], where, timeout=30)
        assert res.returncode == 0, res.stderr
        walls.append(res.wall_s)
    return min(walls)


_startup: list[float] = []


def startup_s_once(where: Path) -> float:
    """``startup_s`` measured once per module: the scale printed beside a bomb that passed."""
    if not _startup:
        _startup.append(startup_s(where))
    return _startup[0]


def test_bombs_cover_every_kind() -> None:
    kinds = " ".join(c.what for c in BOMBS)
    for what in ("billion laughs", "10^10 variants", "imgsz", "frame 10^10", "100 MB", "nested"):
        assert what in kinds


@pytest.mark.parametrize("case", BOMBS, ids=[c.id for c in BOMBS])
def test_bomb_refused_fast(case: Case, bases: Bases, tmp_path: Path) -> None:
    """Alone, one at a time: refused (exit 2, one line) in under 2 s (wall and CPU) and under 300 MB
    peak RSS, Python's start-up and the command's imports included: every command reads and checks
    its input before it imports the simulator. A wall time over 2 s with the CPU time under it is
    the machine's load, not the command's: such a case runs again (at most twice more) (``lookahead --help``
    start-up is shown for scale)."""
    if case.id in _results and not _results[case.id][1].note:  # the corpus test's own child, run alone
        ctx, res = _results[case.id]
    else:
        ctx = Ctx(bases=bases, dir=tmp_path / "bomb")
        ctx.dir.mkdir()
        res = run_cli(ctx.fill(case), ctx.dir)
    argv = res.argv[1:]
    for _ in range(BOMB_RETRIES):
        if not res.wall_s >= BOMB_S > res.cpu_s:
            break
        res = run_cli(argv, ctx.dir)
    found = problems(case, ctx, res, rss_limit=BOMB_RSS_BYTES)
    if res.wall_s >= BOMB_S:
        found.append(f"took {res.wall_s:.2f} s wall >= {BOMB_S:.0f} s (--help start-up {startup_s(tmp_path):.2f} s)")
    if res.cpu_s >= BOMB_S:
        found.append(f"used {res.cpu_s:.2f} s CPU >= {BOMB_S:.0f} s (--help start-up {startup_s(tmp_path):.2f} s)")
    assert not found, report(case, res, found)
    scale = f"(--help start-up {startup_s_once(tmp_path):.2f} s)"
    print(f"{case.id}: {res.wall_s:.2f} s wall, {res.cpu_s:.2f} s CPU, {res.maxrss_bytes / 2**20:.0f} MB {scale}")


def test_export_dataset_name_traversal(tmp_path: Path) -> None:
    """A scenario whose name climbs out (``../../escape``) exports, and writes only under --out."""
    work = tmp_path / "a" / "b" / "c"
    work.mkdir(parents=True)
    sc = work / "escape.yaml"
    sc.write_text((CORPUS / "valid" / "base.yaml").read_text().replace("name: base", "name: ../../escape")
                  .replace("duration: 1.0", "duration: 0.5"))
    out = work / "ds"
    before = {p for p in tmp_path.rglob("*")}
    for fmt in ("yolo", "coco", "mot"):
        res = invoke(app, ["export-dataset", str(sc), "--out", str(out / fmt), "--format", fmt, "--no-render"], work,
                     timeout=60)
        assert res.exit_code == 0, f"--format {fmt}: exit {res.exit_code}\n{res.stderr[-2000:]}"
    written = {p for p in tmp_path.rglob("*")} - before
    outside = sorted(str(p) for p in written if out not in p.parents and p != out)
    assert not outside, f"export-dataset wrote outside --out: {outside[:5]}"
    assert any(p.is_file() for p in out.rglob("*")), "nothing exported"


def test_shipped_model_exists() -> None:  # the hostile ONNX fixtures are built from it
    assert SHIPPED_MODEL.is_file()
