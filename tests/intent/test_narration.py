"""Narration templates, what a sentence states, and the fact check (``intent.narration``)."""

from __future__ import annotations

import itertools
import math

import pytest

from lookahead.intent.alerts import Alert
from lookahead.intent.labels import Behaviour, Risk
from lookahead.intent.narration import (
    AHEAD_HALF_WIDTH,
    AMBIGUOUS,
    CLASS_WORDS_EN,
    LANGS,
    SIDES,
    Facts,
    Stated,
    check,
    consistent,
    extract_facts,
    facts_of_alert,
    make_facts,
    one_sentence,
    said,
    side_of,
    template,
)
from lookahead.perception.detections import CLASSES

LATERAL_OF_SIDE = {"left": 3.0, "ahead": 0.4, "right": -2.5, "unknown": None}


def all_facts():
    for cls, side, level, (rng, ttc) in itertools.product(
        CLASSES, SIDES, (Risk.HIGH, Risk.CRITICAL), ((8.46, 1.23), (23.894, 2.387), (9.96, None), (0.0, 0.0)),
    ):
        yield make_facts(cls, "crossing" if cls == "pedestrian" else "moving", LATERAL_OF_SIDE[side], rng, ttc, level)


@pytest.mark.parametrize("lang", LANGS)
def test_every_template_round_trips_exactly(lang):
    n = 0
    for facts in all_facts():
        sentence = template(facts, lang)
        assert extract_facts(sentence, lang) == said(facts), sentence
        assert one_sentence(sentence, lang), sentence
        assert consistent(extract_facts(sentence, lang), facts), sentence
        n += 1
    assert n == len(CLASSES) * len(SIDES) * 2 * 4


@pytest.mark.parametrize("lang", LANGS)
def test_every_behaviour_reads_without_changing_the_facts(lang):
    for b in Behaviour:
        facts = make_facts("car", b.name.lower(), 0.0, 31.2, 3.04, Risk.HIGH)
        assert extract_facts(template(facts, lang), lang) == said(facts)


def test_template_wording():
    f = make_facts("pedestrian", "crossing", -2.0, 8.46, 1.23, Risk.CRITICAL)
    assert template(f, "en") == "Brake now: a pedestrian crossing on the right at 8.5 m, collision in 1.2 s."
    assert template(f, "zh") == "立即刹车：右前方8.5米处有行人横穿，预计1.2秒后碰撞。"
    g = make_facts("animal", "unknown", None, 23.894, None, Risk.HIGH)
    assert template(g, "en") == "Be ready to brake: an animal at 24 m."
    assert template(g, "zh") == "准备刹车：24米处有动物。"


def test_side_band():
    assert side_of(0.0) == side_of(AHEAD_HALF_WIDTH) == side_of(-AHEAD_HALF_WIDTH) == "ahead"
    assert side_of(AHEAD_HALF_WIDTH + 0.01) == "left" and side_of(-AHEAD_HALF_WIDTH - 0.01) == "right"
    assert side_of(None) == side_of(math.nan) == "unknown"


def test_facts_of_an_alert():
    a = Alert(2.7, 1, "critical", int(Risk.CRITICAL), 0, 15.076, 1.312, int(Behaviour.CROSSING), 4, "", "")
    f = facts_of_alert(a, -2.05)
    assert (f.cls, f.behaviour, f.side, f.level, f.advice) == ("pedestrian", "crossing", "right", "CRITICAL", "Brake now")
    assert f.ttc == pytest.approx(1.312) and Facts.from_dict(f.to_dict()) == f
    never = facts_of_alert(Alert(2.7, 1, "fcw", 3, 4, 12.0, math.inf, 0, 4, "", ""), None)
    assert never.ttc is None and never.side == "unknown"


def test_free_wording_is_read():
    en = extract_facts("Careful: there is a child running in front of you, 7 metres away, impact in about 1.5 seconds!")
    assert en == Stated("pedestrian", "ahead", 7.0, 1.5)
    zh = extract_facts("注意！左侧12米有一辆小汽车，约2.0秒后可能相撞。", "zh")
    assert zh == Stated("car", "left", 12.0, 2.0)
    assert extract_facts("A car and a truck ahead at 10 m.").cls == AMBIGUOUS
    assert extract_facts("A car at 10 m, then 12 m.").range == AMBIGUOUS
    assert extract_facts("A car moving at 3 m/s, 10 m ahead.").range == 10.0  # a speed is no range


def test_check_tolerances():
    truth = make_facts("pedestrian", "crossing", -2.0, 20.0, 2.0, Risk.HIGH)
    assert check(Stated("pedestrian", "right", 22.9, 2.5), truth) == {"class": True, "side": True, "range": True, "ttc": True}
    assert check(Stated("cyclist", "left", 23.1, 2.51), truth) == {"class": False, "side": False, "range": False, "ttc": False}
    near = make_facts("pedestrian", "crossing", None, 4.0, 1.0, Risk.CRITICAL)  # 1 m and 0.5 s floors; side unknown
    assert check(Stated("pedestrian", None, 5.0, 1.5), near) == {"class": True, "side": None, "range": True, "ttc": True}
    assert check(Stated("pedestrian", None, None, None), near)["range"] is False  # left out: not right
    never = make_facts("car", "stopped", 0.0, 30.0, None, Risk.HIGH)
    assert check(Stated("car", "ahead", 30.0, None), never)["ttc"] is True
    assert check(Stated("car", "ahead", 30.0, 3.0), never)["ttc"] is False


def test_one_sentence():
    assert one_sentence("Brake now: a car ahead at 8.5 m, collision in 1.2 s.")
    assert not one_sentence("Brake now. A car is ahead.")
    assert not one_sentence("Brake now\nA car")
    assert not one_sentence("立即刹车。前方有车。", "zh")
    assert one_sentence("立即刹车：正前方8.5米处有汽车。", "zh")
    assert not one_sentence("")


def test_class_words_cover_every_class():
    assert set(CLASSES) <= set(CLASS_WORDS_EN)
