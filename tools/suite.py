"""Suite files: a name and a list of scenario paths (relative to the suite file)."""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from sim.scenario import ScenarioError


def load_suite(path: str | Path) -> tuple[str, list[Path]]:
    """(name, scenario paths) of a suite YAML; one-line ``ScenarioError`` when it is wrong."""
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: no such suite file")
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except yaml.YAMLError as e:
        raise ScenarioError(f"{p}: malformed YAML: {getattr(e, 'problem', e)}") from None
    if not isinstance(data, dict) or not isinstance(data.get("scenarios"), list) or not data["scenarios"]:
        raise ScenarioError(f"{p}: scenarios: expected a non-empty list of scenario paths")
    paths = [(p.parent / str(s)).resolve() for s in data["scenarios"]]
    missing = [s for s in paths if not s.is_file()]
    if missing:
        raise ScenarioError(f"{p}: scenarios: no such scenario file {missing[0]}")
    return str(data.get("name", p.stem)), paths


def run_one(scenario_path: str, out_dir: str, render: bool) -> dict:
    """Run and score one scenario into ``out_dir`` (a worker's job; returns its metrics)."""
    from sim.runner import Runner
    from sim.scenario import load_scenario
    from tools.rundir import RunDirWriter
    from tools.score import score_run

    sc = load_scenario(scenario_path)
    summary = Runner(sc, sinks=[RunDirWriter(Path(out_dir), sc, scenario_path)], render=render).run()
    metrics = score_run(Path(out_dir))
    return {"name": sc.name, "dir": out_dir, "summary": summary.to_dict(), "metrics": metrics}


def run_suite(
    suite_path: str | Path, out: Path, workers: int = 1, render: bool = False, progress=None
) -> dict:
    """Run every scenario of a suite (on a process pool when ``workers`` > 1), score
    each, and write ``out/summary.json`` with per-run metrics and suite ``totals``."""
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from multiprocessing import get_context

    from sim.scenario import load_scenario
    from tools.rundir import prepare_dir
    from tools.score import score_suite

    name, paths = load_suite(suite_path)
    for p in paths:  # validate everything before running anything
        load_scenario(p)
    prepare_dir(out)
    jobs = [(str(p), str(out / p.stem), render) for p in paths]
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
    totals = score_suite([Path(r["dir"]) for r in ordered])
    totals["closed_loop"] = {
        "runs": len(ordered),
        "collisions": sum(len(r["summary"]["collisions"]) for r in ordered),
    }
    summary = {
        "suite": name,
        "render": render,
        "runs": {r["name"]: {"dir": Path(r["dir"]).name, "summary": r["summary"], "metrics": r["metrics"]} for r in ordered},
        "totals": totals,
    }
    from sim.records import jsonable

    (out / "summary.json").write_text(json.dumps(jsonable(summary), indent=2) + "\n")
    return summary
