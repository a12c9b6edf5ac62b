"""``NarrationSink``: one sentence per alert, in English and Chinese, into ``RUN_DIR/narration.jsonl``.

Per alert event that raises a warning (kind ``fcw`` or ``critical``, level >= HIGH; a
``downgrade`` or ``clear`` warns of nothing new) ``on_tick`` takes the alert's facts
(``intent.narration.Facts``: class, behaviour, side from the track's lateral offset, range, TTC,
level, advice), the same facts from ground truth, and the template sentences. That is all it does
on the tick thread unless a chat endpoint is configured; then it also hands a request to a small
thread pool (``NarrationConfig.workers``) and returns: ``on_tick`` never waits for the network.

The request (OpenAI-compatible): ``POST {url}/chat/completions`` with ``{"model", "messages":
[system, user], "max_tokens", "temperature": 0}``; the user message holds the facts as JSON, the
system message asks for ``{"en": ..., "zh": ...}``, one sentence each, stating class, side, range
and TTC as given. ``Authorization: Bearer $KEY`` when ``key_env`` names a set environment variable
(the key itself is never logged nor written). The model's sentences are used only when the reply
parses, each is one sentence, and every fact they state agrees with the tick's facts
(``intent.narration.check``: class and side equal, range within max(1 m, 15 %), TTC within
max(0.5 s, 25 %)); otherwise the template is kept and ``fallback_reason`` says why: ``timeout``
(no answer within ``timeout`` s of the tick), ``down`` (connection refused, unreachable, reset),
``http <code>`` or ``nonsense``.

Lines are written by the tick thread in alert order: at each ``on_tick`` the requests at the head
of the queue that are answered or past their deadline are written; ``on_end`` waits for the rest
at most until their deadlines (so at most ``timeout`` s) and writes the template for any still
unanswered. Every alert gets exactly one line.

``narration.jsonl``, one line per narrated alert::

    {"t", "frame", "track_id", "kind", "level", "facts": Facts.to_dict() (the tick's),
     "truth_actor": GT actor id or null, "truth_facts": Facts.to_dict() from ground truth or null,
     "en", "zh", "source": "template" | "llm", "fallback_reason": null | "timeout" | "down" |
     "nonsense" | "http <code>", "latency_ms": request time (null without an endpoint)}

Ground truth: an own track is the actor its box matches that frame as scoring matches tracks
(as ``tools.scoring.intent`` does: reported tracks, class-agnostic IoU >= 0.5 of boxes grown to 8 px
with the actors' visible boxes, Hungarian); an object only other cameras see (remote id) is the
actor the cooperative fusion's record names. Truth TTC is the actor's enhanced TTC when known
(the TTC alerts decide on), else its TTC.
"""

from __future__ import annotations

import collections
import json
import logging
import math
import os
import re
import socket
import time
import urllib.error
import urllib.parse
import urllib.request
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lookahead.intent.labels import Risk
from lookahead.intent.narration import (
    Facts,
    behaviour_name,
    consistent,
    extract_facts,
    facts_of_alert,
    make_facts,
    one_sentence,
    said,
    template,
)
from lookahead.perception.cooperative import REMOTE_ID_BASE
from lookahead.sim.groundtruth import truth_ids
from lookahead.sim.records import TickRecord, jsonable
from lookahead.tools.sinks.paths import OutputError

log = logging.getLogger(__name__)

NARRATION_FILE = "narration.jsonl"
NARRATED_KINDS = ("fcw", "critical")
#: A request with less time left before its deadline than this (s) is not sent: it could only time
#: out (no chat model answers that fast) and would load the endpoint, e.g. a backlog behind a stall.
MIN_REQUEST_S = 0.05
#: The scorer's track-to-truth rule (``tools.scoring.matching``: IoU >= 0.5 of visible boxes grown to
#: 8 px), through ``sim.groundtruth.truth_ids``; its constants here because sinks may not import scoring.
IOU_THRESHOLD = 0.5
MIN_MATCH_SIZE_PX = 8.0
_REPORTED = (1, 2)  # TrackState CONFIRMED, LOST: the tracks scoring reports

SYSTEM_PROMPT = (
    "You are the voice of a driver-assistance system. You get the facts of one hazard as JSON. "
    "Write exactly one short sentence for the driver in English and one in Simplified Chinese. "
    "Each sentence states the advice, the object's class, its side (left, ahead or right; leave it "
    "out when unknown), its range in metres and its time to collision in seconds (leave it out when "
    "null), with the numbers exactly as given. Reply with JSON only: {\"en\": \"...\", \"zh\": \"...\"}."
)


class NarrationError(ValueError):
    """A narration setting that cannot work (a malformed URL); ``str()`` is one line."""


@dataclass(frozen=True)
class NarrationConfig:
    """``url``: the endpoint's base URL (``.../v1``; ``/chat/completions`` is appended unless it
    ends so), None for templates only; ``model``: the model name; ``timeout`` (s) from the tick;
    ``key_env``: the environment variable holding an API key (optional)."""

    url: str | None = None
    model: str | None = None
    timeout: float = 2.0
    key_env: str | None = None
    max_tokens: int = 200
    workers: int = 2


def check_url(url: str) -> str:
    """The chat completions URL of ``url`` (NarrationError when it is not an http(s) URL)."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise NarrationError(f"--narrate-url {url!r}: an http:// or https:// URL expected, e.g. http://127.0.0.1:8000/v1")
    try:
        parts.port  # noqa: B018 (raises on a bad port)
    except ValueError as e:
        raise NarrationError(f"--narrate-url {url!r}: {e}") from None
    base = url.rstrip("/")
    return base if base.endswith("/chat/completions") else base + "/chat/completions"


@dataclass
class Outcome:
    en: str
    zh: str
    source: str
    reason: str | None
    latency_ms: float | None


def prompt_facts(facts: Facts) -> dict:
    """The facts as the model is given them (numbers as a sentence says them)."""
    s = said(facts)
    return {"class": facts.cls, "behaviour": facts.behaviour, "side": facts.side, "range_m": s.range,
            "ttc_s": s.ttc, "level": facts.level, "advice": facts.advice}


def parse_reply(body: bytes) -> tuple[str, str]:
    """The ``en`` and ``zh`` sentences of a chat completion's body (ValueError if there are none)."""
    content = json.loads(body)["choices"][0]["message"]["content"]
    if not isinstance(content, str):
        raise ValueError("no text content")
    m = re.search(r"\{.*\}", content, re.DOTALL)
    if m is None:
        raise ValueError("no JSON object in the reply")
    obj = json.loads(m.group(0))
    en, zh = obj.get("en"), obj.get("zh")
    if not isinstance(en, str) or not isinstance(zh, str):
        raise ValueError("en / zh missing")
    return en.strip(), zh.strip()


def acceptable(en: str, zh: str, facts: Facts) -> bool:
    """One sentence each, every fact stated and consistent with ``facts``."""
    return (one_sentence(en, "en") and one_sentence(zh, "zh")
            and consistent(extract_facts(en, "en"), facts) and consistent(extract_facts(zh, "zh"), facts))


def _reason_of(exc: BaseException) -> str:
    if isinstance(exc, urllib.error.HTTPError):
        return f"http {exc.code}"
    if isinstance(exc, urllib.error.URLError):
        exc = exc.reason if isinstance(exc.reason, BaseException) else exc
    if isinstance(exc, TimeoutError | socket.timeout):
        return "timeout"
    return "down"


class ChatClient:
    """One OpenAI-compatible chat completions endpoint (stdlib ``urllib``; no retries)."""

    def __init__(self, url: str, model: str, timeout: float = 2.0, api_key: str | None = None,
                 max_tokens: int = 200) -> None:
        self.endpoint = check_url(url)
        self.model = model
        self.timeout = float(timeout)
        self._key = api_key
        self.max_tokens = max_tokens

    def __repr__(self) -> str:  # never the key
        return f"ChatClient({self.endpoint!r}, model={self.model!r}, timeout={self.timeout})"

    def body(self, facts: Facts) -> dict:
        return {
            "model": self.model,
            "messages": [{"role": "system", "content": SYSTEM_PROMPT},
                         {"role": "user", "content": json.dumps(prompt_facts(facts), ensure_ascii=False)}],
            "max_tokens": self.max_tokens,
            "temperature": 0,
        }

    def narrate(self, facts: Facts, fallback: tuple[str, str], submitted: float, deadline: float) -> Outcome:
        """The model's sentences, or ``fallback`` with the reason (runs on a worker thread)."""
        left = deadline - time.monotonic()
        if left < MIN_REQUEST_S:
            return Outcome(*fallback, "template", "timeout", (time.monotonic() - submitted) * 1e3)
        headers = {"Content-Type": "application/json"}
        if self._key:
            headers["Authorization"] = f"Bearer {self._key}"
        req = urllib.request.Request(self.endpoint, data=json.dumps(self.body(facts)).encode(), headers=headers,
                                     method="POST")
        try:
            with urllib.request.urlopen(req, timeout=left) as resp:  # noqa: S310 (http(s) checked)
                raw = resp.read()
        except Exception as e:  # noqa: BLE001 (every failure falls back to the template)
            return Outcome(*fallback, "template", _reason_of(e), (time.monotonic() - submitted) * 1e3)
        latency = (time.monotonic() - submitted) * 1e3
        if time.monotonic() > deadline:
            return Outcome(*fallback, "template", "timeout", latency)
        try:
            en, zh = parse_reply(raw)
        except (ValueError, KeyError, IndexError, TypeError):
            return Outcome(*fallback, "template", "nonsense", latency)
        if not acceptable(en, zh, facts):
            return Outcome(*fallback, "template", "nonsense", latency)
        return Outcome(en, zh, "llm", None, latency)


# --------------------------------------------------------------------------- facts of a tick


def _row(ids, tid: int) -> int | None:
    hit = np.flatnonzero(np.asarray(ids, dtype=np.int64).reshape(-1) == tid)
    return int(hit[0]) if len(hit) else None


def alert_lateral(record: TickRecord, tid: int) -> float | None:
    """The lateral offset (m) of the alert's object that tick: its track's estimate, or for a remote
    id the fused object's centre; None when unknown."""
    if tid < REMOTE_ID_BASE and record.tracks is not None and record.estimates is not None:
        i = _row(record.tracks.track_id, tid)
        if i is not None and i < len(record.estimates.lateral):
            return float(record.estimates.lateral[i])
    fused = (record.cooperative or {}).get("fused") or {}
    i = _row(fused.get("id", []), tid) if len(fused.get("id", [])) else None
    if i is not None:
        xy = np.asarray(fused.get("xy"), dtype=np.float64).reshape(-1, 2)
        if i < len(xy):
            return float(xy[i, 1])
    return None


def truth_actor(record: TickRecord, tid: int) -> int | None:
    """The ground-truth actor of track ``tid`` that frame (module docstring), None if none."""
    gt = record.ground_truth
    fused = (record.cooperative or {}).get("fused") or {}
    if len(fused.get("id", [])):
        i = _row(fused["id"], tid)
        truth = list(np.asarray(fused.get("truth", []), dtype=np.int64).reshape(-1))
        if i is not None and i < len(truth) and truth[i] >= 0 and tid >= REMOTE_ID_BASE:
            return int(truth[i])
    tr = record.tracks
    if tr is None or not len(tr.track_id) or not len(gt):
        return None
    reported = np.isin(tr.state, _REPORTED)
    i = _row(tr.track_id[reported], tid)
    if i is None:
        return None
    actor = truth_ids(tr.xyxy[reported], gt, record.frame.camera, IOU_THRESHOLD, visible=True,
                      min_size=MIN_MATCH_SIZE_PX)[i]
    return int(actor) if actor >= 0 else None


def truth_facts(record: TickRecord, actor: int | None) -> Facts | None:
    """The facts of ground-truth ``actor`` that frame (None if it is not in the frame's truth)."""
    if actor is None:
        return None
    gt = record.ground_truth
    i = _row(gt.actor_id, actor)
    if i is None:
        return None
    ttc = float(gt.ettc[i]) if gt.ettc is not None else float(gt.ttc[i])
    return make_facts(str(gt.cls[i]), behaviour_name(int(gt.behaviour[i])), float(gt.lateral[i]),
                      float(gt.range[i]), ttc, int(gt.risk[i]))


# --------------------------------------------------------------------------- the sink


@dataclass
class _Pending:
    line: dict
    fallback: tuple[str, str]
    submitted: float
    deadline: float
    future: Future | None


class NarrationSink:
    """A sink narrating every warning (module docstring). ``path``: the ``narration.jsonl`` to write."""

    def __init__(self, path: Path, config: NarrationConfig | None = None) -> None:
        self.path = Path(path)
        self.config = config or NarrationConfig()
        if self.path.is_dir():
            raise OutputError(f"{self.path}: is a directory, cannot write the narration")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.path.exists() and not os.access(self.path, os.W_OK):
            raise OutputError(f"{self.path}: not writable")
        if not os.access(self.path.parent, os.W_OK):
            raise OutputError(f"{self.path.parent}: not writable")
        self.client: ChatClient | None = None
        if self.config.url:
            if not self.config.model:
                raise NarrationError("--narrate-url needs --narrate-model")
            key = os.environ.get(self.config.key_env) if self.config.key_env else None
            self.client = ChatClient(self.config.url, self.config.model, self.config.timeout, key,
                                     self.config.max_tokens)
        self._pool: ThreadPoolExecutor | None = None
        self._queue: collections.deque[_Pending] = collections.deque()
        self._file = None
        self.on_tick_ms: list[float] = []  # time each on_tick took (ms), for tests and benchmarks
        self.lines = 0

    def on_start(self, info: dict) -> None:
        self._file = self.path.open("w", encoding="utf-8")
        if self.client is not None:
            self._pool = ThreadPoolExecutor(max_workers=max(1, self.config.workers), thread_name_prefix="narration")
            for _ in range(max(1, self.config.workers)):  # start the workers now, not on the first alert's tick
                self._pool.submit(time.sleep, 0.01)

    def on_tick(self, record: TickRecord) -> None:
        t0 = time.perf_counter()
        for alert in record.alerts:
            if getattr(alert, "kind", None) not in NARRATED_KINDS or alert.level < Risk.HIGH:
                continue
            self._narrate(record, alert)
        self._drain(block=False)
        self.on_tick_ms.append((time.perf_counter() - t0) * 1e3)

    def on_end(self, summary: dict) -> None:
        self._drain(block=True)
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None
        if self._file is not None:
            self._file.close()
            self._file = None

    # ------------------------------------------------------------------ internals

    def _narrate(self, record: TickRecord, alert) -> None:
        tid = int(alert.track_id)
        facts = facts_of_alert(alert, alert_lateral(record, tid))
        actor = truth_actor(record, tid)
        truth = truth_facts(record, actor)
        fallback = (template(facts, "en"), template(facts, "zh"))
        line = {"t": round(float(alert.t), 4), "frame": int(record.frame_index), "track_id": tid, "kind": alert.kind,
                "level": facts.level, "facts": facts.to_dict(), "truth_actor": actor,
                "truth_facts": None if truth is None else truth.to_dict()}
        now = time.monotonic()
        future = None
        if self.client is not None and self._pool is not None:
            future = self._pool.submit(self.client.narrate, facts, fallback, now, now + self.config.timeout)
        self._queue.append(_Pending(line, fallback, now, now + self.config.timeout, future))

    def _drain(self, block: bool) -> None:
        while self._queue:
            p = self._queue[0]
            if p.future is None:
                out = Outcome(*p.fallback, "template", None, None)
            else:
                left = p.deadline - time.monotonic()
                if p.future.done() or (block and left > 0):
                    try:
                        out = p.future.result(timeout=max(left, 0.0) + 0.05 if block else 0)
                    except FutureTimeout:
                        p.future.cancel()
                        out = Outcome(*p.fallback, "template", "timeout", (time.monotonic() - p.submitted) * 1e3)
                    except Exception as e:  # noqa: BLE001 (a bug in a worker: the template, said why)
                        log.warning("narration request failed: %s", e)
                        out = Outcome(*p.fallback, "template", "down", (time.monotonic() - p.submitted) * 1e3)
                elif left <= 0:
                    p.future.cancel()
                    out = Outcome(*p.fallback, "template", "timeout", (time.monotonic() - p.submitted) * 1e3)
                else:
                    return  # the head is still waiting: later lines wait for it (alert order)
            self._queue.popleft()
            self._write(p.line, out)

    def _write(self, line: dict, out: Outcome) -> None:
        latency = None if out.latency_ms is None or not math.isfinite(out.latency_ms) else round(out.latency_ms, 2)
        full = {**line, "en": out.en, "zh": out.zh, "source": out.source, "fallback_reason": out.reason,
                "latency_ms": latency}
        self._file.write(json.dumps(jsonable(full), ensure_ascii=False) + "\n")
        self._file.flush()
        self.lines += 1
