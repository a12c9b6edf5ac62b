"""The wheel: one top-level package, the shipped detector and scenarios inside, runnable anywhere.

A wheel is built from this checkout and installed into a fresh virtual environment
whose dependencies come from the project's own environment (a ``.pth`` line, so the
test needs no network); the installed ``lookahead`` then runs a packaged scenario with
the shipped ONNX detector from an empty directory.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def run(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    dist = tmp_path_factory.mktemp("dist")
    res = run(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", dist, ROOT)
    assert res.returncode == 0, res.stderr
    (path,) = dist.glob("lookahead-*.whl")
    return path


def test_the_wheel_holds_one_top_level_package_with_the_model_and_scenarios(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {"lookahead", wheel.name.split("-py3")[0] + ".dist-info"}
    for sub in ("perception", "intent", "sim", "tools", "tools/sinks", "perception/detectors"):
        assert f"lookahead/{sub}/__init__.py" in names, sub
    for data in ("models/lookahead-det.onnx", "models/MODEL_CARD.md", "scenarios/ped_crossing_nearside.yaml",
                 "scenarios/suites/smoke.yaml", "scenarios/sweeps/aeb_stationary_car.yaml", "scenarios/ncap/ccrs_100.yaml",
                 "scenarios/scenario.schema.json"):
        assert f"lookahead/{data}" in names, data
    assert not any(n.startswith("lookahead/tests/") for n in names)


def test_installed_wheel_runs_a_packaged_scenario_from_an_empty_directory(wheel: Path, tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    assert run(sys.executable, "-m", "venv", "--without-pip", venv).returncode == 0
    py = venv / "bin" / "python"
    site = Path(run(py, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))").stdout.strip())
    before = set(os.listdir(site))
    res = run(sys.executable, "-m", "pip", "--python", py, "install", "-q", "--no-deps", "--no-index", wheel)
    assert res.returncode == 0, res.stderr
    added = set(os.listdir(site)) - before
    assert added == {"lookahead", wheel.name.split("-py3")[0] + ".dist-info"}, added
    # the dependencies: this environment's packages, added after the install was checked
    (site / "deps.pth").write_text(sysconfig.get_path("purelib") + "\n")

    empty = tmp_path / "empty"
    empty.mkdir()
    res = run(venv / "bin" / "lookahead", "run", "ped_crossing_nearside", "--detector", "onnx", "--out", "ped",
              cwd=empty)
    assert res.returncode == 0, res.stderr[-2000:]
    located = run(py, "-c", "import lookahead.perception.config as c; print(c.DEFAULT_MODEL)", cwd=empty).stdout
    assert Path(located.strip()).is_relative_to(site)  # the wheel's copy, not this checkout's
    run_json = json.loads((empty / "ped" / "run.json").read_text())
    assert run_json["complete"] and run_json["scenario"]["name"] == "ped_crossing_nearside"
    assert run_json["scenario"]["perception"]["detector"]["kind"] == "onnx"
    lines = (empty / "ped" / "ticks.jsonl").read_text().splitlines()
    assert sum(len(json.loads(line)["detections"]["class_id"]) for line in lines) > len(lines) / 2
