"""Single-frame range measurement: where a box puts its object, from one camera.

The measurement model of the range estimator: a box (xyxy px) and its class give
the range of the object's nearest face, its lateral offset and half-width, and
their covariance -- no memory, no motion. ``perception.estimator`` runs one motion
filter per track on these measurements.

Frames and units
----------------
Ego frame (ISO 8855): origin at the centre of the front bumper on the ground,
x forward, y left, z up. m, rad. Pixels through ``CameraModel``
(``mount`` m = (m_x, m_y, m_z) in the ego frame). Boxes are float xyxy px.
``range`` is the ego-frame x of the object's *nearest* point (its visible
face), ``lateral`` the y of its centre, ``half_width`` half its y extent --
the definitions the ground truth uses (``sim.groundtruth``).

One frame: range from a box (``BoxRanger.measure``, vectorised)
-----------------------------------------------------------------
Let u_c = (x1 + x2) / 2, d(u, v) the ego-frame ray of a pixel
(``camera.pixel_rays``) and s(v) = d_z / d_x its slope in column u_c.

1. Ground contact. The lowest image point of an object standing on a flat
   road is where it touches the road (a vehicle's wheels, see step 6), so
   the bottom-centre pixel (u_c, y2) back-projected onto z = 0
   (``camera.ground_points``) gives x_g. Its std is sigma_g = |dx_g/dv| *
   sigma_v with sigma_v^2 = sigma_px^2 + (k h_px)^2 + (f_y sigma_pitch)^2
   (fixed pixel noise, edge jitter proportional to the box height h_px --
   ``edge_sigma_rel`` 0.05, the ``gt`` detector's default ``box_sigma`` --
   road slope / pitching); dx_g/dv ~ (x_g - m_x)^2 / (f_y m_z), so sigma_g
   grows as r^2 / (f h). A contact above the road plane by z (a kerb, a
   pavement: 0.15 m in the simulator) puts x_g too far by z (x_g - m_x) / m_z;
   the class's ``contact_height_sigma`` (pedestrians 0.1 m) adds that spread
   to sigma_g, so at range the height cue weighs more for classes found on
   pavements. A ground map (``perception.ground_map``, ``measure(ground=)``) removes
   the bias where it knows the ground: the ray meets the plane of the surface
   it hits first (a pavement's top) instead of z = 0.
2. Height prior H +- sigma_H of the class. A vertical face at x whose foot
   and top project to rows y2 and y1 obeys H = (x - m_x) (s(y1) - s(y2)), so
   x_h = m_x + H / ds -- the exact, pitch-aware form of r_cam ~ f_y H / h_px.
   sigma_h^2 = (x_c sigma_H / H)^2 + (x_c sigma_ds / ds)^2, x_c = x_h - m_x.
   ``measure(height=, height_sigma=)`` replaces the class prior by an object's own
   height where known (a track's learned height, ``perception.estimator``), here
   and in steps 4 and 6. Each box with both cues also gives the height evidence
   ``height_ground`` = (x_g at the face - m_x) ds, relative std ``height_rel_sigma``
   from the box's noise only (not ``contact_height_sigma``: a contact's height is
   one object's, the same every frame).
   Width prior W +- sigma_W (classes with ``width_cue``: cars, trucks, buses).
   A vehicle seen end-on (|cos psi| >= ``width_cue_min_cos``, psi as in step
   6) whose end face spans the camera's column (t_r < 0 < t_l, t = d_y/d_x of
   the rays through the bottom corners) shows no side face, so the box width
   is W at the face: x_w = m_x + W / (t_l - t_r), sigma_w^2 = (x_c sigma_W /
   W)^2 + (x_c sigma_dt / dt)^2. Its noise comes from the two vertical edges,
   independent of the horizontal ones the other cues share: for a car 20 m
   ahead it cuts the single-frame range error by about a sixth.
3. Fusion. Ground and height cues both move with y2: their errors covary by
   c = (dx_g/dy2)(dx_h/dy2)(k h_px)^2. Their best linear unbiased combination
   has weights (sigma_h^2 - c, sigma_g^2 - c) / (sigma_g^2 + sigma_h^2 - 2c)
   and variance (sigma_g^2 sigma_h^2 - c^2) / (sigma_g^2 + sigma_h^2 - 2c)
   (c capped at the better cue's variance, so no weight is negative; ignoring
   c made the fused range worse than the ground cue alone at 10 m once that is
   precise). The width cue is independent: inverse-variance weighting.
4. Truncation. An edge within ``edge_margin_px`` of the image border is cut;
   a side or bottom edge also within ``edge_cut_sigmas`` edge-noise stds
   (``edge_sigma_rel`` x the box size) of it, as a truncated box's noisy edge
   lands that far inside (not the top edge: a box cut at both ends would keep
   no range cue but the bound). A box cut at the top has no height: ground
   contact only. A box cut at the image bottom has no
   contact point: its top ray meets the plane z = H at x_t = m_x +
   (H - m_z) / s(y1) (std from sigma_H and the top edge), and its foot is
   below the image, so x <= U = the ground x of the bottom image row (and
   x <= m_x + (H + 2 sigma_H) / ds_visible). The estimate is the mean and
   std of N(x_t, sigma_t^2) truncated to [min(0, U), U] (uniform on it when
   x_t is undefined, e.g. H <= m_z). Cut at both ends: the uniform only.
   (``perception.estimator`` runs a filter on such a box's bearing only,
   bounded by x_max and by the visible point being in front of the camera:
   ``Measurement.bearing_depth``.)
5. Lateral: the bottom-centre ray at the fused contact x, y = m_y + (x - m_x) d_y/d_x;
   the rays through the two bottom corners give the y extent and half_width.
   A box cut at the left / right image edge: the visible edge plus the class
   half-width prior. Vehicles seen end-on (as for the width cue) have a
   W x L footprint (class priors ``width``, ``length``) behind the face at x:
   for one wholly to one side of the camera's column the box's *outer* edge
   is the end face's outer corner, exact, while its inner edge is the far
   end's inner corner, L deeper -- taken at the face's depth it made a car
   3 m aside 1.3 m half-wide instead of 0.9 at 10 m (1.5 m at 5 m), its
   inner edge 0.5-0.7 m nearer the ego's path: cars parked at the kerb
   looked in path. So y = (outer edge at x) -/+ W/2, half_width = W/2; an end face
   spanning the column gives both edges at x; a box cut on the side the
   vehicle lies on shows only the inner edge, at depth x + L (std from
   sigma_L). Measurement covariance: sigma_y^2 = (t sigma_x)^2 + ((x - m_x)
   sigma_u / f_x)^2 + floor^2 (+ prior terms), cov_xy = t sigma_x^2, t the
   slope d y / d x of the ray or edge used.
6. Nearest face (done per cue before the fusion of step 3). ``range`` is the
   nearest point's x, but the box bottom shows the ground contact: a car seen
   from behind touches the road with its rear wheels, ``contact_offset``
   (its rear overhang, 0.95 m) behind its bumper; a cyclist's wheel touches
   about a wheel radius behind its front; a pedestrian's feet are its nearest
   point (0). Seen side-on the offset is ``contact_offset_side``; in between
   off = contact_offset |cos psi| + contact_offset_side |sin psi|, psi the
   heading from the filter's ground velocity above ``heading_min_speed``
   once the filter has settled (else the road's direction, psi = 0). Very close, the face's lower edge
   (bumper, ``clearance`` c above the road) is lower in the image than the
   wheels, so the ground cue maps to the face as
   x = max(x_g - off, m_x + (x_g - m_x) (m_z - c) / m_z). The height cue
   assumed foot and top at one x; with the foot off behind a face of height
   H it reads about off m_z / H too far: x = max(x_h - off m_z / H,
   m_x + (x_h - m_x) (H - c) / H). The offset's own uncertainty
   (``contact_offset_rel_sigma`` of the correction) is added to each cue's
   std. Real monocular estimators carry the same per-class priors; the
   values follow typical vehicles (and the simulator's shapes: sedan / SUV
   rear overhang 0.21 L, truck 1.6 m, bus 3.0 m). Boxes cut at the bottom
   keep the top ray's estimate (step 4), which already refers to the face.
7. Cut at a side, nearest face out of view (``side_bound``). A box cut at the
   left or right image edge (not at the bottom) of a class whose footprint is
   long along x (x extent L |cos psi| + W |sin psi| >= ``side_cut_min_extent``,
   1 m: vehicles, cyclists end-on) whose nearest face is wholly beyond the
   border -- the face's span lat -/+ W/2 at the measured x lies beyond y_b,
   where the ray through the box's bottom corner at the border meets that
   depth -- shows only a farther part of the object: a car overtaking
   alongside. A segmentation mask's (or a detector's) box bottom is then the
   lowest pixel at the border, the ground under the visible part, not the
   nearest contact: the measured face x is an upper bound, the object reaching
   up to the extent nearer. The measurement keeps x with sigma widened by the
   extent's uniform std (extent / sqrt(12)); the filter does not settle on it
   (``perception.estimator``). A box clipped at the border whose face is
   partly in view is measured as in steps 1-6.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.perception.estimator_config import EstimatorConfig, PriorTable
from lookahead.perception.ground_map import GroundMap

_DV = 0.5  # px, finite-difference step for d(ray)/dv
MIN_DEPTH = 0.1  # m, nearest camera-forward distance accepted for a measurement


@dataclass
class Measurement:
    """Single-frame position measurements of N boxes (ego frame, m). NaN where undefined.

    ``x`` / ``sigma``: fused range of the nearest face and its std; ``x_ground`` /
    ``sigma_ground``: the ground contact (before the contact offset); ``x_height`` /
    ``sigma_height``: height prior (box height, or the top ray for boxes cut at
    the bottom); ``x_width`` / ``sigma_width``: width prior (vehicles seen
    end-on, at the face; NaN otherwise); ``cov``: (N, 2, 2) covariance
    of (x, lateral). ``x_max``: upper bound of the range of boxes cut at the
    bottom (NaN otherwise). ``side_bound``: cut at a side with a footprint extending
    ``side_cut_min_extent`` or more along x: ``x`` is the visible part's face, an upper
    bound, with ``sigma`` widened by the extent's uniform std (module docstring, step 7).
    ``height_ground``: the height the ground cue gives the box's top, at its nearest face, (x_g_face -
    m_x) ``height_slope`` (NaN without a ground cue or a height); ``height_rel_sigma``: its
    relative std from the box's noise only (the ground cue's without the contact height's part, and the box height's):
    white from frame to frame, where a contact's height above the road is one object's, the same
    every frame (``perception.estimator`` learns it with the height). The lateral as a function of the range: lateral = m_y + (x - m_x)
    ``tan_y`` + ``lateral_offset`` (``tan_y`` the bearing of the edge or ray it comes from,
    ``lateral_offset`` 0 or a half-width prior); ``sigma_bearing`` the bearing's std (rad);
    ``var_y_extra``: lateral variance not due to x or bearing (m^2). ``height_slope``:
    s(y1) - s(y2) of a box cut neither at the top nor at the bottom (NaN otherwise), so
    an object whose face is at x stands (x - m_x) ``height_slope`` m tall. ``bearing_depth``: how
    far behind the face (m, along x) the point whose bearing ``tan_y`` is lies -- the far end's
    inner corner, L, of a vehicle seen end-on whose box is cut on the side it lies on (step 5);
    0 otherwise. That point is in view, so in front of the camera: the face is at least
    x > m_x + ``MIN_DEPTH`` - ``bearing_depth`` (``perception.estimator`` bounds a box cut at the
    bottom by it).
    """

    x: np.ndarray
    sigma: np.ndarray
    x_ground: np.ndarray
    sigma_ground: np.ndarray
    x_height: np.ndarray
    sigma_height: np.ndarray
    x_width: np.ndarray
    sigma_width: np.ndarray
    lateral: np.ndarray
    half_width: np.ndarray
    cov: np.ndarray
    cut_bottom: np.ndarray
    cut_top: np.ndarray
    x_max: np.ndarray
    side_bound: np.ndarray
    tan_y: np.ndarray
    sigma_bearing: np.ndarray
    var_y_extra: np.ndarray
    lateral_offset: np.ndarray
    height_slope: np.ndarray
    bearing_depth: np.ndarray
    height_ground: np.ndarray
    height_rel_sigma: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.x) & np.isfinite(self.lateral) & np.all(np.isfinite(self.cov), axis=(1, 2))


class BoxRanger:
    """Single-frame position measurements of boxes from one camera (module docstring).

    Args:
        camera: the calibrated camera the boxes come from.
        config: the estimator's settings (box noise, truncation, class priors);
            ``EstimatorConfig()`` when None.
        priors: ``config``'s priors as a table; built from ``config`` when None.
    """

    def __init__(
        self, camera: CameraModel, config: EstimatorConfig | None = None, priors: PriorTable | None = None
    ) -> None:
        self.camera = camera
        self.config = config or EstimatorConfig()
        self.priors = PriorTable(self.config) if priors is None else priors

    def measure(
        self, xyxy: np.ndarray, class_id: np.ndarray, cos_heading: np.ndarray | None = None,
        height: np.ndarray | None = None, height_sigma: np.ndarray | None = None,
        ground: GroundMap | None = None,
    ) -> Measurement:
        """Position measurements (module docstring, steps 1-7) of boxes (N, 4) with classes (N,).

        ``cos_heading``: |cos| of each object's heading relative to the ego x axis
        (1 = seen end-on, the default; 0 = side-on), for the contact offset.
        ``height`` / ``height_sigma`` (N,): each object's height and its std (m) where known --
        a track's learned height (``perception.estimator``) --, in place of the class prior
        (step 2, 4 and 6); NaN or None: the class prior. ``ground``: the frame's ground map
        (``perception.ground_map``), used with ``config.ground_map``: each box's contact lies on
        the surface its bottom-centre ray meets first (a pavement's top), and its height is
        uncertain by the map's ``ground_map_sigma`` instead of the class's
        ``contact_height_sigma`` (step 1). None: the road plane, and the class's std.
        """
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        n = len(b)
        cid = np.broadcast_to(np.asarray(class_id, dtype=np.int64).reshape(-1), (n,))
        c = np.ones(n) if cos_heading is None else np.broadcast_to(np.asarray(cos_heading, float).reshape(-1), (n,))
        H, sH = self.priors.of(cid, "height").astype(float), self.priors.of(cid, "height_sigma").astype(float)
        if height is not None and height_sigma is not None:
            h = np.broadcast_to(np.asarray(height, float).reshape(-1), (n,))
            sh = np.broadcast_to(np.asarray(height_sigma, float).reshape(-1), (n,))
            known = np.isfinite(h) & np.isfinite(sh) & (h > 0) & (sh > 0)
            H, sH = np.where(known, h, H), np.where(known, sh, sH)
        with np.errstate(all="ignore"):
            return self._measure(b, cid, np.clip(np.nan_to_num(c, nan=1.0), 0.0, 1.0), H, sH,
                                 ground if self.config.ground_map else None)

    def _measure(
        self, b: np.ndarray, cid: np.ndarray, cos_h: np.ndarray, H: np.ndarray, sH: np.ndarray,
        ground: GroundMap | None,
    ) -> Measurement:
        cfg, cam = self.config, self.camera
        n = len(b)
        mx, my, mz = cam.mount
        x1, y1, x2, y2 = b.T
        w_px, h_px = x2 - x1, y2 - y1
        ok = np.all(np.isfinite(b), axis=1) & (w_px > 0) & (h_px > 0) & np.all(np.abs(b) < 1e6, axis=1)
        W, sW = self.priors.of(cid, "width"), self.priors.of(cid, "width_sigma")
        # a side or bottom edge within its noise of the image border may be the border: cut there
        # (not the top edge: a box cut at both ends keeps no range cue but the bound)
        margin = cfg.edge_margin_px
        margin_u = margin + cfg.edge_cut_sigmas * cfg.edge_sigma_rel * w_px
        margin_v = margin + cfg.edge_cut_sigmas * cfg.edge_sigma_rel * h_px
        cut_bottom = ok & (y2 >= cam.height - margin_v)
        cut_top = ok & (y1 <= margin)
        cut_left = ok & (x1 <= margin_u)
        cut_right = ok & (x2 >= cam.width - margin_u)

        sv = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * h_px)  # one horizontal edge, px
        su = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * w_px) / np.sqrt(2.0)  # box centre, px
        uc = 0.5 * (x1 + x2)
        vb = np.minimum(y2, float(cam.height))  # bottom row, at most the image's
        pix = np.stack(
            [
                np.stack([uc, vb], -1),
                np.stack([uc, vb + _DV], -1),
                np.stack([uc, vb - _DV], -1),
                np.stack([uc, y1], -1),
                np.stack([uc, y1 + _DV], -1),
                np.stack([uc, y1 - _DV], -1),
                np.stack([x1, vb], -1),
                np.stack([x2, vb], -1),
            ],
            axis=1,
        )  # (N, 8, 2)
        pix = np.where(ok[:, None, None], pix, 0.0)
        rays = cam.pixel_rays(pix) if n else np.zeros((0, 8, 3))
        fwd = rays[..., 0] > 1e-9
        slope = np.where(fwd, rays[..., 2] / rays[..., 0], np.nan)  # d_z / d_x
        tan_y = np.where(fwd, rays[..., 1] / rays[..., 0], np.nan)  # d_y / d_x

        # 1. ground contact (also the bound U of boxes cut at the bottom)
        # on the plane of the contact: the road's, or the surface a ground map says the ray meets first
        if ground is None:
            zc, szc = np.zeros(n), self.priors.of(cid, "contact_height_sigma").astype(float)
        else:
            zc, szc = ground.contact_heights(cam, pix[:, 0]), np.full(n, cfg.ground_map_sigma)
        gp = cam.ground_points(pix[:, :3], zc[:, None]) if n else np.zeros((0, 3, 3))
        xg_all = gp[:, 0, 0]
        dxdv = np.abs(gp[:, 1, 0] - gp[:, 2, 0]) / (2.0 * _DV)
        sig_g = dxdv * np.hypot(sv, cam.fy * cfg.pitch_sigma)
        sig_g_px = np.where(ok & ~cut_bottom, sig_g, np.nan)  # the box's noise only, no contact height
        sig_g = np.hypot(sig_g, (xg_all - mx) * szc / (mz - zc))
        g_ok = ok & ~cut_bottom & np.isfinite(xg_all) & np.isfinite(sig_g) & (xg_all - mx > MIN_DEPTH)
        x_g = np.where(g_ok, xg_all, np.nan)
        sig_g = np.where(g_ok, sig_g, np.nan)

        # 2. height prior from the box height
        s_b, s_t = slope[:, 0], slope[:, 3]
        dsdv_b = np.abs(slope[:, 1] - slope[:, 2]) / (2.0 * _DV)
        dsdv_t = np.abs(slope[:, 4] - slope[:, 5]) / (2.0 * _DV)
        ds = s_t - s_b
        xc_h = H / ds
        sig_ds = np.hypot(dsdv_t * sv, dsdv_b * sv)
        sig_h = xc_h * np.hypot(sH / H, sig_ds / ds)
        h_ok = ok & ~cut_top & ~cut_bottom & (ds > 0) & (xc_h > MIN_DEPTH) & np.isfinite(sig_h)
        x_h = np.where(h_ok, mx + xc_h, np.nan)
        sig_h = np.where(h_ok, sig_h, np.nan)

        # 2b. width prior of a vehicle seen end-on whose end face spans the camera's column
        # (then no side face is in the box): x_c = W / (t_l - t_r), at the face
        t_l, t_r = tan_y[:, 6], tan_y[:, 7]
        dt = t_l - t_r
        xc_w = W / dt
        sig_dt = np.sqrt(2.0) * np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * w_px) / cam.fx
        sig_w = xc_w * np.hypot(sW / W, sig_dt / dt)
        w_cue = self.priors.of(cid, "width_cue").astype(bool)
        w_ok = (
            ok & w_cue & ~cut_left & ~cut_right & ~cut_bottom & (t_r < 0.0) & (t_l > 0.0)
            & (cos_h >= cfg.width_cue_min_cos) & (xc_w > MIN_DEPTH) & np.isfinite(sig_w)
        )
        x_w = np.where(w_ok, mx + xc_w, np.nan)
        sig_w = np.where(w_ok, sig_w, np.nan)

        # 3. the nearest face from each cue (step 6 of the docstring), then the fusion: x (the
        # contact, for the lateral) and x_face (the range). Ground and height cues share the
        # bottom edge's noise: best linear unbiased weights of the correlated pair (never
        # negative), then the independent width cue by inverse variance.
        xg_f, xh_f, off = self._faces(x_g, x_h, cid, cos_h, H)
        var_g = sig_g**2 + (cfg.contact_offset_rel_sigma * (x_g - xg_f)) ** 2
        var_h = sig_h**2 + (cfg.contact_offset_rel_sigma * (x_h - xh_f)) ** 2
        dxg_dv = (gp[:, 1, 0] - gp[:, 2, 0]) / (2.0 * _DV)  # signed, per px of y2
        dxh_dv = xc_h / ds * (slope[:, 1] - slope[:, 2]) / (2.0 * _DV)  # x_h - m_x = H / (s_t - s_b)
        both = g_ok & h_ok
        c_gh = np.where(both, dxg_dv * dxh_dv * (cfg.edge_sigma_rel * h_px) ** 2, 0.0)
        c_gh = np.minimum(c_gh, np.fmin(var_g, var_h))  # at most the better cue alone
        den = np.where(both, var_g + var_h - 2.0 * c_gh, 1.0)
        a_g = np.where(both, (var_h - c_gh) / den, np.where(g_ok, 1.0, 0.0))  # weight of the ground cue
        a_h = np.where(both, (var_g - c_gh) / den, np.where(h_ok, 1.0, 0.0))
        var_gh = np.where(both, (var_g * var_h - c_gh**2) / den, np.where(g_ok, var_g, var_h))
        gh_ok = g_ok | h_ok
        x_gh = np.nan_to_num(x_g) * a_g + np.nan_to_num(x_h) * a_h
        xf_gh = np.nan_to_num(xg_f) * a_g + np.nan_to_num(xh_f) * a_h
        w_gh = np.where(gh_ok, 1.0 / var_gh, 0.0)
        w_w = np.where(w_ok, 1.0 / sig_w**2, 0.0)
        w_sum = w_gh + w_w
        xw_c = x_w + off  # the width cue's face, moved back to the contact
        with np.errstate(invalid="ignore", divide="ignore"):
            x = np.where(w_sum > 0, (np.where(gh_ok, x_gh, 0.0) * w_gh + np.nan_to_num(xw_c) * w_w) / w_sum, np.nan)
            x_face = np.where(
                w_sum > 0, (np.where(gh_ok, xf_gh, 0.0) * w_gh + np.nan_to_num(x_w) * w_w) / w_sum, np.nan
            )
            sig = np.where(w_sum > 0, 1.0 / np.sqrt(w_sum), np.nan)

        # 4. boxes cut at the bottom: top ray on z = H, bounded by the bottom image row
        x_max = np.full(n, np.nan)
        if np.any(cut_bottom):
            x, sig, x_h, sig_h, x_max = self._cut_bottom(
                cut_bottom, cut_top, x, sig, x_h, sig_h, xg_all, s_t, dsdv_t, ds, sv, H, sH
            )

        # 5. lateral offset and half-width at the fused range (the bottom-centre ray at the contact)
        xc = x - mx
        front = xc > MIN_DEPTH
        x = np.where(front, x, np.nan)
        sig = np.where(front, sig, np.nan)
        t_c = tan_y[:, 0]
        y_c, y_l, y_r = my + xc * t_c, my + xc * t_l, my + xc * t_r
        hw = 0.5 * (y_l - y_r)
        side = cut_left ^ cut_right
        hw = np.where(cut_left | cut_right, np.maximum(hw, 0.5 * W), hw)
        lat = np.where(cut_left & ~cut_right, y_r + hw, y_c)
        lat = np.where(cut_right & ~cut_left, y_l - hw, lat)
        lat = np.where(np.isfinite(x), lat, np.nan)
        tan_eff = np.where(side, (lat - my) / xc, t_c)
        s_bear = su / cam.fx
        extra = np.where(side, (0.5 * sW) ** 2, 0.0)
        offset = np.zeros(n)
        deep = np.zeros(n)

        # 6. the range is the nearest face's (boxes cut at the bottom: the top ray's estimate)
        x = np.where(cut_bottom | ~front, x, x_face)
        xc = x - mx  # the face's depth; the lateral stays the contact's (the box centre's ray) ...

        # 5b. ... except for a vehicle seen end-on, whose footprint is W x L behind its face
        end_on = w_cue & (cos_h >= cfg.width_cue_min_cos) & (xc > MIN_DEPTH) & ~(cut_left & cut_right)
        if np.any(end_on):
            e = self._end_on_lateral(xc, t_l, t_r, cut_left, cut_right, W, sW, cid, w_px, s_bear)
            lat, hw, tan_eff, offset, s_bear, extra, deep = (
                np.where(end_on, a, b)
                for a, b in zip(e, (lat, hw, tan_eff, offset, s_bear, extra, deep), strict=True)
            )
            lat = np.where(np.isfinite(x), lat, np.nan)

        # 7. cut at a side, with a footprint long along x, and none of its nearest face in view
        # (the face spans lat -/+ W/2 at x; the border ray through the box's bottom corner at the
        # border reaches y_b there): the nearest part is out of view, up to the footprint's x
        # extent nearer than the visible part. The measured face is an upper bound; its std is
        # widened by the extent's uniform std, and the filter does not settle on it.
        extent = self.priors.of(cid, "length") * cos_h + W * np.sqrt(1.0 - cos_h**2)
        y_b = my + xc * np.where(cut_left, t_l, t_r)
        half = np.minimum(hw, 0.5 * W)
        beyond = np.where(cut_left, lat - half >= y_b, lat + half <= y_b)
        side_bound = (cut_left ^ cut_right) & ~cut_bottom & (extent >= cfg.side_cut_min_extent) & beyond
        side_bound &= np.isfinite(x)
        if np.any(side_bound):
            sig = np.where(side_bound, np.hypot(sig, extent / np.sqrt(12.0)), sig)
        return Measurement(
            x=x,
            sigma=sig,
            x_ground=x_g,
            sigma_ground=sig_g,
            x_height=x_h,
            sigma_height=sig_h,
            x_width=x_w,
            sigma_width=sig_w,
            lateral=lat,
            half_width=np.where(np.isfinite(lat), hw, np.nan),
            cov=self.position_cov(xc, sig, tan_eff, s_bear, extra),
            cut_bottom=cut_bottom,
            cut_top=cut_top,
            x_max=x_max,
            side_bound=side_bound,
            tan_y=tan_eff,
            sigma_bearing=s_bear,
            var_y_extra=extra,
            lateral_offset=np.where(np.isfinite(lat), offset, np.nan),
            height_slope=np.where(ok & ~cut_top & ~cut_bottom & (ds > 0), ds, np.nan),
            bearing_depth=deep,
            height_ground=np.where(g_ok & h_ok, (xg_f - mx) * ds, np.nan),
            height_rel_sigma=np.where(g_ok & h_ok, np.hypot(sig_g_px / (xg_f - mx), sig_ds / ds), np.nan),
        )

    def _end_on_lateral(
        self,
        xf: np.ndarray,
        t_l: np.ndarray,
        t_r: np.ndarray,
        cut_left: np.ndarray,
        cut_right: np.ndarray,
        W: np.ndarray,
        sW: np.ndarray,
        cid: np.ndarray,
        w_px: np.ndarray,
        s_bear_c: np.ndarray,
    ) -> tuple[np.ndarray, ...]:
        """Lateral of vehicles seen end-on: footprint W x L behind the face at depth ``xf`` (step 5b).

        Returns (lateral, half_width, tan_y, lateral_offset, sigma_bearing, var_y_extra, bearing_depth);
        lateral = m_y + xf tan_y + lateral_offset.
        """
        cfg, my = self.config, self.camera.mount[1]
        L, sL = self.priors.of(cid, "length"), self.priors.of(cid, "length_sigma")
        s_edge = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * w_px) / self.camera.fx  # one edge (rad)
        left_of, right_of = t_r > 0.0, t_l < 0.0  # the box wholly left / right of the camera's column
        whole = ~cut_left & ~cut_right
        span = whole & ~left_of & ~right_of
        # the end face spans the camera's column: both edges are its corners
        tan = np.where(span, 0.5 * (t_l + t_r), np.nan)
        off = np.zeros(len(xf))
        hw = np.where(span, 0.5 * xf * (t_l - t_r), 0.5 * W)
        s_bear = np.where(span, s_bear_c, s_edge)
        extra = np.where(span, 0.0, (0.5 * sW) ** 2)
        deep = np.zeros(len(xf))
        # the outer edge is the end face's outer corner: -/+ W/2 from it (also a box cut on
        # the far side whose visible edge is then the outer one)
        for m, t_e, sgn in ((whole & left_of, t_l, -1.0), (whole & right_of, t_r, 1.0),
                            (cut_left & ~cut_right & ~left_of, t_r, 1.0),
                            (cut_right & ~cut_left & ~right_of, t_l, -1.0)):  # fmt: skip
            tan, off = np.where(m, t_e, tan), np.where(m, sgn * 0.5 * W, off)
        # cut on the side it lies on: only the inner edge is seen, the far end's corner, L deeper
        for m, t_e, sgn in ((cut_left & ~cut_right & left_of, t_r, 1.0),
                            (cut_right & ~cut_left & right_of, t_l, -1.0)):  # fmt: skip
            tan, off = np.where(m, t_e, tan), np.where(m, sgn * 0.5 * W + L * t_e, off)
            deep = np.where(m, L, deep)
            # the far corner's bearing error reaches the lateral over xf + L, not xf: add the L part
            extra = np.where(m, (0.5 * sW) ** 2 + (sL * t_e) ** 2 + (L * s_edge) ** 2, extra)
        return my + xf * tan + off, hw, tan, off, s_bear, extra, deep

    def _faces(
        self, x_g: np.ndarray, x_h: np.ndarray, cid: np.ndarray, cos_h: np.ndarray, H: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest-face range from the ground cue and from the height cue (docstring, step 6),
        and the contact offset ``off`` used.

        The box bottom is the lower of the ground contact, ``off`` behind the face, and
        the face's lower edge at height c: x = max(x_g - off, m_x + (x_g - m_x)(m_z - c)/m_z).
        The height cue assumed its foot and top at one x; with the foot ``off`` behind
        a face of height H it reads about off m_z / H too far (c: (x_h - m_x) H / (H - c)).
        """
        mx, mz = self.camera.mount[0], self.camera.mount[2]
        sin_h = np.sqrt(1.0 - cos_h**2)
        off = self.priors.of(cid, "contact_offset") * cos_h + self.priors.of(cid, "contact_offset_side") * sin_h
        clr = np.minimum(self.priors.of(cid, "clearance"), 0.9 * mz)
        xg_f = np.maximum(x_g - off, mx + (x_g - mx) * (mz - clr) / mz)
        hh = np.maximum(H, clr + 0.1)
        xh_f = np.maximum(x_h - off * mz / hh, mx + (x_h - mx) * (hh - clr) / hh)
        return xg_f, xh_f, off

    def position_cov(
        self, xc: np.ndarray, sig_x: np.ndarray, tan_y: np.ndarray, s_bear: np.ndarray, extra: np.ndarray
    ) -> np.ndarray:
        """(N, 2, 2) covariance of (x, y) = (x, m_y + (x - m_x) tan_y) (module docstring, step 5)."""
        xc, sig_x, tan_y = np.atleast_1d(xc), np.atleast_1d(sig_x), np.atleast_1d(tan_y)
        floor2 = self.config.position_sigma_floor**2
        cov = np.empty((len(xc), 2, 2))
        cov[:, 0, 0] = sig_x**2 + floor2
        cov[:, 1, 1] = (tan_y * sig_x) ** 2 + (xc * s_bear) ** 2 + floor2 + extra
        cov[:, 0, 1] = cov[:, 1, 0] = tan_y * sig_x**2
        return cov

    def _cut_bottom(
        self,
        cut_bottom: np.ndarray,
        cut_top: np.ndarray,
        x: np.ndarray,
        sig: np.ndarray,
        x_h: np.ndarray,
        sig_h: np.ndarray,
        x_row: np.ndarray,
        s_t: np.ndarray,
        dsdv_t: np.ndarray,
        ds_vis: np.ndarray,
        sv: np.ndarray,
        H: np.ndarray,
        sH: np.ndarray,
    ) -> tuple[np.ndarray, ...]:
        """Range of boxes whose foot is below the image (module docstring, step 4)."""
        mx, mz = self.camera.mount[0], self.camera.mount[2]
        x, sig, x_h, sig_h = x.copy(), sig.copy(), x_h.copy(), sig_h.copy()
        i = np.flatnonzero(cut_bottom)
        # top ray meets z = H
        xc_t = (H[i] - mz) / s_t[i]
        sig_t = np.hypot(sH[i] / s_t[i], xc_t / s_t[i] * dsdv_t[i] * sv[i])
        t_ok = ~cut_top[i] & (xc_t > MIN_DEPTH) & np.isfinite(sig_t)
        # the foot is below the bottom row: x <= U
        upper = np.where(np.isfinite(x_row[i]), x_row[i], np.inf)
        h_bound = mx + (H[i] + 2.0 * sH[i]) / ds_vis[i]
        upper = np.where(~cut_top[i] & (ds_vis[i] > 0) & (h_bound < upper), h_bound, upper)
        lower = np.minimum(0.0, upper)
        bounded = np.isfinite(upper)
        width = np.maximum(upper - lower, 0.1)
        xi = np.where(bounded, 0.5 * (lower + upper), np.nan)  # uniform on [lower, upper]
        si = width / np.sqrt(12.0)
        use_t = t_ok & bounded  # the top ray's Gaussian truncated to the bounds
        if np.any(use_t):
            from scipy.stats import truncnorm  # lazy: scipy.stats costs ~0.5 s at start-up

            mu, sd = mx + xc_t[use_t], sig_t[use_t]
            a, bb = (lower[use_t] - mu) / sd, (upper[use_t] - mu) / sd
            m_tr, v_tr = truncnorm.stats(a, bb, loc=mu, scale=sd, moments="mv")
            m_tr, s_tr = np.asarray(m_tr, float), np.sqrt(np.asarray(v_tr, float))
            good = np.isfinite(m_tr) & np.isfinite(s_tr)  # far outside: the nearer bound
            xi[use_t] = np.where(good, m_tr, np.clip(mu, lower[use_t], upper[use_t]))
            si[use_t] = np.where(good, np.maximum(s_tr, 1e-3), si[use_t])
        only_t = t_ok & ~bounded
        xi[only_t], si[only_t] = mx + xc_t[only_t], sig_t[only_t]
        x[i], sig[i] = xi, si
        x_h[i] = np.where(t_ok, mx + xc_t, np.nan)
        sig_h[i] = np.where(t_ok, sig_t, np.nan)
        x_max = np.full(len(x), np.nan)
        x_max[i] = np.where(bounded, upper, np.nan)
        return x, sig, x_h, sig_h, x_max

    # ------------------------------------------------------------ tracking
