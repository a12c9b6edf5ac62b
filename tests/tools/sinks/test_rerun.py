"""RerunSink: a short real rendered run to .rrd, loaded back through rerun's own reader."""

from __future__ import annotations

import dataclasses
import warnings
from collections import Counter
from pathlib import Path

import pytest

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402

from lookahead.intent.alerts import Alert  # noqa: E402
from lookahead.intent.labels import Risk  # noqa: E402
from lookahead.sim.records import RecordCollector  # noqa: E402
from lookahead.sim.runner import Runner  # noqa: E402
from lookahead.sim.scenario import load_scenario, with_detector  # noqa: E402
from lookahead.tools.sinks.rerun import RerunSink  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]


Collect = RecordCollector


def load(path: Path) -> tuple[Counter, set[str], dict[str, list]]:
    """Rows per temporal entity, static entity paths, and the columns of each temporal entity."""
    # the sink writes no footer (flat memory): read the whole file, as the viewer does
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="RRD file has no footer")
        stream = RrdReader(path).stream()
    rows: Counter = Counter()
    static: set[str] = set()
    columns: dict[str, list] = {}
    for chunk in stream.to_chunks():
        if chunk.is_static:
            static.add(chunk.entity_path)
            continue
        rows[chunk.entity_path] += chunk.num_rows
        assert {"sim_time", "frame"} <= set(chunk.timeline_names)
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            columns.setdefault(f"{chunk.entity_path}:{name}", []).extend(batch.column(name).to_pylist())
    return rows, static, columns


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    sc = load_scenario(ROOT / "scenarios" / "ped_crossing_nearside.yaml").model_copy(update={"duration": 2.0})
    sc = with_detector(sc, "gt")  # the sink is under test, not the detector: ground-truth tracks
    path = tmp_path_factory.mktemp("rrd") / "sub" / "run.rrd"
    sink, col = RerunSink(path), Collect()
    summary = Runner(sc, sinks=[col, sink], render=True).run()
    return path, sink, col.records, summary


def test_rrd_loads_back_with_one_row_per_frame(recorded):
    path, sink, records, summary = recorded
    n = summary.frames
    assert n == len(records) == sink.frames > 10
    rows, static, columns = load(path)
    for entity in ("/ego/camera/image", "/ego/camera/gt", "/ego/camera/tracks", "/ego/camera/detections",
                   "/ego/gt", "/ego/tracks", "/plots/ego/speed", "/plots/range/gt_ped1"):
        assert rows[entity] == n, entity
    assert {"/", "/ego", "/ego/body", "/ego/camera"} <= static
    n_tracked = sum(len(r.tracks.track_id) > 0 for r in records)
    assert n_tracked > 0 and rows["/plots/range/track_1"] == n_tracked
    # the GT boxes and the image are really there
    gt_labels = [x for x in columns["/ego/gt:Boxes3D:labels"] if x]
    assert gt_labels and all(lab == ["ped1"] for lab in gt_labels)
    images = columns["/ego/camera/image:EncodedImage:blob"]
    assert len(images) == n and all(b for b in images)


def test_alerts_are_text_log_entries_with_levels(recorded, tmp_path):
    _, _, records, _ = recorded
    r = next(r for r in records if len(r.tracks.track_id))
    tid = int(r.tracks.track_id[0])
    fcw = Alert(r.t, tid, "fcw", int(Risk.HIGH), 0, 12.0, 2.5, 4, 4, "HIGH: danger", "高风险")
    crit = dataclasses.replace(fcw, kind="critical", level=int(Risk.CRITICAL), reason="CRITICAL: danger")
    path = tmp_path / "alerts.rrd"
    sink = RerunSink(path, jpeg_quality=None)
    sink.on_start({"scenario": "x", "seed": 0})
    sink.on_tick(dataclasses.replace(r, alerts=[fcw, crit]))
    sink.on_end({})
    rows, _, columns = load(path)
    assert rows["/alerts"] == 2
    assert [lv for lv in columns["/alerts:TextLog:level"]] == [["WARN"], ["CRITICAL"]]
    assert any("CRITICAL: danger" in t[0] for t in columns["/alerts:TextLog:text"])
    assert rows["/ego/camera/image"] == 1 and "/ego/camera/image:Image:buffer" in columns  # raw RGB


def test_needs_a_destination():
    with pytest.raises(ValueError, match="path"):
        RerunSink(None, spawn=False)


def test_unwritable_path_is_one_line_output_error(tmp_path):
    from lookahead.tools.sinks.rundir import OutputError

    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError, match="Rerun recording"):
        RerunSink(tmp_path / "file" / "run.rrd")


def test_no_footer_by_default_and_one_on_request(recorded, tmp_path):
    """The default file has no footer (rerun keeps the footer's manifest in memory for the whole
    run); ``footer=True`` writes it, so ``RrdReader.store()`` (which needs it) works."""
    _, _, records, _ = recorded
    for footer in (False, True):
        path = tmp_path / f"footer{footer}.rrd"
        sink = RerunSink(path, footer=footer)
        sink.on_start({"scenario": "x", "seed": 0})
        for r in records[:3]:
            sink.on_tick(r)
        sink.on_end({})
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="RRD file has no footer")
            reader = RrdReader(path)
        if footer:
            assert sum(c.num_rows for c in reader.store().stream().to_chunks() if c.entity_path == "/ego/camera/image") == 3
        else:
            with pytest.raises(RuntimeError, match="without footer"):
                reader.store()
        assert load(path)[0]["/ego/camera/image"] == 3


def test_a_cooperative_run_records_every_camera_and_the_fused_objects(tmp_path):
    sc = with_detector(load_scenario(ROOT / "scenarios" / "coop_child_parked_cars.yaml"), "gt")
    path = tmp_path / "coop.rrd"
    sink = RerunSink(path)
    Runner(sc.model_copy(update={"duration": 0.6}), sinks=[sink], render=True).run()
    rows, static, _ = load(path)
    assert rows["/ego/camera/image"] == 6
    assert rows["/ego/coop/senders/oncoming/camera/image"] == 6  # the oncoming car's own rendered frames
    assert "/ego/coop/senders/oncoming/camera" in static  # its pinhole
    assert rows["/ego/coop/fused"] == 6 and rows["/ego/coop/received/oncoming"] >= 4  # messages arrive 50-70 ms late
