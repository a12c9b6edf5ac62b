"""VideoSink: an annotated MP4 of a short real rendered run, read back with OpenCV."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import cv2
import numpy as np
import pytest
from support.video import read_frames
from system_deps import require_cjk_font

from lookahead.intent.alerts import Alert
from lookahead.intent.labels import Risk, risk_colour
from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.sinks import video
from lookahead.tools.sinks.video import VideoSink, find_cjk_font

ROOT = Path(__file__).resolve().parents[3]


Collect = RecordCollector


def gt_detector(sc):
    """``sc`` with the ground-truth detector (the default, the shipped ONNX model, may be absent)."""
    det = sc.perception.detector.model_copy(update={"kind": "gt"})
    return sc.model_copy(update={"perception": sc.perception.model_copy(update={"detector": det})})


def short_scenario(duration: float = 2.0):
    sc = load_scenario(ROOT / "scenarios" / "ped_crossing_nearside.yaml")
    return gt_detector(sc.model_copy(update={"duration": duration}))


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """A 2 s rendered run written to an MP4 (plus the records, for offline checks)."""
    sc = short_scenario()
    path = tmp_path_factory.mktemp("video") / "sub" / "annotated.mp4"
    sink, col = VideoSink(path, fps=sc.camera.rate), Collect()
    summary = Runner(sc, sinks=[col, sink], render=True).run()
    return sc, path, sink, col.records, summary





def test_mp4_reads_back_with_every_frame_at_the_camera_size(rendered):
    sc, path, sink, records, summary = rendered
    frames = read_frames(path)
    assert sink.frames_written == len(records) == summary.frames > 10
    assert len(frames) == sink.frames_written
    assert {f.shape for f in frames} == {(sc.camera.height, sc.camera.width, 3)}
    assert sink.fourcc == video.FOURCC


def test_frames_carry_the_overlay(rendered):
    """The header strip is darkened and every tracked object gets a box in its risk colour."""
    _, path, sink, records, _ = rendered
    frames = read_frames(path)
    k = next(i for i, r in enumerate(records) if len(r.tracks.track_id))
    raw = records[k].frame.image.astype(float)
    shown = cv2.cvtColor(frames[k], cv2.COLOR_BGR2RGB).astype(float)
    assert np.median(shown[2:12, 2:200]) < 0.6 * np.median(raw[2:12, 2:200])  # darkened header
    img = VideoSink(path.with_name("x.mp4"), fps=10).annotate(records[k])
    tr, a = records[k].tracks, records[k].assessments
    for box, risk in zip(tr.xyxy, a.risk, strict=True):
        x0, y0, _, y1 = np.round(box).astype(int)
        ym = (y0 + y1) // 2
        assert np.abs(img[ym, x0].astype(int) - risk_colour(int(risk))).max() < 60


def test_alert_banner_shows_the_latest_alert_reason(rendered):
    _, path, _, records, _ = rendered
    r = next(r for r in records if len(r.tracks.track_id))
    tid = int(r.tracks.track_id[0])
    al = Alert(r.t, tid, "critical", int(Risk.CRITICAL), 0, 9.5, 1.1, 4, 4, "CRITICAL: test", "极高风险：测试")
    sink = VideoSink(path.with_name("y.mp4"), fps=10)
    with_alert = sink.annotate(dataclasses.replace(r, alerts=[al]))
    h = sink._style.text.line_h + sink._style.pad
    row = with_alert[h + 5, :, :].astype(int)
    assert (np.abs(row - risk_colour(Risk.CRITICAL)).max(axis=1) < 30).mean() > 0.5  # a red banner
    cleared = dataclasses.replace(r, alerts=[dataclasses.replace(al, kind="clear", level=0)])
    row = sink.annotate(cleared)[h + 5, :, :].astype(int)
    assert (np.abs(row - risk_colour(Risk.CRITICAL)).max(axis=1) < 30).mean() < 0.5


def test_frames_without_image_are_skipped_with_one_warning(tmp_path, caplog):
    sc = short_scenario(1.0)
    sink = VideoSink(tmp_path / "none.mp4", fps=sc.camera.rate)
    with caplog.at_level(logging.WARNING, logger="lookahead.tools.sinks.video"):
        summary = Runner(sc, sinks=[sink], render=False).run()
    assert summary.frames > 1 and sink.frames_written == 0
    assert len([m for m in caplog.messages if "rendering off" in m]) == 1


def test_zh_without_a_cjk_font_warns_once_and_falls_back(monkeypatch, tmp_path, caplog):
    monkeypatch.setattr(video, "find_cjk_font", lambda *a, **k: None)
    monkeypatch.setattr(video, "_FONT_WARNED", False)
    with caplog.at_level(logging.WARNING, logger="lookahead.tools.sinks.video"):
        sinks = [VideoSink(tmp_path / f"{i}.mp4", fps=10, lang="zh") for i in range(2)]
    assert [s.lang for s in sinks] == ["en", "en"]
    msgs = [m for m in caplog.messages if "no CJK font found" in m]
    assert len(msgs) == 1 and "fonts-noto-cjk" in msgs[0] and "falling back to English" in msgs[0]


def test_zh_draws_chinese_labels(rendered, tmp_path):
    require_cjk_font()  # setup/system.sh installs one (fonts-wqy-microhei)
    _, _, _, records, _ = rendered
    r = next(r for r in records if len(r.tracks.track_id))
    zh = VideoSink(tmp_path / "zh.mp4", fps=10, lang="zh")
    assert zh.lang == "zh"
    en_img = VideoSink(tmp_path / "en.mp4", fps=10).annotate(r)
    zh_img = zh.annotate(r)
    assert zh_img.shape == en_img.shape and np.any(zh_img != en_img)


def test_bad_arguments():
    with pytest.raises(ValueError, match="lang"):
        VideoSink(Path("x.mp4"), fps=10, lang="fr")
    with pytest.raises(ValueError, match="fps"):
        VideoSink(Path("x.mp4"), fps=0)


def test_font_search_by_file_name(monkeypatch, tmp_path):
    monkeypatch.delenv(video.CJK_FONT_ENV, raising=False)
    assert find_cjk_font(dirs=(str(tmp_path),), use_fc=False) is None
    (tmp_path / "truetype" / "wqy").mkdir(parents=True)
    font = tmp_path / "truetype" / "wqy" / "wqy-microhei.ttc"
    font.write_bytes(b"")
    find_cjk_font.cache_clear()
    assert find_cjk_font(dirs=(str(tmp_path),), use_fc=False) == (str(font), 0)


def test_unwritable_path_is_one_line_output_error(tmp_path):
    from lookahead.tools.sinks.rundir import OutputError

    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError, match="video's directory"):
        VideoSink(tmp_path / "file" / "a.mp4", fps=10).on_start({})


def test_bad_paths_fail_when_the_sink_is_made(tmp_path):
    """Checked in __init__ (before any sink starts): a directory, a parent that is a file."""
    from lookahead.tools.sinks.rundir import OutputError

    (tmp_path / "file").write_text("keep")
    (tmp_path / "dir.mp4").mkdir()
    for path, needle in [(tmp_path / "file" / "a.mp4", "video's directory"), (tmp_path / "dir.mp4", "is a directory")]:
        with pytest.raises(OutputError, match=needle) as e:
            VideoSink(path, fps=10)
        assert "\n" not in str(e.value) and str(path) in str(e.value)
    assert (tmp_path / "file").read_text() == "keep" and not any((tmp_path / "dir.mp4").iterdir())
    VideoSink(tmp_path / "new" / "ok.mp4", fps=10)  # a good path: parent made, no file, no probe left
    assert list((tmp_path / "new").iterdir()) == []


def test_a_directory_that_refuses_files_is_an_output_error_at_construction(tmp_path, monkeypatch):
    from lookahead.tools.sinks.rundir import OutputError

    def refuse(self, data):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "write_bytes", refuse)
    with pytest.raises(OutputError, match="cannot write in the video's directory") as e:
        VideoSink(tmp_path / "a.mp4", fps=10)
    assert str(tmp_path / "a.mp4") in str(e.value) and list(tmp_path.iterdir()) == []


def test_key_frames_are_the_video_overlay(rendered, tmp_path):
    """tools.sinks.keyframes.KeyFrameSink draws with the video's Overlay: its PNGs equal VideoSink.annotate."""
    from lookahead.tools.sinks.keyframes import KEY_FRAMES_INDEX, KeyFrameSink

    _, _, _, records, _ = rendered
    keys = KeyFrameSink(tmp_path / "frames", len(records))
    ref = VideoSink(tmp_path / "ref.mp4", fps=10)
    keys.on_start({})
    drawn = {}
    for r in records:
        keys.on_tick(r)
        drawn[r.frame_index] = ref.annotate(r)
    keys.on_end({})
    assert len(keys.saved) >= 3
    for p in keys.saved:
        k = int(p.stem.split("_")[1])
        png = cv2.cvtColor(cv2.imread(str(p)), cv2.COLOR_BGR2RGB)
        assert np.array_equal(png, drawn[k]), p.name
    import json

    reasons = json.loads((tmp_path / "frames" / KEY_FRAMES_INDEX).read_text())
    assert sorted(reasons) == sorted(p.name for p in keys.saved)
    assert any("50% of the run" in v for v in reasons.values())
