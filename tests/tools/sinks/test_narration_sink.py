"""``NarrationSink`` on real closed-loop runs, against a real chat server on loopback that answers,
stalls, talks nonsense or fails, and a closed port: the tick never waits for it, every alert gets
exactly one sentence, and the sentences agree with ground truth."""

from __future__ import annotations

import json
import socket
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from typer.testing import CliRunner

from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.tools.cli import app
from lookahead.tools.scoring.narration import narration_section
from lookahead.tools.sinks.narration import NARRATION_FILE, NarrationConfig, NarrationSink

ROOT = Path(__file__).resolve().parents[3]
SCENARIO = ROOT / "scenarios" / "ped_crossing_nearside.yaml"
# what on_tick may take while a request is out: half the 100 ms camera frame (it takes ~0.01-5 ms on a
# loaded 2-core machine); a tick that waited for the endpoint would take its delay, 1 s or more here
TICK_BUDGET_MS = 50.0
SIDE_WORDS = {"left": "to your left", "right": "to your right", "ahead": "straight ahead", "unknown": ""}
SIDE_ZH = {"left": "左侧", "right": "右侧", "ahead": "正前方", "unknown": ""}


class ChatServer:
    """An OpenAI-compatible ``/v1/chat/completions`` on 127.0.0.1 in a thread. ``mode``: ``good``
    (a correct sentence, worded unlike the template), ``slow`` (answers after ``delay`` s),
    ``nonsense`` (the range tripled), ``error`` (HTTP 500)."""

    def __init__(self, mode: str = "good", delay: float = 1.0) -> None:
        self.mode, self.delay, self.requests = mode, delay, []
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args) -> None:
                pass

            def do_POST(self) -> None:  # noqa: N802
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                server.requests.append((self.path, body, self.headers.get("Authorization")))
                if self.path != "/v1/chat/completions":
                    return self.send_error(404)
                if server.mode == "error":
                    return self.send_error(500)
                if server.mode == "slow":
                    time.sleep(server.delay)
                facts = json.loads(body["messages"][-1]["content"])
                rng = facts["range_m"] * (3 if server.mode == "nonsense" else 1)
                ttc = "" if facts["ttc_s"] is None else f", about {facts['ttc_s']} seconds to impact"
                ttc_zh = "" if facts["ttc_s"] is None else f"，约{facts['ttc_s']}秒后相撞"
                cls_zh = {"pedestrian": "行人", "car": "汽车"}.get(facts["class"], facts["class"])
                content = json.dumps({
                    "en": f"{facts['advice']} - {facts['class']} {SIDE_WORDS[facts['side']]} {rng} metres away{ttc}.",
                    "zh": f"{SIDE_ZH[facts['side']]}{rng}米有{cls_zh}{ttc_zh}，请注意。",
                }, ensure_ascii=False)
                reply = json.dumps({"id": "x", "object": "chat.completion", "model": body["model"],
                                    "choices": [{"index": 0, "finish_reason": "stop",
                                                 "message": {"role": "assistant", "content": content}}]}).encode()
                try:
                    self.send_response(200)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(reply)))
                    self.end_headers()
                    self.wfile.write(reply)
                except OSError:  # the client gave up (timeout)
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def __enter__(self) -> ChatServer:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def closed_port_url() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"http://127.0.0.1:{port}/v1"


def run(sink: NarrationSink) -> tuple[RecordCollector, list[dict], float]:
    """A real closed-loop run (ground-truth detector, not rendered) with ``sink``; its records, the
    narration lines and how long ``on_end`` took (s)."""
    sc = with_detector(load_scenario(SCENARIO), "gt", None)
    collect = RecordCollector()
    end = []

    class Timed:  # measures the sink's on_end
        def on_start(self, info):
            sink.on_start(info)

        def on_tick(self, rec):
            sink.on_tick(rec)

        def on_end(self, summary):
            t0 = time.perf_counter()
            sink.on_end(summary)
            end.append(time.perf_counter() - t0)

    Runner(sc, sinks=[collect, Timed()], render=False).run()
    lines = [json.loads(x) for x in sink.path.read_text(encoding="utf-8").splitlines()]
    return collect, lines, end[0]


def warnings_of(collect: RecordCollector) -> list[tuple[int, int]]:
    return [(r.frame_index, a.track_id) for r in collect.records for a in r.alerts if a.kind in ("fcw", "critical")]


def check_every_alert_once(collect, lines, sink) -> None:
    assert warnings_of(collect), "the scenario raises warnings"
    assert [(x["frame"], x["track_id"]) for x in lines] == warnings_of(collect)
    assert all(x["en"] and x["zh"] for x in lines)
    assert max(sink.on_tick_ms) < TICK_BUDGET_MS, max(sink.on_tick_ms)


def test_templates_on_a_real_run_agree_with_ground_truth(tmp_path):
    sink = NarrationSink(tmp_path / NARRATION_FILE)
    collect, lines, _ = run(sink)
    check_every_alert_once(collect, lines, sink)
    assert {x["source"] for x in lines} == {"template"} and {x["fallback_reason"] for x in lines} == {None}
    assert all(x["truth_actor"] is not None and x["truth_facts"]["class"] == "pedestrian" for x in lines)
    section = narration_section(tmp_path)
    assert section["alerts"] == len(lines) and section["no_truth"] == 0
    assert section["agreement"]["assessment"]["sentences_all_agree"] == 1.0
    assert section["agreement"]["truth"]["all"] == {"class": 1.0, "side": 1.0, "range": 1.0, "ttc": 1.0}
    assert narration_section(tmp_path / "nowhere") is None


def test_chat_endpoint_answers(tmp_path, monkeypatch):
    monkeypatch.setenv("NARRATION_TEST_KEY", "sk-test")
    with ChatServer("good") as server:
        sink = NarrationSink(tmp_path / NARRATION_FILE, NarrationConfig(
            url=server.url, model="tiny", timeout=2.0, key_env="NARRATION_TEST_KEY"))
        collect, lines, _ = run(sink)
    check_every_alert_once(collect, lines, sink)
    assert {x["source"] for x in lines} == {"llm"}, lines
    assert all("metres away" in x["en"] and x["fallback_reason"] is None for x in lines)
    path, body, auth = server.requests[0]
    assert path == "/v1/chat/completions" and body["model"] == "tiny" and body["temperature"] == 0
    assert [m["role"] for m in body["messages"]] == ["system", "user"] and auth == "Bearer sk-test"
    assert "sk-test" not in (tmp_path / NARRATION_FILE).read_text()
    section = narration_section(tmp_path)
    assert section["by_source"] == {"llm": len(lines)}
    assert section["llm_latency_ms"]["max"] < 2000
    assert section["agreement"]["truth"]["all"]["class"] == 1.0


def test_a_stalled_endpoint_times_out_without_delaying_the_tick(tmp_path):
    timeout = 0.3
    with ChatServer("slow", delay=1.5) as server:
        sink = NarrationSink(tmp_path / NARRATION_FILE, NarrationConfig(url=server.url, model="tiny", timeout=timeout))
        collect, lines, on_end_s = run(sink)
    check_every_alert_once(collect, lines, sink)
    assert {(x["source"], x["fallback_reason"]) for x in lines} == {("template", "timeout")}
    assert on_end_s < timeout + 0.2  # the end waits at most the timeout
    assert all(x["latency_ms"] < (timeout + 0.2) * 1e3 for x in lines)
    assert narration_section(tmp_path)["fallback_reasons"] == {"timeout": len(lines)}


def test_a_backlog_of_alerts_on_a_stalled_endpoint(tmp_path):
    """Many alerts at once (a real run's alerting ticks replayed 30 times) on a stalled endpoint with
    two workers: each tick hands its requests over and returns; each alert times out on its own
    deadline, and the end waits at most one timeout."""
    collect, _, _ = run(NarrationSink(tmp_path / "first.jsonl"))
    alerting = [r for r in collect.records if r.alerts]
    timeout = 0.3
    with ChatServer("slow", delay=2.0) as server:
        sink = NarrationSink(tmp_path / NARRATION_FILE, NarrationConfig(url=server.url, model="m", timeout=timeout))
        sink.on_start({})
        for _ in range(30):
            for rec in alerting:
                sink.on_tick(rec)
        t0 = time.perf_counter()
        sink.on_end({})
        on_end_s = time.perf_counter() - t0
    lines = [json.loads(x) for x in sink.path.read_text(encoding="utf-8").splitlines()]
    assert len(lines) == 30 * len(warnings_of(collect)) == sink.lines
    assert {(x["source"], x["fallback_reason"]) for x in lines} == {("template", "timeout")}
    assert max(sink.on_tick_ms) < TICK_BUDGET_MS and on_end_s < timeout + 0.2
    assert len(server.requests) <= 4  # queued requests past their deadline are never sent


def test_nonsense_is_replaced_by_the_template(tmp_path):
    with ChatServer("nonsense") as server:
        sink = NarrationSink(tmp_path / NARRATION_FILE, NarrationConfig(url=server.url, model="tiny", timeout=2.0))
        collect, lines, _ = run(sink)
    check_every_alert_once(collect, lines, sink)
    assert {(x["source"], x["fallback_reason"]) for x in lines} == {("template", "nonsense")}
    assert all(x["en"].startswith(("Brake now", "Be ready")) for x in lines)


def test_an_http_error_and_a_closed_port_fall_back(tmp_path):
    with ChatServer("error") as server:
        sink = NarrationSink(tmp_path / "a" / NARRATION_FILE, NarrationConfig(url=server.url, model="m", timeout=2.0))
        collect, lines, _ = run(sink)
    check_every_alert_once(collect, lines, sink)
    assert {x["fallback_reason"] for x in lines} == {"http 500"}

    sink = NarrationSink(tmp_path / "b" / NARRATION_FILE, NarrationConfig(url=closed_port_url(), model="m", timeout=2.0))
    collect, lines, on_end_s = run(sink)
    check_every_alert_once(collect, lines, sink)
    assert {(x["source"], x["fallback_reason"]) for x in lines} == {("template", "down")}
    assert on_end_s < 1.0


def test_cli_refuses_a_malformed_url_before_running(tmp_path):
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["run", str(SCENARIO), "--out", str(out), "--no-render",
                                   "--narrate-url", "localhost:8000", "--narrate-model", "m"])
    assert res.exit_code == 2 and "--narrate-url" in res.output and not out.exists()
    res = CliRunner().invoke(app, ["run", str(SCENARIO), "--out", str(out), "--no-render",
                                   "--narrate-url", "http://127.0.0.1:9/v1"])
    assert res.exit_code == 2 and "--narrate-model" in res.output and not out.exists()


def test_cli_narrates(tmp_path):
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["run", str(SCENARIO), "--out", str(out), "--no-render", "--detector", "gt", "--narrate"])
    assert res.exit_code == 0, res.output
    assert narration_section(out)["by_source"] == {"template": 2}
