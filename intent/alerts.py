"""Alerts: forward-collision warning at HIGH, critical at CRITICAL, debounced with hysteresis.

Per track, an alert *level* (none, HIGH, CRITICAL) follows the track's risk:
it rises to a level after the risk has reached it on ``on_frames`` consecutive
frames (CRITICAL rises at once by default), and falls back only after the risk
has stayed below it for ``off_frames`` frames — so alerts neither flicker nor
hang on. Every change of level is an ``Alert`` event that says which object,
when, and why (range, TTC, behaviour), in English or Chinese.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from lookahead.intent.labels import (
    BEHAVIOUR_NAMES,
    LABEL_NAMES,
    LABEL_NAMES_ZH,
    NEVER,
    Assessment,
    Behaviour,
    Label,
    Risk,
)

RISK_NAMES_ZH = {Risk.SAFE: "安全", Risk.LOW: "低风险", Risk.MEDIUM: "中风险", Risk.HIGH: "高风险", Risk.CRITICAL: "极高风险"}
BEHAVIOUR_NAMES_ZH = {
    Behaviour.UNKNOWN: "未知", Behaviour.STANDING: "站立", Behaviour.WALKING: "行走", Behaviour.RUNNING: "奔跑",
    Behaviour.CROSSING: "横穿", Behaviour.STOPPED: "停止", Behaviour.MOVING: "行驶", Behaviour.SPEEDING: "超速",
    Behaviour.SUDDEN_BRAKE: "急刹", Behaviour.SUDDEN_TURN: "急转", Behaviour.WRONG_WAY: "逆行",
    Behaviour.STATIONARY: "静止", Behaviour.ENTERING_ROAD: "闯入道路", Behaviour.LOITERING: "徘徊",
    Behaviour.WAVING: "挥手", Behaviour.FALLING: "摔倒",
}


class AlertConfig(BaseModel):
    """Debounce and hysteresis, in camera frames."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    on_frames_high: int = Field(2, ge=1, description="frames at >= HIGH before a forward-collision warning")
    on_frames_critical: int = Field(1, ge=1, description="frames at CRITICAL before a critical alert")
    off_frames: int = Field(3, ge=1, description="frames below the active level before it falls back")
    forget_frames: int = Field(10, ge=1, description="a track unseen this long loses its alert state silently")


@dataclass
class Alert:
    """An alert event: ``kind`` is ``fcw`` (rose to HIGH), ``critical`` (rose to
    CRITICAL) or ``clear`` (fell below HIGH); ``level`` is the new alert level; ``ttc``
    the enhanced (constant-acceleration) TTC risk decided on (s)."""

    t: float
    track_id: int
    kind: str
    level: int
    class_id: int
    range: float
    ttc: float
    behaviour: int
    label: int
    reason: str
    reason_zh: str

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["level_name"] = Risk(self.level).name
        d["t"] = round(self.t, 4)
        d["range"] = round(self.range, 3)
        d["ttc"] = round(min(self.ttc, NEVER), 3)
        return d


def reason_text(range_m: float, ttc: float, behaviour: int, label: int, level: int) -> tuple[str, str]:
    """Why, in English and Chinese."""
    ttc_en = "no closing" if not np.isfinite(ttc) or ttc >= NEVER else f"TTC {ttc:.1f} s"
    ttc_zh = "未接近" if not np.isfinite(ttc) or ttc >= NEVER else f"碰撞时间 {ttc:.1f} 秒"
    b = Behaviour(behaviour)
    lab = Label(label)
    en = f"{Risk(level).name}: {LABEL_NAMES[lab]}, {BEHAVIOUR_NAMES[b]}, range {range_m:.1f} m, {ttc_en}"
    zh = f"{RISK_NAMES_ZH[Risk(level)]}：{LABEL_NAMES_ZH[lab]}，{BEHAVIOUR_NAMES_ZH[b]}，距离 {range_m:.1f} 米，{ttc_zh}"
    return en, zh


@dataclass
class _TrackAlertState:
    level: int = 0  # 0 = none, else Risk.HIGH or Risk.CRITICAL
    up_count: dict = field(default_factory=lambda: {Risk.HIGH: 0, Risk.CRITICAL: 0})
    below: int = 0
    unseen: int = 0


class AlertManager:
    """Turns per-frame track assessments into debounced alert events."""

    def __init__(self, config: AlertConfig | None = None) -> None:
        self.config = config or AlertConfig()
        self.states: dict[int, _TrackAlertState] = {}

    def hand_over(self, old: int, new: int) -> None:
        """Object ``old`` goes on as track ``new`` (cooperative fusion: an object only others saw
        is now the ego's own track): its alert state moves to ``new``, so the alert neither
        restarts its debounce nor is raised again; ``new``'s own state stays if it is higher."""
        st = self.states.pop(int(old), None)
        if st is None:
            return
        mine = self.states.get(int(new))
        if mine is None or mine.level < st.level:
            st.unseen = 0
            self.states[int(new)] = st

    def active(self) -> dict[int, int]:
        """Track id -> current alert level, for tracks seen this frame with an alert on."""
        return {k: s.level for k, s in self.states.items() if s.level and s.unseen == 0}

    def update(
        self, t: float, track_ids: np.ndarray, class_id: np.ndarray, range_m: np.ndarray, a: Assessment
    ) -> list[Alert]:
        """Advance one frame; returns the alert events of this frame."""
        cfg = self.config
        events: list[Alert] = []
        seen = set()
        ttc = a.ttc if a.ettc is None else a.ettc  # the TTC risk decided on (enhanced when known)
        for i, tid in enumerate(np.asarray(track_ids).tolist()):
            seen.add(tid)
            st = self.states.setdefault(tid, _TrackAlertState())
            st.unseen = 0
            risk = int(a.risk[i]) if a.label[i] != Label.INITIALIZING else int(Risk.SAFE)
            for lvl in (Risk.HIGH, Risk.CRITICAL):
                st.up_count[lvl] = st.up_count[lvl] + 1 if risk >= lvl else 0
            new = st.level
            if st.up_count[Risk.CRITICAL] >= cfg.on_frames_critical:
                new = max(new, int(Risk.CRITICAL))
            elif st.up_count[Risk.HIGH] >= cfg.on_frames_high:
                new = max(new, int(Risk.HIGH))
            if st.level and risk < st.level:
                st.below += 1
                if st.below >= cfg.off_frames:
                    new = int(Risk.HIGH) if risk >= Risk.HIGH else 0
                    st.below = 0
            else:
                st.below = 0
            if new != st.level:
                kind = "critical" if new == Risk.CRITICAL else "fcw" if new == Risk.HIGH else "clear"
                if kind == "fcw" and st.level == Risk.CRITICAL:
                    kind = "downgrade"
                lvl_for_text = new if new else risk
                en, zh = reason_text(float(range_m[i]), float(ttc[i]), int(a.behaviour[i]), int(a.label[i]), lvl_for_text)
                events.append(Alert(t, int(tid), kind, int(new), int(class_id[i]), float(range_m[i]),
                                    float(ttc[i]), int(a.behaviour[i]), int(a.label[i]), en, zh))
                st.level = new
        for tid in list(self.states):  # tracks gone for good: their alerts clear silently
            if tid not in seen:
                st = self.states[tid]
                st.unseen += 1
                if st.unseen >= cfg.forget_frames:
                    del self.states[tid]
        return events
