"""Collision timing under constant accelerations: enhanced TTC and the required deceleration.

Longitudinal only, along the ego's x axis (ISO 8855; m, s, m/s, m/s^2). An object
``r`` m ahead (its nearest face) moves over the ground at ``v_o`` with acceleration
``a_o``; the ego at ``v_e`` with ``a_e``. A body whose acceleration opposes its
velocity stops when its speed reaches zero and stays stopped (a braking car does not
reverse) -- the assumption of the enhanced TTC of FCW standards (ISO 15623, SAE
J2400) and of Euro NCAP's CCRb case. Constant velocities reduce both to the usual
TTC = r / closing speed.

* ``enhanced_ttc``: the first time the gap r + s_o(t) - s_e(t) reaches zero (inf
  if never; 0 at r <= 0). s(t) is each body's displacement, piecewise quadratic
  with a break where it stops, so the gap is quadratic on at most three pieces
  and each piece is solved exactly.
* ``required_decel``: the constant deceleration d >= 0 the ego needs, from now,
  to keep the gap >= 0 (inf at r <= 0). Closing speed v_c = v_e - v_o. Either the
  speeds match while the object still moves -- d = v_c^2 / (2 r) - a_o, with the
  match at t* = 2 r / v_c -- or, when the object stops first (t* beyond its stop
  time), the ego must stop behind its stopping point: d = v_e^2 / (2 (r + s_stop)).
  An object coming towards the ego (v_o < 0) cannot be avoided by braking alone;
  the speed-match formula then reads above any car's capability, as it should.
"""

from __future__ import annotations

import numpy as np


def _stop_time(v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Time (s) at which a body at speed v with acceleration a comes to rest (inf if never)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(v * a < 0.0, -v / a, np.inf)


def _displacement(v: np.ndarray, a: np.ndarray, t: np.ndarray) -> np.ndarray:
    return v * t + 0.5 * a * t * t


def _first_root(c0: np.ndarray, c1: np.ndarray, c2: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Smallest root of c0 + c1 t + c2 t^2 in [lo, hi] (inf where none)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lin = np.where(c1 != 0.0, -c0 / c1, np.inf)
        disc = c1 * c1 - 4.0 * c2 * c0
        sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        r1 = (-c1 - sq) / (2.0 * c2)
        r2 = (-c1 + sq) / (2.0 * c2)
    quad = np.abs(c2) > 1e-12
    cand = np.stack([np.where(quad, r1, lin), np.where(quad, r2, np.inf)])
    ok = (cand >= lo - 1e-12) & (cand <= hi + 1e-12)
    return np.where(ok, cand, np.inf).min(axis=0)


def enhanced_ttc(
    rng: np.ndarray, v_o: np.ndarray, a_o: np.ndarray, v_e: float | np.ndarray, a_e: float | np.ndarray
) -> np.ndarray:
    """Enhanced (constant-acceleration) time to collision (s), (N,); see the module docstring.

    Args:
        rng: range to the object's nearest face (m). v_o, a_o: its ground velocity and
            acceleration along the ego x axis (m/s, m/s^2; NaN acceleration counts as 0).
        v_e, a_e: the ego's speed and longitudinal acceleration.
    """
    r = np.asarray(rng, dtype=np.float64)
    vo = np.asarray(v_o, dtype=np.float64)
    ao = np.nan_to_num(np.asarray(a_o, dtype=np.float64), nan=0.0)
    shape = np.broadcast(r, vo, ao).shape
    r, vo, ao = (np.broadcast_to(x, shape) for x in (r, vo, ao))
    ve = np.broadcast_to(np.asarray(v_e, dtype=np.float64), shape)
    ae = np.broadcast_to(np.nan_to_num(np.asarray(a_e, dtype=np.float64), nan=0.0), shape)
    ts_o, ts_e = _stop_time(vo, ao), _stop_time(ve, ae)
    s_o = np.where(np.isfinite(ts_o), _displacement(vo, ao, np.where(np.isfinite(ts_o), ts_o, 0.0)), 0.0)
    s_e = np.where(np.isfinite(ts_e), _displacement(ve, ae, np.where(np.isfinite(ts_e), ts_e, 0.0)), 0.0)
    bounds = np.sort(np.stack([np.zeros(shape), ts_o, ts_e, np.full(shape, np.inf)]), axis=0)
    out = np.full(shape, np.inf)
    for k in range(3):
        lo, hi = bounds[k], bounds[k + 1]
        mid = np.where(np.isfinite(hi), 0.5 * (lo + hi), lo + 1.0)
        mo, me = mid < ts_o, mid < ts_e  # which bodies still move on this piece
        c0 = r + np.where(mo, 0.0, s_o) - np.where(me, 0.0, s_e)
        c1 = np.where(mo, vo, 0.0) - np.where(me, ve, 0.0)
        c2 = 0.5 * (np.where(mo, ao, 0.0) - np.where(me, ae, 0.0))
        live = hi > lo
        out = np.where(live, np.minimum(out, _first_root(c0, c1, c2, lo, hi)), out)
    out = np.where(r <= 0.0, 0.0, out)
    return np.where(np.isnan(r) | np.isnan(vo) | np.isnan(ve), np.nan, out)


def required_decel(
    rng: np.ndarray, v_o: np.ndarray, a_o: np.ndarray, v_e: float | np.ndarray
) -> np.ndarray:
    """Constant ego deceleration (m/s^2, >= 0) that avoids the collision; see the module docstring.

    Args as ``enhanced_ttc`` (the ego's own current acceleration does not enter: the
    result replaces it). inf at r <= 0, NaN for NaN inputs.
    """
    r = np.asarray(rng, dtype=np.float64)
    vo = np.asarray(v_o, dtype=np.float64)
    ao = np.nan_to_num(np.asarray(a_o, dtype=np.float64), nan=0.0)
    ve = np.asarray(v_e, dtype=np.float64)
    vc = ve - vo
    stops = (vo > 0.0) & (ao < 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_stop = np.where(stops, vo / -ao, np.inf)
        s_stop = np.where(stops, vo * vo / (-2.0 * ao), 0.0)
        d_match = np.where(vc > 0.0, vc * vc / (2.0 * r) - ao, 0.0)
        t_match = np.where(vc > 0.0, 2.0 * r / vc, np.inf)
        d_stop = ve * ve / (2.0 * (r + s_stop))
    d = np.where(stops & (t_match > t_stop), d_stop, d_match)
    d = np.maximum(d, 0.0)
    d = np.where(r <= 0.0, np.inf, d)
    return np.where(np.isnan(r) | np.isnan(vo) | np.isnan(ve), np.nan, d)
