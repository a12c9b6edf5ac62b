"""Suite files: a name and a list of scenario paths (relative to the suite file)."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

from lookahead.intent.stack import build_detector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_aeb, with_detector
from lookahead.tools.runs.inputs import (  # noqa: F401 (re-exported)
    MAX_SUITE_SCENARIOS,
    SUITE_KEYS,
    is_suite,
    load_suite,
    read_yaml,
)
from lookahead.tools.scoring.run import score_run
from lookahead.tools.scoring.totals import RunFrames, suite_totals
from lookahead.tools.sinks.keyframes import KeyFrameSink
from lookahead.tools.sinks.rundir import (
    RunDir,
    RunDirWriter,
    inside,
    prepare_dir,
    safe_file_stem,
    write_summary,
)
from lookahead.tools.sinks.store import SqliteStore, open_db
from lookahead.tools.sinks.video import VideoSink


def run_one(
    scenario_path: str, out_dir: str, render: bool, db: str | None = None, outputs: tuple[str, ...] = (),
    detector: tuple[str | None, str | None] = (None, None), aeb: str | None = None,
) -> dict:
    """Run and score one scenario into ``out_dir`` (a worker's job).

    Returns name, dir, the runner's summary, the metrics and ``frames``: the run's
    ``tools.scoring.totals.RunFrames`` (what suite totals re-score), so the caller does
    not read the run directory again.

    ``outputs`` may name extra sinks: ``keyframes`` (annotated PNGs in frames/),
    ``video`` (annotated.mp4), ``rerun`` (run.rrd). ``detector`` = (kind, model)
    overrides the scenario's detector (``sim.scenario.with_detector``), ``aeb`` (on | off)
    its ego's AEB (``sim.scenario.with_aeb``).
    """
    sc = with_aeb(with_detector(load_scenario(scenario_path), *detector), aeb)
    run_dir = Path(out_dir)
    sinks: list = [RunDirWriter(run_dir, sc, scenario_path)]
    if db is not None:
        sinks.append(SqliteStore(Path(db), sc, run_dir=run_dir, source=scenario_path))
    if "keyframes" in outputs:
        sinks.append(KeyFrameSink(run_dir / "frames", int(sc.duration * sc.camera.rate)))
    if "video" in outputs:
        sinks.append(VideoSink(run_dir / "annotated.mp4", fps=sc.camera.rate))
    if "rerun" in outputs:
        from lookahead.tools.sinks.rerun import RerunSink  # lazy: rerun-sdk only when asked for

        sinks.append(RerunSink(run_dir / "run.rrd"))
    try:
        runner = Runner(sc, sinks=sinks, render=render)
    except BaseException:  # e.g. a detector that cannot run: release the sinks' files now
        for sink in sinks:
            if hasattr(sink, "close"):
                sink.close()
        raise
    summary = runner.run()
    rd = RunDir(out_dir)  # one parse of the run: scoring, then the suite totals' frames
    metrics = score_run(rd)
    return {"name": sc.name, "dir": out_dir, "summary": summary.to_dict(), "metrics": metrics,
            "frames": RunFrames.of(rd)}


def run_suite(
    suite_path: str | Path, out: Path, workers: int = 1, render: bool = False, progress=None,
    db: Path | None = None, outputs: dict[str, tuple[str, ...]] | None = None,
    detector: tuple[str | None, str | None] = (None, None), aeb: str | None = None,
) -> dict:
    """Run every scenario of a suite (on a process pool when ``workers`` > 1), score
    each, and write ``out/summary.json`` with per-run metrics and suite ``totals``
    (``tools.scoring.totals.suite_totals``, from the frames the workers scored).
    ``detector`` = (kind, model) overrides every scenario's detector, ``aeb`` (on | off) every
    scenario's ``ego.aeb``; both are recorded in the summary (None: as the scenarios say)."""
    name, paths = load_suite(suite_path)
    checked: set[str] = set()
    for p in paths:  # validate everything (and load each detector once) before running anything
        sc = with_aeb(with_detector(load_scenario(p), *detector), aeb)
        key = sc.perception.detector.model_dump_json()
        if key not in checked:
            build_detector(sc.perception.detector, sc.seed, render)
            checked.add(key)
    prepare_dir(out)
    if db is not None:  # fail before running anything; creates the schema once
        open_db(db).close()
    outputs = outputs or {}
    det = (detector[0], None if detector[1] is None else str(detector[1]))
    jobs = [(str(p), str(inside(out, out / safe_file_stem(p.stem))), render, None if db is None else str(db),
             outputs.get(p.stem, ()), det, aeb) for p in paths]
    results: dict[str, dict] = {}
    if workers <= 1:
        for job in jobs:
            r = run_one(*job)
            results[r["name"]] = r
            if progress:
                progress(r["name"])
    else:
        with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
            futures = [pool.submit(run_one, *job) for job in jobs]
            for f in as_completed(futures):
                r = f.result()
                results[r["name"]] = r
                if progress:
                    progress(r["name"])
    ordered = [results[load_scenario(p).name] for p in paths]
    totals = suite_totals([r["frames"] for r in ordered], [r["metrics"] for r in ordered])
    summary = {
        "suite": name,
        "render": render,
        "detector": {"kind": detector[0], "model": det[1]},
        "aeb": aeb,
        "runs": {r["name"]: {"dir": Path(r["dir"]).name, "summary": r["summary"], "metrics": r["metrics"]} for r in ordered},
        "totals": totals,
    }
    write_summary(out, summary)
    return summary
