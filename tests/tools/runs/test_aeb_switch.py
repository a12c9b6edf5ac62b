"""``--aeb on|off`` on run / suite / regress / sweep: every scenario's ``ego.aeb`` switched
(``sim.scenario.with_aeb``), recorded where ``--detector`` is; without it nothing changes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from lookahead.sim.aeb import AebConfig
from lookahead.sim.scenario import ScenarioError, load_scenario, parse_scenario, with_aeb
from lookahead.tools.cli import app

ROOT = Path(__file__).resolve().parents[3]
CAR = ROOT / "scenarios" / "stationary_car.yaml"
cli = CliRunner()


def test_with_aeb_switches_the_ego_aeb_only():
    sc = load_scenario(CAR)
    assert sc.ego.aeb is False
    assert with_aeb(sc, None) is sc
    on = with_aeb(sc, "on")
    assert on.ego.aeb is True and on.ego.aeb_config == AebConfig()  # no settings: the defaults
    assert on.model_dump(exclude={"ego"}) == sc.model_dump(exclude={"ego"})
    assert with_aeb(on, "off").ego.aeb is False and with_aeb(on, "off").ego.aeb_config is None
    tuned = parse_scenario("name: x\nego: {aeb: {latency: 0.5, decel: 4}}\n")
    assert with_aeb(tuned, "on").ego.aeb_config == AebConfig(latency=0.5, decel=4.0)  # its own settings kept
    assert with_aeb(tuned, "off").ego.aeb is False
    with pytest.raises(ScenarioError, match="--aeb: expected on or off"):
        with_aeb(sc, "maybe")


def _ticks(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "ticks.jsonl").read_text().splitlines()]


def test_run_aeb_on_brakes_before_the_stationary_car_and_off_hits_it(tmp_path):
    for switch in ("on", "off"):
        out = tmp_path / switch
        res = cli.invoke(app, ["run", "stationary_car", "--aeb", switch, "--no-render", "--out", str(out)])
        assert res.exit_code == 0, res.output
        run = json.loads((out / "run.json").read_text())
        braked = any((t["ego"].get("brake") or 0) > 0 for t in _ticks(out))
        hits = [c["name"] for c in run["summary"]["collisions"]]
        if switch == "on":
            assert run["scenario"]["ego"]["aeb"] is True  # the shipped scenario has no AEB settings: defaults
            assert braked and hits == []
        else:
            assert run["scenario"]["ego"]["aeb"] is False
            assert not braked and hits == ["target"]


def test_suite_records_the_switch_and_applies_it_to_every_run(tmp_path):
    short = tmp_path / "short_car.yaml"
    short.write_text(CAR.read_text().replace("duration: 8.0", "duration: 1.0"))
    suite = tmp_path / "suite.yaml"
    suite.write_text(f"name: s\nscenarios: [{short.name}]\n")
    res = cli.invoke(app, ["suite", str(suite), "--aeb", "on", "--out", str(tmp_path / "on")])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "on" / "summary.json").read_text())
    assert summary["aeb"] == "on" and summary["detector"] == {"kind": None, "model": None}
    run = json.loads((tmp_path / "on" / "short_car" / "run.json").read_text())
    assert run["scenario"]["ego"]["aeb"] is True
    # without the option: recorded as null, the scenario as written
    assert cli.invoke(app, ["suite", str(suite), "--out", str(tmp_path / "as")]).exit_code == 0
    assert json.loads((tmp_path / "as" / "summary.json").read_text())["aeb"] is None
    assert json.loads((tmp_path / "as" / "short_car" / "run.json").read_text())["scenario"]["ego"]["aeb"] is False
