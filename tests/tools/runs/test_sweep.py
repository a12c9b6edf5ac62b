"""Scenario sweeps: expansion and ids, a real pool run with failures, a real kill and
resume, the store, Ray, CLI errors, and the bench JSON structure (no timing asserted)."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from lookahead.tools.cli import app
from lookahead.tools.runs.sweep import SweepError, is_complete, load_sweep, run_sweep, variant_id

ROOT = Path(__file__).resolve().parents[3]
CAR = ROOT / "scenarios" / "stationary_car.yaml"
PED = ROOT / "scenarios" / "ped_crossing_nearside.yaml"
cli = CliRunner()


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def short_sweep(tmp_path: Path, grid: str, name: str = "s.yaml", duration: float = 2.0) -> Path:
    return write(tmp_path / name, f"scenario: {CAR}\nset: {{duration: {duration}}}\ngrid:\n{grid}")


def db_runs(db: Path) -> list[tuple]:
    with sqlite3.connect(db) as conn:
        return conn.execute("SELECT run_dir, complete FROM runs ORDER BY run_dir").fetchall()


# --------------------------------------------------------------------------- expansion


def test_grid_times_samples_with_ids_independent_of_order(tmp_path):
    a = write(tmp_path / "a.yaml", f"""scenario: {CAR}
grid:
  ego.speed: [8, 10.5]
  ego.aeb: [false, true]
samples:
  n: 3
  seed: 5
  params:
    actors[target].impact_offset: {{uniform: [-0.5, 0.5]}}
    seed: {{randint: [0, 99]}}
    perception.detector.noise.miss_rate: {{choice: [0.0, 0.1]}}
""")
    b = write(tmp_path / "b.yaml", f"""scenario: {CAR}
samples:
  seed: 5
  params:
    perception.detector.noise.miss_rate: {{choice: [0.0, 0.1]}}
    seed: {{randint: [0, 99]}}
    actors[target].impact_offset: {{uniform: [-0.5, 0.5]}}
  n: 3
grid:
  ego.aeb: [true, false]
  ego.speed: [10.5, 8.0]
""")
    _, _, va = load_sweep(a)
    _, _, vb = load_sweep(b)
    assert len(va) == 2 * 2 * 3 == len({v.id for v in va})
    assert {v.id: v.params for v in va} == {v.id: v.params for v in vb}
    for v in va:
        assert v.id == variant_id(dict(reversed(list(v.params.items()))))
        assert v.scenario.ego.speed == v.params["ego.speed"] and v.scenario.ego.aeb == v.params["ego.aeb"]
        assert v.scenario.seed == v.params["seed"]
        assert v.scenario.actors[0].start.offset == v.params["actors[target].impact_offset"]
        assert v.scenario.perception.detector.noise == {"miss_rate": v.params["perception.detector.noise.miss_rate"]}
        assert v.id.endswith(variant_id(v.params)[-8:]) and "aeb-" in v.id
    # the same draws combine with every grid point
    assert len({json.dumps(v.params["actors[target].impact_offset"]) for v in va}) == 3


def test_shipped_sweep_files_expand():
    sizes = {p.stem: len(load_sweep(p)[2]) for p in sorted((ROOT / "scenarios" / "sweeps").glob("*.yaml"))}
    assert sizes["aeb_stationary_car"] == 16 and sizes["ped_crossing_random"] == 24


def test_item_selectors_and_impact_offset_of_a_crossing_pedestrian(tmp_path):
    sw = write(tmp_path / "p.yaml", f"""scenario: {PED}
grid:
  actors[ped1].script.0.do.speed: [1.4]
  actors.0.heading: [90]
  actors[0].impact_offset: [-3.0, 0.0, 3.0]
""")
    _, _, variants = load_sweep(sw)
    ys = [v.scenario.actors[0].start.y for v in variants]
    assert ys[0] < ys[1] < ys[2] and ys[2] - ys[1] == pytest.approx(3.0)
    from lookahead.sim.runner import Runner

    hits = [bool(Runner(v.scenario, render=False).run().collisions) for v in variants]
    assert hits == [False, True, False]  # not yet there / hit centrally / already past


@pytest.mark.parametrize("text, needles", [
    ("grid:\n  ego.sped: [1]\n", ["grid: ego.sped", "unknown field 'sped'"]),
    ("grid:\n  actors[nobody].speed: [1]\n", ["actors[nobody].speed", "no item with id 'nobody'", "target"]),
    ("grid:\n  ego.speed: [10, 99]\n", ["grid: ego.speed = 99", "ego.speed", "less than or equal to 60"]),
    ("grid:\n  perception.detector.noise.miss_rate: [0.1, 1.5]\n", ["grid: perception.detector.noise.miss_rate = 1.5"]),
    ("grid:\n  ego..speed: [1]\n", ["malformed parameter path"]),
    ("grdi:\n  ego.speed: [1]\n", ["s.yaml:", "grdi: unknown field"]),
    ("samples: {n: 2, params: {ego.speed: {uniform: [5]}}}\n", ["s.yaml:2", "samples.params"]),
    # hostile values: not finite, not a parameter value at all, out of range, two paths to one field
    ("grid:\n  ego.speed: [8, .nan]\n", ["ego.speed", "expected a finite number", "nan"]),
    ("grid:\n  ego.speed: [-.inf]\n", ["ego.speed", "expected a finite number", "inf"]),
    ("grid:\n  ego.speed: []\n", ["grid: ego.speed", "non-empty list"]),
    ("grid:\n  ego.speed: [2020-01-01]\n", ["grid: ego.speed[0]", "unsupported value"]),
    ("set:\n  ego.speed: !!binary aGVsbG8=\n", ["set: ego.speed", "unsupported value"]),
    ("samples: {n: 2, params: {ego.speed: {uniform: [-1.0e308, 1.0e308]}}}\n", ["ego.speed", "finite [low, high]"]),
    ("samples: {n: 2, params: {seed: {randint: [0, 100000000000000000000000]}}}\n", ["seed", "randint"]),
    ("samples: {n: 2, params: {ego.aeb: {choice: [true, 2020-01-01]}}}\n", ["ego.aeb", "item 1", "unsupported"]),
    ("grid:\n  actors[0].speed: [1]\n  actors[target].speed: [2]\n",
     ["actors[target].speed", "same scenario field as actors[0].speed"]),
    ("set:\n  actors[0].speed: 1\ngrid:\n  actors[target].speed: [2]\n",
     ["grid: actors[target].speed", "same scenario field as set: actors[0].speed"]),
])
def test_bad_sweep_is_one_clear_line(tmp_path, text, needles):
    sw = write(tmp_path / "s.yaml", f"scenario: {CAR}\n{text}")
    with pytest.raises(SweepError) as e:
        load_sweep(sw)
    msg = str(e.value)
    assert "\n" not in msg and str(sw) in msg and all(n in msg for n in needles), msg


def test_a_sweep_spec_built_in_python_refuses_non_finite_values():
    """The same check without the YAML loader (which refuses NaN first): the model itself."""
    from pydantic import ValidationError

    from lookahead.tools.runs.sweep import SweepSpec

    for grid in ({"ego.speed": [8.0, float("nan")]}, {"ego.speed": [float("inf")]}):
        with pytest.raises(ValidationError, match=r"grid: ego\.speed\[\d\]: expected a finite number"):
            SweepSpec(scenario=str(CAR), grid=grid)
    with pytest.raises(ValidationError, match="set: duration: expected a finite number"):
        SweepSpec(scenario=str(CAR), set={"duration": float("nan")})


# --------------------------------------------------------------------------- running


def test_pool_sweep_with_failing_variants_store_summary_and_report(tmp_path):
    # an onnx detector passes the scenario model but refuses to run without rendering
    sw = short_sweep(tmp_path, "  ego.speed: [8, 12]\n  perception.detector.kind: [gt, onnx]\n")
    out = tmp_path / "out"
    seen = []
    s = run_sweep(sw, out, workers=2, progress=seen.append)
    assert s["counts"] == {"variants": 4, "done": 2, "failed": 2, "ran": 4, "skipped": 0}
    assert len(seen) == 4 and s["backend"] == "pool"
    on_disk = json.loads((out / "summary.json").read_text())
    assert on_disk["counts"] == s["counts"] and on_disk["totals"]["closed_loop"]["runs"] == 2
    for vid, v in on_disk["variants"].items():
        bad = v["params"]["perception.detector.kind"] == "onnx"
        assert v["status"] == ("failed" if bad else "done")
        if bad:
            assert "needs rendered frames" in v["error"] and "\n" not in v["error"]
            assert on_disk["failed"][vid] == v["error"]
        else:
            assert v["metrics"]["closed_loop.collision"] is False and v["summary"]["frames"] == 20
            assert (out / v["dir"] / "scenario.yaml").is_file()
    done_dirs = sorted(str(out / "runs" / k) for k, v in on_disk["variants"].items() if v["status"] == "done")
    assert db_runs(out / "sweep.sqlite") == [(d, 1) for d in done_dirs]  # one run per variant
    assert (out / "report.html").is_file() and list((out / "plots").glob("*.png"))
    html = (out / "report.html").read_text()
    assert "metrics vs ego.speed" in html and html.count("failed: ") == 2
    # the report command recognises a sweep directory
    (out / "report.html").unlink()
    assert cli.invoke(app, ["report", str(out)]).exit_code == 0 and (out / "report.html").is_file()
    # re-run: the done variants are skipped, only the failed ones run again
    again = run_sweep(sw, out, workers=1, report=False)
    assert again["counts"] == {"variants": 4, "done": 2, "failed": 2, "ran": 2, "skipped": 2}
    assert db_runs(out / "sweep.sqlite") == [(d, 1) for d in done_dirs]


def test_killed_sweep_reruns_only_the_missing_variants(tmp_path):
    exe = Path(sys.executable).parent / "lookahead"
    if not exe.exists():
        pytest.skip("console script not installed")
    sw = short_sweep(tmp_path, "  ego.speed: [6, 7, 8, 9, 10, 11, 12, 13]\n  ego.aeb: [true]\n", duration=3.0)
    out = tmp_path / "out"
    _, _, variants = load_sweep(sw)
    proc = subprocess.Popen([str(exe), "sweep", str(sw), "--out", str(out), "--workers", "2", "--no-report"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and proc.poll() is None:
            if sum(is_complete(out / "runs" / v.id, v.scenario) for v in variants) >= 2:
                break
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its workers, mid-run
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    before = {v.id: (out / "runs" / v.id / "metrics.json").stat().st_mtime_ns
              for v in variants if is_complete(out / "runs" / v.id, v.scenario)}
    assert 2 <= len(before) < len(variants)
    s = run_sweep(sw, out, workers=1, report=False)
    assert s["counts"] == {"variants": 8, "done": 8, "failed": 0, "ran": 8 - len(before), "skipped": len(before)}
    assert {k for k, v in s["variants"].items() if v["skipped"]} == set(before)
    for vid, mtime in before.items():
        assert (out / "runs" / vid / "metrics.json").stat().st_mtime_ns == mtime  # not run again
    rows = db_runs(out / "sweep.sqlite")  # the killed, half-written runs are gone from the store
    assert rows == sorted((str(out / "runs" / v.id), 1) for v in variants)


def _ray_or_skip():
    try:
        import ray
    except ImportError as e:
        pytest.skip(f"ray is not importable (the 'distributed' extra): {e}")
    return ray


def test_sweep_on_a_local_ray_instance_equals_the_pool(tmp_path):
    """``--ray local``: a new local Ray instance (2 CPUs), started and shut down by the sweep, runs
    every variant on reused workers with the same metrics as the process pool."""
    ray = _ray_or_skip()
    sw = short_sweep(tmp_path, "  ego.speed: [8, 10, 12]\n  ego.aeb: [true]\n", duration=1.0)
    s = run_sweep(sw, tmp_path / "ray", ray_address="local", workers=2, report=False)
    assert not ray.is_initialized()  # started here, so shut down here
    pool = run_sweep(sw, tmp_path / "pool", workers=2, report=False)
    assert s["backend"] == "ray" and pool["backend"] == "pool"
    assert s["counts"] == pool["counts"] == {"variants": 3, "done": 3, "failed": 0, "ran": 3, "skipped": 0}
    assert len(db_runs(tmp_path / "ray" / "sweep.sqlite")) == 3
    on_disk = json.loads((tmp_path / "ray" / "summary.json").read_text())
    assert {k: v["metrics"] for k, v in on_disk["variants"].items()} == {
        k: v["metrics"] for k, v in json.loads((tmp_path / "pool" / "summary.json").read_text())["variants"].items()}
    assert json.dumps(s["totals"], sort_keys=True) == json.dumps(pool["totals"], sort_keys=True)
    # 3 variants on at most 2 reused worker processes, none of them this one
    assert 1 <= len(s["worker_pids"]) <= 2 and os.getpid() not in s["worker_pids"]
    assert {v["pid"] for v in s["variants"].values()} == set(s["worker_pids"])


def test_cli_bad_input_is_one_line_and_exit_2(tmp_path):
    bad_field = short_sweep(tmp_path, "  ego.speed: [8]\nworkers: 3\n", name="bad.yaml")
    bad_path = short_sweep(tmp_path, "  ego.speeed: [8]\n", name="path.yaml")
    nan = short_sweep(tmp_path, "  ego.speed: [8, .nan]\n", name="nan.yaml")
    for args, needle in [
        (["sweep", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "o")], "no such sweep file"),
        (["sweep", str(bad_field), "--out", str(tmp_path / "o")], "workers: unknown field"),
        (["sweep", str(bad_path), "--out", str(tmp_path / "o")], "unknown field 'speeed'"),
        (["sweep", str(nan), "--out", str(tmp_path / "o")], "expected a finite number, got nan"),
    ]:
        res = cli.invoke(app, args)
        out = res.output.strip()
        assert res.exit_code == 2 and needle in out and "Traceback" not in out, out
        assert args[1] in out and (args[1] != str(nan) or "ego.speed" in out), out  # the file and the parameter
        assert len(out.splitlines()) == 1, out
    assert not (tmp_path / "o").exists()
    dry = cli.invoke(app, ["sweep", str(short_sweep(tmp_path, "  ego.speed: [8, 9]\n")), "--out",
                           str(tmp_path / "o"), "--dry-run"])
    assert dry.exit_code == 0 and "2 variants, 0 done, 2 to run" in dry.output


# --------------------------------------------------------------------------- benchmarks (structure only)


def _check_bench(result: dict, ratio: str) -> None:
    assert set(result) >= {"machine", "cases", "ratios"} and result["machine"]["cpus"]
    for c in result["cases"].values():
        assert set(c) >= {"ms_median", "ms_p95", "n"} and c["n"] >= 1
    assert result["ratios"][ratio] > 0
    json.dumps(result)


def test_bench_env_and_bench_sweep_json(tmp_path):
    from lookahead.tools.bench.env import bench_env
    from lookahead.tools.bench.sweep import bench_sweep

    env = bench_env(ROOT / "scenarios" / "highway_traffic.yaml", steps=20)
    _check_bench(env, "tracks_env_realtime_factor")
    assert env["traffic_vehicles"] == 10 and env["cases"]["tracks_env_step"]["n"] == 20
    assert "highway_env_step" in env["cases"] and "highway_env_realtime_factor" in env["ratios"]
    sw = short_sweep(tmp_path, "  ego.speed: [8, 9, 10]\n", duration=1.0)
    result = bench_sweep(sw, variants=2, ray=False)
    _check_bench(result, "two_workers_over_one")
    assert result["variants"] == 2 and result["failed_variants"] == 0
    assert set(result["cases"]) == {f"{k}_{n}" for k in ("sweep", "variant", "variant_cpu")
                                    for n in ("1_worker", "2_workers")}
    assert len(result["worker_pids"]["2"]) == 2 and result["workers_reused"]
    assert result["ray_skipped"] == "not asked for" and "ray_over_two_workers" not in result["ratios"]


def test_bench_sweep_ray_case(tmp_path):
    """The Ray case (an initialised Ray, which ``run_sweep`` uses as it is): warmed, reused workers,
    the same results as the 2-worker pool (structure only)."""
    ray = _ray_or_skip()
    from lookahead.tools.bench.sweep import bench_sweep

    sw = short_sweep(tmp_path, "  ego.speed: [8, 9, 10]\n", duration=1.0)
    result = bench_sweep(sw, worker_counts=(2,))
    _check_bench(result, "ray_over_two_workers")
    assert {"sweep_ray", "variant_ray", "variant_cpu_ray", "sweep_2_workers"} <= set(result["cases"])
    assert result["ray_same_results"] is True and result["ray_differing_variants"] == []
    assert result["workers_reused"] and len(result["worker_pids"]["ray"]) == 2
    assert set(result["variant_worker_pids"]["ray"]) <= set(result["worker_pids"]["ray"])
    assert not ray.is_initialized()  # the bench started it, so shut it down


def test_differing_variants_compares_status_and_metrics():
    from lookahead.tools.bench.sweep import differing_variants

    a = {"variants": {"x": {"status": "done", "metrics": {"m": float("nan")}}, "y": {"status": "done", "metrics": {}}}}
    b = {"variants": {"x": {"status": "done", "metrics": {"m": float("nan")}}, "z": {"status": "done", "metrics": {}}}}
    assert differing_variants(a, a) == [] and differing_variants(a, b) == ["y", "z"]
    c = {"variants": {"x": {"status": "done", "metrics": {"m": 1.0}}, "y": {"status": "failed", "metrics": None}}}
    assert differing_variants(a, c) == ["x", "y"]


def test_a_sweep_resumed_with_another_aeb_switch_reruns_instead_of_mixing(tmp_path):
    sw = short_sweep(tmp_path, "  ego.speed: [8]\n  ego.aeb: [false, true]\n", duration=1.0)
    out = tmp_path / "out"
    first = run_sweep(sw, out, workers=1, report=False)
    assert first["aeb"] is None and first["counts"]["ran"] == 2
    # --aeb on: the variant without AEB changes (new config hash) and runs again; the other is the same scenario
    on = run_sweep(sw, out, workers=1, report=False, aeb="on")
    assert on["aeb"] == "on" and on["counts"] == {"variants": 2, "done": 2, "failed": 0, "ran": 1, "skipped": 1}
    for v in on["variants"].values():
        run = json.loads((out / v["dir"] / "run.json").read_text())
        assert run["scenario"]["ego"]["aeb"] is True
    _, _, variants = load_sweep(sw, aeb="on")
    assert all(is_complete(out / "runs" / v.id, v.scenario) for v in variants)
    # --aeb off: both variants now ran with AEB, so both are to run again
    assert not any(is_complete(out / "runs" / v.id, v.scenario) for v in load_sweep(sw, aeb="off")[2])
    res = cli.invoke(app, ["sweep", str(sw), "--out", str(out), "--aeb", "off", "--dry-run"])
    assert res.exit_code == 0 and res.output.count("todo") == 2 and "2 to run" in res.output, res.output
    off = run_sweep(sw, out, workers=1, report=False, aeb="off")
    assert off["aeb"] == "off" and off["counts"]["ran"] == 2 and off["counts"]["done"] == 2
    assert {json.loads((out / v["dir"] / "run.json").read_text())["scenario"]["ego"]["aeb"]
            for v in off["variants"].values()} == {False}


def test_a_sweep_too_large_to_run_is_refused_before_expanding(tmp_path):
    """10 parameters x 10 values (10^10 variants) are counted, not materialised: one error."""
    from lookahead.tools.runs.sweep import MAX_VARIANTS, SweepError, load_sweep

    grid = "\n".join(f"  seed_{i}: [{', '.join(str(v) for v in range(10))}]" for i in range(10))
    f = tmp_path / "huge.yaml"
    f.write_text(f"scenario: {ROOT / 'scenarios' / 'stationary_car.yaml'}\ngrid:\n{grid}\n")
    with pytest.raises(SweepError, match=f"10,000,000,000 variants; at most {MAX_VARIANTS:,}"):
        load_sweep(f)
