"""Narration: one sentence per alert, in English and Chinese, and the facts a sentence states.

Pure functions (no I/O): ``tools.sinks.narration`` builds the sentences of a run, by template or
from a chat model, and ``tools.scoring.narration`` scores them.

* ``Facts``: what an alert is about -- class, behaviour, side, range (m), TTC (s), level and the
  advice of that level. ``facts_of_alert`` takes them from an ``Alert`` (its class, range, TTC --
  the enhanced TTC risk decided on -- and behaviour) and the track's lateral offset;
  ``truth_facts`` the same from ground truth.
* Side, from the lateral offset y (ego frame, y left): ``ahead`` when |y| <= ``AHEAD_HALF_WIDTH``
  (1.75 m: half a 3.5 m lane, i.e. in the ego's own lane), else ``left`` (y > 0) / ``right``;
  ``unknown`` without a lateral offset.
* ``template(facts, lang)``: the sentence, e.g. "Brake now: a pedestrian crossing ahead at 8.5 m,
  collision in 1.2 s." / "立即刹车：正前方8.5米处有行人横穿，预计1.2秒后碰撞。". Ranges are said to
  0.1 m under 10 m and to the metre from 10 m on, TTCs to 0.1 s; a TTC of "never" (not closing)
  and an unknown side are left out, an ``unknown`` behaviour too. Advice by level: CRITICAL "Brake
  now" / "立即刹车", HIGH "Be ready to brake" / "准备刹车".
* ``extract_facts(sentence, lang)``: the class, side, range and TTC a sentence states (``Stated``;
  a fact said twice with different values is ``AMBIGUOUS``). Template sentences round-trip
  exactly: ``extract_facts(template(f, lang), lang) == said(f)``.
* ``check(stated, truth, tolerances)``: per fact, whether the sentence agrees with ``truth``:
  class and side equal, range within max(1 m, 15 %), TTC within max(0.5 s, 25 %) (a TTC of never
  agrees with no TTC stated); ``None`` where the truth has nothing to check against (no side known).
  A fact the truth has but the sentence leaves out disagrees: a sentence must say it to be right.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass

from lookahead.intent.alerts import BEHAVIOUR_NAMES_ZH, Alert
from lookahead.intent.labels import NEVER, Behaviour, Risk
from lookahead.perception.detections import CLASSES

#: Half-width (m) of the band of lateral offsets that is "ahead": half a 3.5 m lane, the ego's own lane.
AHEAD_HALF_WIDTH = 1.75
#: Below this range (m) a range is said to 0.1 m, from it on to the metre.
FINE_RANGE_BELOW = 10.0
#: A fact a sentence states more than once with different values.
AMBIGUOUS = "ambiguous"
SIDES = ("left", "ahead", "right", "unknown")
LANGS = ("en", "zh")
FACTS_CHECKED = ("class", "side", "range", "ttc")

ADVICE = {
    int(Risk.CRITICAL): ("Brake now", "立即刹车"),
    int(Risk.HIGH): ("Be ready to brake", "准备刹车"),
}
_ADVICE_BELOW = ("Watch out", "注意")

#: Words of each class: the first is the template's; the others are what a sentence may also say.
CLASS_WORDS_EN: dict[str, tuple[str, ...]] = {
    "pedestrian": ("pedestrian", "pedestrians", "person", "people", "walker", "child", "kid", "man", "woman"),
    "cyclist": ("cyclist", "bicyclist", "bicycle", "bike", "cycle", "e-bike"),
    "motorcyclist": ("motorcyclist", "motorcycle", "motorbike", "scooter", "moped", "rider on a motorcycle"),
    "tricycle": ("tricycle", "trike", "three-wheeler"),
    "car": ("car", "sedan", "suv"),
    "truck": ("truck", "lorry"),
    "bus": ("bus", "coach"),
    "animal": ("animal", "dog", "deer", "cow", "cattle"),
    "obstacle": ("obstacle", "cone", "barrier", "debris"),
}
CLASS_WORDS_ZH: dict[str, tuple[str, ...]] = {
    "pedestrian": ("行人", "儿童", "小孩", "路人"),
    "cyclist": ("骑车人", "骑自行车的人", "自行车", "电动自行车"),
    "motorcyclist": ("摩托车手", "摩托车", "骑摩托车的人"),
    "tricycle": ("三轮车",),
    "car": ("汽车", "轿车", "小汽车", "小轿车"),
    "truck": ("卡车", "货车"),
    "bus": ("公交车", "大巴", "客车", "巴士"),
    "animal": ("动物", "狗", "鹿", "牛"),
    "obstacle": ("障碍物", "锥桶", "路障"),
}
#: How a behaviour reads in an English sentence (``unknown`` is left out; others by their name).
BEHAVIOUR_EN = {
    Behaviour.SUDDEN_BRAKE: "braking hard",
    Behaviour.SUDDEN_TURN: "turning suddenly",
    Behaviour.WRONG_WAY: "going the wrong way",
    Behaviour.STATIONARY: "standing still",
    Behaviour.ENTERING_ROAD: "entering the road",
    Behaviour.LOITERING: "loitering",
    Behaviour.WAVING: "waving",
    Behaviour.FALLING: "fallen",
}
SIDE_EN = {"left": "on the left", "ahead": "ahead", "right": "on the right", "unknown": ""}
SIDE_ZH = {"left": "左前方", "ahead": "正前方", "right": "右前方", "unknown": ""}


@dataclass(frozen=True)
class Facts:
    """What one alert is about. ``cls``: class name (``perception.detections.CLASSES``);
    ``behaviour``: ``Behaviour`` name, lower case; ``side``: left / ahead / right / unknown;
    ``range`` (m); ``ttc`` (s, None: not closing); ``level``: ``Risk`` name; ``advice`` (English)."""

    cls: str
    behaviour: str
    side: str
    range: float
    ttc: float | None
    level: str
    advice: str
    lateral: float | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["class"] = d.pop("cls")
        for k in ("range", "ttc", "lateral"):
            if d[k] is not None:
                d[k] = round(float(d[k]), 3)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Facts:
        return cls(cls=d["class"], behaviour=d.get("behaviour", "unknown"), side=d.get("side", "unknown"),
                   range=d.get("range"), ttc=d.get("ttc"), level=d.get("level", "HIGH"),
                   advice=d.get("advice", ""), lateral=d.get("lateral"))


@dataclass(frozen=True)
class Stated:
    """The facts a sentence states: each None (not said), a value, or ``AMBIGUOUS`` (said twice,
    differently)."""

    cls: str | None
    side: str | None
    range: float | str | None
    ttc: float | str | None

    def to_dict(self) -> dict:
        return {"class": self.cls, "side": self.side, "range": self.range, "ttc": self.ttc}


@dataclass(frozen=True)
class Tolerances:
    """How far a stated number may be from the truth and still agree: max(abs, rel * truth)."""

    range_abs: float = 1.0
    range_rel: float = 0.15
    ttc_abs: float = 0.5
    ttc_rel: float = 0.25


# --------------------------------------------------------------------------- facts


def side_of(lateral: float | None) -> str:
    """left / ahead / right from the lateral offset (m, y left); unknown for None or NaN."""
    if lateral is None or not math.isfinite(lateral):
        return "unknown"
    if abs(lateral) <= AHEAD_HALF_WIDTH:
        return "ahead"
    return "left" if lateral > 0 else "right"


def class_name(class_id: int) -> str:
    return CLASSES[class_id] if 0 <= class_id < len(CLASSES) else "obstacle"


def behaviour_name(behaviour: int) -> str:
    try:
        return Behaviour(int(behaviour)).name.lower()
    except ValueError:
        return "unknown"


def level_name(level: int) -> str:
    try:
        return Risk(int(level)).name
    except ValueError:
        return str(level)


def advice_of(level: int, lang: str = "en") -> str:
    en, zh = ADVICE.get(int(level), _ADVICE_BELOW)
    return zh if lang == "zh" else en


def _ttc(ttc: float | None) -> float | None:
    if ttc is None or not math.isfinite(ttc) or ttc >= NEVER:
        return None
    return max(float(ttc), 0.0)


def make_facts(cls: str, behaviour: str, lateral: float | None, range_m: float, ttc: float | None,
               level: int) -> Facts:
    lat = None if lateral is None or not math.isfinite(lateral) else float(lateral)
    return Facts(cls=cls, behaviour=behaviour, side=side_of(lat), range=float(range_m), ttc=_ttc(ttc),
                 level=level_name(level), advice=advice_of(level), lateral=lat)


def facts_of_alert(alert: Alert, lateral: float | None) -> Facts:
    """An alert's facts; ``lateral``: the track's lateral offset (m) that tick, None if unknown."""
    return make_facts(class_name(alert.class_id), behaviour_name(alert.behaviour), lateral, alert.range,
                      alert.ttc, alert.level)


# --------------------------------------------------------------------------- sentences


def said_range(r: float) -> float:
    """The range as a sentence says it: 0.1 m under ``FINE_RANGE_BELOW``, else whole metres."""
    v = round(max(float(r), 0.0), 1)
    return v if v < FINE_RANGE_BELOW else float(round(v))


def said_ttc(t: float | None) -> float | None:
    return None if t is None else round(float(t), 1)


def _num(v: float) -> str:
    return f"{v:.1f}" if v < FINE_RANGE_BELOW else f"{v:.0f}"


def said(facts: Facts) -> Stated:
    """The facts a template sentence states (what ``extract_facts`` reads back from it)."""
    return Stated(cls=facts.cls, side=None if facts.side == "unknown" else facts.side,
                  range=said_range(facts.range), ttc=said_ttc(facts.ttc))


def _behaviour_en(name: str) -> str:
    if name == "unknown":
        return ""
    try:
        return BEHAVIOUR_EN.get(Behaviour[name.upper()], name.replace("_", " "))
    except KeyError:
        return name.replace("_", " ")


def _behaviour_zh(name: str) -> str:
    try:
        b = Behaviour[name.upper()]
    except KeyError:
        return ""
    return "" if b == Behaviour.UNKNOWN else BEHAVIOUR_NAMES_ZH.get(b, "")


def template(facts: Facts, lang: str = "en") -> str:
    """One sentence stating the facts (module docstring)."""
    level = Risk[facts.level] if facts.level in Risk.__members__ else Risk.HIGH
    r = _num(said_range(facts.range))
    t = said_ttc(facts.ttc)
    if lang == "zh":
        word = CLASS_WORDS_ZH.get(facts.cls, (facts.cls,))[0]
        ttc = "" if t is None else f"，预计{t:.1f}秒后碰撞"
        return f"{advice_of(level, 'zh')}：{SIDE_ZH[facts.side]}{r}米处有{word}{_behaviour_zh(facts.behaviour)}{ttc}。"
    word = CLASS_WORDS_EN.get(facts.cls, (facts.cls,))[0]
    article = "an" if word[0] in "aeiou" else "a"
    parts = [f"{article} {word}", _behaviour_en(facts.behaviour), SIDE_EN[facts.side], f"at {r} m"]
    ttc = "" if t is None else f", collision in {t:.1f} s"
    return f"{advice_of(level, 'en')}: {' '.join(p for p in parts if p)}{ttc}."


# --------------------------------------------------------------------------- reading sentences

_NUM = r"(\d+(?:\.\d+)?)"
_RANGE_EN = re.compile(_NUM + r"\s*(?:m|metres|meters|metre|meter)\b(?!\s*/|\s*per\b)", re.IGNORECASE)
_TTC_EN = re.compile(_NUM + r"\s*(?:s|sec|secs|seconds|second)\b", re.IGNORECASE)
_RANGE_ZH = re.compile(_NUM + r"\s*(?:米|公尺|m\b)(?!\s*/|每)")
_TTC_ZH = re.compile(_NUM + r"\s*(?:秒|s\b)")
_SIDE_EN = (
    ("left", re.compile(r"\bleft\b", re.IGNORECASE)),
    ("right", re.compile(r"\bright\b", re.IGNORECASE)),
    ("ahead", re.compile(r"\b(?:ahead|in front)\b", re.IGNORECASE)),
)
_SIDE_ZH = (
    ("left", re.compile(r"左")),
    ("right", re.compile(r"右")),
    ("ahead", re.compile(r"(?<![左右])前方|正前")),
)


def _one(values: list) -> object:
    distinct = sorted(set(values), key=str)
    if not distinct:
        return None
    return distinct[0] if len(distinct) == 1 else AMBIGUOUS


def _classes_en(text: str) -> list[str]:
    found = []
    for cls, words in CLASS_WORDS_EN.items():
        pattern = r"\b(?:" + "|".join(re.escape(w) for w in sorted(words, key=len, reverse=True)) + r")\b"
        if re.search(pattern, text, re.IGNORECASE):
            found.append(cls)
    return found


def _classes_zh(text: str) -> list[str]:
    spans: list[tuple[int, int, str]] = []
    words = sorted(((w, c) for c, ws in CLASS_WORDS_ZH.items() for w in ws), key=lambda x: -len(x[0]))
    for w, c in words:  # longest first; a word inside a longer one already found is not counted again
        for m in re.finditer(re.escape(w), text):
            if not any(s <= m.start() and m.end() <= e for s, e, _ in spans):
                spans.append((m.start(), m.end(), c))
    return [c for _, _, c in spans]


def extract_facts(sentence: str, lang: str = "en") -> Stated:
    """The class, side, range (m) and TTC (s) a sentence states (module docstring)."""
    text = sentence or ""
    if lang == "zh":
        classes, sides, rng, ttc = _classes_zh(text), _SIDE_ZH, _RANGE_ZH, _TTC_ZH
    else:
        classes, sides, rng, ttc = _classes_en(text), _SIDE_EN, _RANGE_EN, _TTC_EN
    side = _one([name for name, p in sides if p.search(text)])
    return Stated(cls=_one(classes), side=side,  # type: ignore[arg-type]
                  range=_one([float(m.group(1)) for m in rng.finditer(text)]),  # type: ignore[arg-type]
                  ttc=_one([float(m.group(1)) for m in ttc.finditer(text)]))  # type: ignore[arg-type]


def one_sentence(text: str, lang: str = "en", max_chars: int = 240) -> bool:
    """Whether ``text`` is one sentence: no line break, at most ``max_chars``, one sentence end at most
    (``.!?`` then a space or the end, in English; ``。！？`` in Chinese)."""
    if not isinstance(text, str) or not text.strip() or "\n" in text.strip() or len(text) > max_chars:
        return False
    ends = re.findall(r"[。！？!?]|\.(?=\s|$)", text.strip()) if lang == "zh" else re.findall(r"[.!?](?=\s|$)", text.strip())
    if len(ends) > 1:
        return False
    return not (len(ends) == 1 and not re.search(r"[。！？.!?]\W*$", text.strip()))


def _near(stated: object, truth: float, abs_tol: float, rel_tol: float) -> bool:
    if not isinstance(stated, float | int):
        return False
    return abs(float(stated) - truth) <= max(abs_tol, rel_tol * abs(truth))


def check(stated: Stated, truth: Facts, tol: Tolerances | None = None) -> dict[str, bool | None]:
    """Per fact (class, side, range, ttc): True agrees, False disagrees (or left out), None nothing
    to check against (the truth's side unknown)."""
    tol = tol or Tolerances()
    out: dict[str, bool | None] = {"class": stated.cls == truth.cls}
    out["side"] = None if truth.side == "unknown" else stated.side == truth.side
    out["range"] = None if truth.range is None else _near(stated.range, truth.range, tol.range_abs, tol.range_rel)
    if truth.ttc is None:
        out["ttc"] = stated.ttc is None
    else:
        out["ttc"] = _near(stated.ttc, truth.ttc, tol.ttc_abs, tol.ttc_rel)
    return out


def consistent(stated: Stated, truth: Facts, tol: Tolerances | None = None) -> bool:
    """Every fact agrees or has nothing to check against."""
    return all(v is not False for v in check(stated, truth, tol).values())
