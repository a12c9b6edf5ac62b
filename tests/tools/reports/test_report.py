"""HTML reports of a real (short, unrendered) run directory and of a suite directory."""

from __future__ import annotations

import base64
import json
import shutil
from html.parser import HTMLParser
from pathlib import Path

import cv2
import numpy as np
import pytest

from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.reports.report import REPORT_FILE, build_report
from lookahead.tools.scoring.run import score_run
from lookahead.tools.scoring.totals import score_suite
from lookahead.tools.sinks.rundir import RunDirWriter

ROOT = Path(__file__).resolve().parents[3]
SCENARIO = ROOT / "scenarios" / "ped_crossing_nearside.yaml"


class _Refs(HTMLParser):
    """Collects every src/href attribute and the tags of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.refs: list[tuple[str, str, str]] = []
        self.tags: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.add(tag)
        self.refs += [(tag, k, v or "") for k, v in attrs if k in ("src", "href")]


def _parse(path: Path) -> _Refs:
    p = _Refs()
    p.feed(path.read_text(encoding="utf-8"))
    return p


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scored run of the nearside pedestrian crossing, with one key-frame PNG."""
    out = tmp_path_factory.mktemp("report") / "ped"
    sc = load_scenario(SCENARIO)
    Runner(sc, sinks=[RunDirWriter(out, sc, str(SCENARIO))], render=False).run()
    score_run(out)
    (out / "frames").mkdir()
    img = np.zeros((36, 64, 3), np.uint8)
    img[10:20, 20:30] = (255, 80, 80)
    assert cv2.imwrite(str(out / "frames" / "frame_0010.png"), img)
    return out


def test_run_report_sections_and_inlined_images(run_dir: Path) -> None:
    path = build_report(run_dir)
    assert path == run_dir / REPORT_FILE
    text = path.read_text(encoding="utf-8")
    for heading in ("Expectations", "Time to collision", "Intent", "Range estimation", "Timing",
                    "Key frames", "Metrics", "ped_crossing_nearside"):
        assert f">{heading}<" in text, heading
    for section in ("detection", "tracking", "estimation", "intent", "danger", "closed_loop"):
        assert f"<h3>{section}</h3>" in text, section
    refs = _parse(path)
    imgs = [v for tag, k, v in refs.refs if tag == "img"]
    # confusion matrix, range error, TTC timeline, timing + the key frame
    assert len(imgs) == 5
    assert all(v.startswith("data:image/png;base64,") for v in imgs)
    assert "frame_0010.png — t = 1.10 s" in text
    assert "PASS" in text  # the scenario's alert expectation


def test_run_report_is_self_contained(run_dir: Path) -> None:
    refs = _parse(build_report(run_dir))
    assert not [r for r in refs.refs if not r[2].startswith("data:")]  # no links, no external files
    assert not refs.tags & {"script", "link", "iframe"}
    assert "http" not in "".join(v for _, _, v in refs.refs if not v.startswith("data:"))


def test_report_command_scores_first_when_metrics_missing(run_dir: Path, tmp_path: Path, capsys, lookahead) -> None:
    bare = tmp_path / "bare"
    shutil.copytree(run_dir, bare)
    (bare / "metrics.json").unlink()
    assert lookahead("report", bare) == 0
    assert (bare / "metrics.json").is_file() and (bare / REPORT_FILE).is_file()
    assert capsys.readouterr().out.strip().endswith(REPORT_FILE)


@pytest.mark.parametrize("kind", ["missing", "empty"])
def test_report_command_bad_path(tmp_path: Path, capsys, lookahead, kind: str) -> None:
    path = tmp_path / "nope"
    if kind == "empty":
        path.mkdir()
    assert lookahead("report", path) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and str(path) in err


def test_suite_report_rows_and_relative_links(run_dir: Path, tmp_path: Path) -> None:
    suite = tmp_path / "suite"
    names = {"ped_a": "a", "ped_b": "b"}
    for d in names.values():
        shutil.copytree(run_dir, suite / d)
        (suite / d / REPORT_FILE).unlink(missing_ok=True)
    metrics = json.loads((run_dir / "metrics.json").read_text())
    summary = {
        "suite": "tiny", "render": False,
        "runs": {n: {"dir": d, "summary": {}, "metrics": metrics} for n, d in names.items()},
        "totals": score_suite([suite / d for d in names.values()]),
    }
    (suite / "summary.json").write_text(json.dumps(summary))
    path = build_report(suite)
    assert path == suite / REPORT_FILE
    text = path.read_text(encoding="utf-8")
    assert "suite tiny" in text and "TOTAL" in text
    assert text.count("<tr>") + text.count("<tr ") == 1 + len(names) + 1  # header, runs, totals
    hrefs = [v for tag, k, v in _parse(path).refs if k == "href"]
    assert sorted(set(hrefs)) == ["a/report.html", "b/report.html"]
    for d in names.values():
        assert (suite / d / REPORT_FILE).is_file()  # each run's report built too
    assert not [v for _, _, v in _parse(path).refs if v.startswith(("http", "/", "file:"))]


def test_key_frames_come_from_annotated_mp4_without_saved_frames(tmp_path: Path) -> None:
    """A rendered run with --video and no frames/: the strip is the video's key frames (JPEG)."""
    from lookahead.tools.sinks.keyframes import key_frame_reason
    from lookahead.tools.sinks.video import VideoSink

    sc = load_scenario(SCENARIO)
    det = sc.perception.detector.model_copy(update={"kind": "gt"})  # the default ONNX model may be absent
    sc = sc.model_copy(update={"duration": 2.5, "perception": sc.perception.model_copy(update={"detector": det})})
    out = tmp_path / "run"
    video = VideoSink(out / "annotated.mp4", fps=sc.camera.rate)
    Runner(sc, sinks=[RunDirWriter(out, sc, str(SCENARIO)), video], render=True).run()
    records = [json.loads(line) for line in (out / "ticks.jsonl").read_text().splitlines()]
    assert video.frames_written == len(records) > 10
    seen: set[str] = set()
    want = [k for k, r in enumerate(records)
            if key_frame_reason(k, len(records), {a["kind"] for a in r["alerts"]}, bool(r["collisions"]), seen)]
    text = build_report(out).read_text(encoding="utf-8")
    assert "no key frames" not in text
    strip = text.split(">Key frames<", 1)[1].split("<h2>", 1)[0]
    imgs = [v for tag, k, v in _parse_text(strip).refs if tag == "img"]
    assert len(imgs) == len(want) >= 3 and all(v.startswith("data:image/jpeg;base64,") for v in imgs)
    assert f"annotated.mp4 frame {records[want[0]]['frame']} — t = {records[want[0]]['t']:.2f} s" in strip
    assert "50% of the run" in strip
    first = base64.b64decode(imgs[0].split(",", 1)[1])
    img = cv2.imdecode(np.frombuffer(first, np.uint8), cv2.IMREAD_COLOR)
    assert img.shape == (sc.camera.height, sc.camera.width, 3)


def test_run_without_frames_or_video_says_so(run_dir: Path, tmp_path: Path) -> None:
    bare = tmp_path / "bare"
    shutil.copytree(run_dir, bare)
    shutil.rmtree(bare / "frames")
    assert "no key frames" in build_report(bare).read_text(encoding="utf-8")


def _parse_text(text: str) -> _Refs:
    p = _Refs()
    p.feed(text)
    return p


def _one_error_line(capsys, code: int, *needles: str) -> None:
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, (code, err)
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.mark.parametrize(("content", "needle"), [
    (b"\x00\xff\xfe\x80", "metrics.json:1: not UTF-8 text"),
    (b'{"detection": 5}', "metrics.json: detection: expected a mapping, got int"),
    (b'{"expectations": 5}', "metrics.json: expectations: expected a list of results"),
    (b'{"expectations": [{"passed": true}]}', "metrics.json: expectations: expected a list of results"),
    (b'{"timing": {"track": 5}}', "metrics.json: timing.track: expected a mapping, got int"),
    (b'{"intent": {"confusion": {"labels": ["a"], "matrix": [[1, 2]]}}}', "metrics.json: intent.confusion"),
    (b'{"detection": {"per_class": {"car": 3}}}', "metrics.json: detection.per_class"),
    (b'{"danger": {"event_list": [1]}}', "metrics.json: danger.event_list"),
])
def test_a_malformed_metrics_json_is_one_line_naming_it(run_dir: Path, tmp_path: Path, capsys, lookahead,
                                                        content: bytes, needle: str) -> None:
    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    (run / REPORT_FILE).unlink(missing_ok=True)
    (run / "metrics.json").write_bytes(content)
    _one_error_line(capsys, lookahead("report", run), f"{run}/{needle}")
    assert not (run / REPORT_FILE).exists()


@pytest.mark.parametrize(("summary", "needle"), [
    (b"\x00\xff\xfe\x80", "summary.json: not UTF-8 text"),
    (b'{"runs": [1, 2]}', "summary.json: runs: expected a mapping, got list"),
    (b'{"runs": {"evil": {"dir": "../outside"}}}', "summary.json: runs.evil.dir '../outside' is not a directory inside"),
    (b'{"runs": {"evil": {"dir": "/tmp"}}}', "summary.json: runs.evil.dir '/tmp' is not a directory inside"),
])
def test_a_suite_summary_cannot_send_a_report_outside_the_suite(run_dir: Path, tmp_path: Path, capsys, lookahead,
                                                                 summary: bytes, needle: str) -> None:
    outside = tmp_path / "outside"
    shutil.copytree(run_dir, outside)  # a run directory a report could be written into
    (outside / REPORT_FILE).unlink(missing_ok=True)
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "summary.json").write_bytes(summary)
    _one_error_line(capsys, lookahead("report", suite), f"{suite}/{needle}")
    assert not (outside / REPORT_FILE).exists() and not (suite / REPORT_FILE).exists()
