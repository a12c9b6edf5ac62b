"""Cooperative perception pictures: panels, global map, the MP4 sink, the CLI refusal, the report
section and the rerun entities -- on synthetic ``ticks.jsonl``-shaped records (no simulator)."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from support.video import read_frames

from lookahead.tools.reports.html import nested_tables
from lookahead.tools.reports.report import cooperative_section
from lookahead.tools.sinks import cooperative_view as cv
from lookahead.tools.sinks.cooperative_view import CooperativeVideoSink, CoopFrame, CoopView, Panel

ROOT = Path(__file__).resolve().parents[3]
PED = ROOT / "scenarios" / "ped_crossing_nearside.yaml"


def record(frame: int = 0, alerts: list | None = None, ego=(100.0, -3.5, 0.0)) -> dict:
    """One ``ticks.jsonl`` line of a cooperative run: own #1 at (20, 5), a sender 'rsu' whose
    object 7 matched #1, object 8 only it sees (remote 1000001), object 9 the ego itself."""
    return {
        "t": frame / 10, "frame": frame, "alerts": alerts or [],
        "ego": {"x": ego[0], "y": ego[1], "yaw": ego[2]},
        "ground_truth": {"name": ["car1", "ped"], "box3d": [[22.0, 5.0, 0.8, 4.0, 2.0, 1.5, 0.0],
                                                            [30.0, -10.0, 0.9, 0.5, 0.5, 1.7, 0.0]]},
        "cooperative": {
            "fusion": True,
            "senders": [{"name": "rsu", "pose": [ego[0] + 40.0, ego[1] + 10.0, math.pi],
                         "reported_pose": [ego[0] + 40.0, ego[1] + 10.0, math.pi], "objects": {}}],
            "received": [{"sender": "rsu", "t": frame / 10, "age": 0.1, "id": [7, 8, 9], "truth": [1, 2, 0],
                          "xy": [[20.4, 5.2], [30.0, -10.0], [-2.0, 0.0]], "fused_id": [1, 1000001, -1],
                          "matched": [True, False, False], "matched_source": [0, -1, -1]}],
            "own": {"id": [1], "truth": [1], "xy": [[20.0, 5.0]]},
            "fused": {"id": [1, 1000001], "truth": [1, 2], "class_id": [4, 0], "xy": [[20.2, 5.1], [30.0, -10.0]],
                      "velocity": [[0, 0], [0, 1.0]], "source": [2, 1], "cov": [[0.25, 0.0, 0.25], [4.0, 0.0, 1.0]]},
            "remote": {"id": [1000001]}, "alerts_alone": [], "link": {"sent": frame, "lost": 0},
        },
    }


def at(img: np.ndarray, uv) -> tuple[int, ...]:
    return tuple(int(v) for v in img[int(round(uv[1])), int(round(uv[0]))])


def near(img: np.ndarray, uv, colour, r: int = 1, tol: int = 45) -> bool:
    """A 1 px line (anti-aliased) of ``colour`` passes within ``r`` px of ``uv``."""
    u, v = int(round(uv[0])), int(round(uv[1]))
    win = img[v - r:v + r + 1, u - r:u + r + 1].reshape(-1, 3).astype(int)
    return bool((np.abs(win - np.asarray(colour)).max(axis=1) <= tol).any())


def test_panels_draw_each_object_at_its_ego_frame_position():
    f = CoopFrame.of(record())
    own, recv, fused, matches = cv.panel_own(f), cv.panel_received(f), cv.panel_fused(f), cv.panel_matches(f)
    assert own.shape == (Panel.height, Panel.width, 3)
    u, v = Panel.px(np.array([[20.0, 5.0]]))[0]  # x forward up, y left to the left
    assert u == Panel.width / 2 - 5 * cv.PANEL_PX_PER_M and v == cv.TITLE_H + 30 * cv.PANEL_PX_PER_M
    assert at(own, (u, v)) == cv.OWN
    assert at(fused, Panel.px(np.array([[20.2, 5.1]]))[0]) == cv.SOURCE_COLOURS[2]  # both
    assert at(fused, Panel.px(np.array([[30.0, -10.0]]))[0]) == cv.SOURCE_COLOURS[1]  # other only
    # received: the sender's colour drawn as a square outline around the point; the ego itself crossed out grey
    c = cv.sender_colours(f)["rsu"]
    r = Panel.px(np.array([[30.0, -10.0]]))[0]
    assert near(recv, r + [4, 0], c) and not near(recv, r + [2, 0], c, r=0)  # a hollow square
    assert at(recv, Panel.px(np.array([[-2.0, 0.0]]))[0]) == cv.SELF_DROP
    # the ego's footprint (front bumper at x = 0) and the truth outlines are in every panel
    for img in (own, recv, fused, matches):
        assert at(img, Panel.px(np.array([[-4.0, 0.5]]))[0]) == cv.EGO_FILL
        assert near(img, Panel.px(np.array([[24.0, 5.0]]))[0], cv.GT_OUTLINE, r=0, tol=12)  # car1's front edge
        assert not near(img, Panel.px(np.array([[25.0, 5.0]]))[0], cv.GT_OUTLINE, r=2, tol=12)
    # nothing where nothing is
    assert at(own, Panel.px(np.array([[45.0, 15.0]]))[0]) == cv.BG


def test_fused_ellipse_is_two_sigma_and_matches_pair_received_with_own():
    pts = cv.ellipse(np.diag([4.0, 1.0]))
    assert np.allclose(np.abs(pts).max(0), [4.0, 2.0], atol=0.05)
    f = CoopFrame.of(record())
    img = cv.panel_fused(f)
    top = Panel.px(np.array([[30.0 + 4.0, -10.0]]))[0]  # the 2-sigma ellipse of the remote object
    assert near(img, top, cv.SOURCE_COLOURS[1])
    assert not near(img, Panel.px(np.array([[30.0 + 5.0, -10.0]]))[0], cv.SOURCE_COLOURS[1], r=2)
    lines = cv.match_lines(f)
    assert len(lines) == 1 and np.allclose(lines[0][0], [20.4, 5.2]) and np.allclose(lines[0][1], [20.0, 5.0])


def test_alert_ring_only_for_alerts_with_a_level():
    f = CoopFrame.of(record(alerts=[{"track_id": 1000001, "kind": "fcw", "level": 3},
                                    {"track_id": 1, "kind": "clear", "level": 0}]))
    assert f.alert_ids == [1000001]
    img = cv.panel_fused(f)
    assert near(img, Panel.px(np.array([[30.0, -10.0]]))[0] + [10, 0], cv.ALERT)
    assert not near(img, Panel.px(np.array([[20.2, 5.1]]))[0] + [10, 0], cv.ALERT, r=2)


def test_map_places_the_fused_objects_and_senders_in_the_world():
    view = CoopView({"ego": (90.0, 0.0), "rsu": (60.0, 0.0)})
    f = CoopFrame.of(record(ego=(100.0, 10.0, math.pi / 2)))  # facing world +y
    _, world = view.draw(f)
    m = view.map
    assert world.shape == (*m.size, 3)
    # ego-frame (30, -10) with the ego at (100, 10) facing +y: world (110, 40)
    assert np.allclose(cv.rotate(np.array([[30.0, -10.0]]), f.ego_pose), [[110.0, 40.0]])
    assert at(world, m.px(np.array([[110.0, 40.0]]))[0]) == cv.SOURCE_COLOURS[1]
    # the sender's body sits behind its pose (it faces -x): 2 m behind is world x + 2
    assert at(world, m.px(np.array([[142.0, 20.0]]))[0]) == cv.sender_colours(f)["rsu"]
    assert np.allclose(cv.to_frame(cv.rotate(np.array([[3.0, 4.0]]), f.ego_pose), f.ego_pose), [[3.0, 4.0]])


def test_sink_writes_one_video_frame_per_cooperative_record_and_the_key_frame(tmp_path):
    sink = CooperativeVideoSink(tmp_path / "v" / "coop.mp4", tmp_path / "run", fps=10.0)
    sink.on_start({})
    for k in range(7):
        rec = record(k, alerts=[{"track_id": 1000001, "kind": "fcw", "level": 3}] if k in (4, 5) else [])
        sink.on_tick(rec)
    sink.on_tick({"t": 0.7, "frame": 7, "ego": {}})  # no cooperative entry: not drawn
    sink.on_end({})
    frames = read_frames(tmp_path / "v" / "coop.mp4")
    assert sink.frames_written == len(frames) == 7
    grid_shape = cv.panels(CoopFrame.of(record())).shape
    assert frames[0].shape == (grid_shape[0], grid_shape[1] + 2 + cv.MAP_WIDTH, 3)
    key = json.loads((tmp_path / "run" / "cooperative" / "key_frame.json").read_text())
    assert key["frame"] == 4 and "others" in key["why"]
    assert (tmp_path / "run" / "cooperative" / "panels.png").is_file()
    assert (tmp_path / "run" / "cooperative" / "map.png").is_file()


def test_without_a_remote_alert_the_key_frame_is_the_middle(tmp_path):
    sink = CooperativeVideoSink(None, tmp_path, fps=10.0)
    sink.on_start({})
    for k in range(9):
        sink.on_tick(record(k))
    sink.on_end({})
    assert sink.key["frame"] == 4 and sink.key["why"] == "middle of the run"


def test_cli_refuses_coop_video_for_a_scenario_without_other_cameras(lookahead, capsys, tmp_path):
    code = lookahead("run", PED, "--out", tmp_path / "r", "--no-render", "--coop-video", tmp_path / "c.mp4")
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.count("\n") == 0 and "--coop-video" in err and "cooperative" in err
    assert not (tmp_path / "r").exists() and not (tmp_path / "c.mp4").exists()


def test_report_section_shows_the_pictures_and_any_metrics_shape(tmp_path):
    metrics = {"cooperative": {"matching": {"precision": 0.9, "recall": 0.8},
                               "warning": {"fusion": {"lead_time_median_s": 1.5}, "alone": {"lead_time_median_s": None}},
                               "n_frames": 40}}
    assert cooperative_section(tmp_path, {}) == ""
    sink = CooperativeVideoSink(None, tmp_path, fps=10.0)
    sink.on_tick(record(0))
    sink.on_end({})
    html = cooperative_section(tmp_path, metrics)
    assert "Cooperative perception" in html and html.count("data:image/png;base64,") == 2
    assert "middle of the run" in html
    tables = nested_tables(metrics["cooperative"])
    for text in ("n_frames", "<h3>warning</h3>", "fusion / lead_time_median_s", "<h3>matching</h3>", "precision"):
        assert text in tables


def test_rerun_logs_fused_received_and_sender_pose(tmp_path):
    rr = pytest.importorskip("rerun")
    from rerun.chunk import RrdReader

    from lookahead.tools.sinks.rerun import RerunSink

    sink = RerunSink(tmp_path / "c.rrd")
    sink.rec.set_time("frame", sequence=0)
    sink.rec.set_time("sim_time", duration=0.0)

    class Rec:  # the parts of a TickRecord the cooperative logging reads
        pass

    rec = Rec()
    for k, v in record().items():
        setattr(rec, k, v)
    sink._log_cooperative(rec)
    sink.close()
    cols: dict[str, list] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for chunk in RrdReader(tmp_path / "c.rrd").stream().to_chunks():
            batch = chunk.to_record_batch()
            for name in batch.schema.names:
                cols.setdefault(f"{chunk.entity_path}:{name}", []).extend(batch.column(name).to_pylist())
    assert cols["/ego/coop/fused:Points3D:labels"][0] == ["#1 both", "r1 other"]
    assert np.allclose(cols["/ego/coop/fused:Points3D:positions"][0], [[20.2, 5.1, 0.5], [30.0, -10.0, 0.5]])
    assert cols["/ego/coop/received/rsu:Points3D:labels"][0] == ["rsu 7", "rsu 8", "self"]
    assert np.allclose(cols["/ego/coop/senders/rsu:Transform3D:translation"][0], [40.0, 10.0, 0.0])
    assert rr is not None
