"""The world: highway-env road and traffic, the ego, scripted actors, collisions.

``World(scenario).step()`` advances one simulation tick of ``1 / rate``
seconds. Nothing here renders; ``sim.renderer`` and ``sim.groundtruth`` read
the state through ``agent_states`` and ``ego_pose``. World frame: x along
the main road, y left, z up, headings CCW from +x (rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from highway_env.road.road import Road, RoadNetwork
from highway_env.vehicle.behavior import IDMVehicle

from lookahead.perception.frame import EgoOdometry
from lookahead.perception.geometry import nearest_x_extent  # noqa: F401 (re-exported)
from lookahead.sim.actors import Identity, ScriptedActor, wrap
from lookahead.sim.ego import Collision, EgoVehicle
from lookahead.sim.layout import RoadLayout, ego_frame  # noqa: F401 (re-exported)
from lookahead.sim.road import MAIN_FROM, MAIN_TO, RoadGeometry, build_road
from lookahead.sim.scenario import Scenario, TriggerSpec
from lookahead.sim.shapes import make_shape

TRAFFIC_MIX = (("car", 0.8), ("truck", 0.1), ("bus", 0.1))
EGO_ACTOR_ID = 0  # the ego's actor id where other cameras see it


@dataclass(frozen=True)
class Viewpoint:
    """Where a camera other than the ego's stands (``World.viewpoint``, or a roadside unit):
    the world pose (x, y, heading; m, rad) of its frame's origin, how that moves (m/s,
    rad/s, m/s^2), and the actor carrying it (None: none), which it does not see."""

    pose: tuple[float, float, float]
    speed: float = 0.0
    yaw_rate: float = 0.0
    accel: float = 0.0
    carrier: int | None = None


@dataclass
class AgentStates:
    """Struct of arrays over all non-ego agents (world frame)."""

    ids: np.ndarray  # (N,) int
    xy: np.ndarray  # (N, 2) m, footprint centre
    yaw: np.ndarray  # (N,) rad
    speed: np.ndarray  # (N,) m/s
    accel: np.ndarray  # (N,) m/s^2 along the heading, over the last tick
    yaw_rate: np.ndarray  # (N,) rad/s over the last tick
    gait_phase: np.ndarray  # (N,) rad
    arm: np.ndarray  # (N,) rad, the gesture arm's pitch (a wave; sim.shapes.Pose)
    body: np.ndarray  # (N,) rad, the whole body's pitch (a fall)
    gesture: np.ndarray  # (N,) int, the scripted gesture as a behaviour code (intent.labels.Behaviour), 0 none
    length: np.ndarray  # (N,) m, collision footprint
    width: np.ndarray  # (N,) m

    def poses(self) -> list:
        """Each agent's ``sim.shapes.Pose`` (the gait phase, or (gait phase, arm, body))."""
        return [_pose(g, a, b) for g, a, b in zip(self.gait_phase, self.arm, self.body, strict=True)]


def _pose(gait: float, arm: float, body: float):
    """A ``sim.shapes.Pose``: the bare gait phase unless the actor gestures."""
    return float(gait) if not arm and not body else (float(gait), float(arm), float(body))


def ref_to_centre(ref: str, yaw: float, length: float, width: float) -> np.ndarray:
    """World-frame vector from a footprint's ``ref`` point (rear, front, nearest) to its centre.

    ``rear`` / ``front``: the bumper centre, half a length behind / ahead of the centre along ``yaw``;
    ``nearest``: the centre lies the footprint's half x-extent beyond (the ego starts heading along +x,
    so the given x is the ground-truth range at t=0: the nearest point's x).
    """
    if ref == "nearest":
        return np.array([float(nearest_x_extent(np.array(yaw), np.array(length), np.array(width))), 0.0])
    sign = 1.0 if ref == "rear" else -1.0
    return sign * 0.5 * float(length) * np.array([np.cos(yaw), np.sin(yaw)])


def scenario_road(scenario: Scenario) -> tuple[RoadNetwork, RoadGeometry, RoadLayout]:
    """The road network, geometry and layout of ``scenario`` (a cross street 60 m ahead of the ego)."""
    return build_road(scenario.road, cross_x=scenario.ego.s + scenario.ego.length / 2.0 + 60.0)


class World:
    """A deterministic closed-loop world built from a ``Scenario``."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.dt = 1.0 / scenario.rate
        self.t = 0.0
        self.tick = 0
        ego_spec = scenario.ego
        self.network, self.geometry, self.layout = scenario_road(scenario)
        self.road = Road(network=self.network, np_random=np.random.RandomState(scenario.seed))

        lane_index = (MAIN_FROM, MAIN_TO, ego_spec.lane)
        lane = self.network.get_lane(lane_index)
        self.ego = EgoVehicle(self.road, lane.position(ego_spec.s, 0.0), 0.0, ego_spec, lane_index)
        self.road.vehicles.append(self.ego)
        # what other cameras see of the ego (``viewpoint``): a sedan; id 0 is the ego's
        self.ego.identity = Identity(EGO_ACTOR_ID, "ego", "car", "sedan", make_shape("car", "sedan", self._rng(4)),
                                     scripted=False)
        self.ego.gait_phase = self.ego.arm = self.ego.body = 0.0
        front0 = np.array([ego_spec.s + ego_spec.length / 2.0, self.geometry.lane_y(ego_spec.lane)])
        self._origin0 = front0

        self.agents: list = []
        self._add_traffic()
        self._add_actors()
        self.by_name = {a.identity.name: a for a in self.agents}
        n = len(self.agents)
        self._prev_speed = np.array([a.speed for a in self.agents], dtype=np.float64)
        self._prev_yaw = np.array([-a.heading for a in self.agents], dtype=np.float64)
        self._accel = np.zeros(n)
        self._yaw_rate = np.zeros(n)
        self._ego_prev = (float(self.ego.speed), -float(self.ego.heading))
        self.odometry = EgoOdometry(speed=float(self.ego.speed))
        self.collisions: list[Collision] = []
        self._hit_ids: set[int] = set()

    # ------------------------------------------------------------------ construction
    def to_world(self, rel_xy: np.ndarray) -> np.ndarray:
        """Ego-relative-at-t0 xy -> world xy (the ego starts heading along +x)."""
        return self._origin0 + np.asarray(rel_xy, dtype=np.float64)

    def _rng(self, *key: int) -> np.random.Generator:
        return np.random.default_rng([self.scenario.seed, *key])

    def _add_traffic(self) -> None:
        spec = self.scenario.traffic
        if spec.count == 0 or spec.density <= 0:
            return
        rng = self._rng(2)
        names, probs = zip(*TRAFFIC_MIX, strict=True)
        for i in range(spec.count):
            speed = None if spec.speed is None else float(rng.uniform(*spec.speed))
            cls = str(rng.choice(names, p=probs))
            shape = make_shape(cls, "sedan" if cls == "car" else cls, self._rng(3, i))
            v = IDMVehicle.create_random(
                self.road, speed=speed, lane_from=MAIN_FROM, lane_to=MAIN_TO, spacing=1.0 / spec.density
            )
            v.LENGTH, v.WIDTH = shape.footprint
            v.diagonal = float(np.hypot(v.LENGTH, v.WIDTH))
            v.enable_lane_change = spec.lane_change
            v.identity = Identity(1000 + i, f"traffic{i}", cls, shape.subtype, shape, scripted=False)
            v.gait_phase = 0.0
            self.road.vehicles.append(v)
            self.agents.append(v)

    def _add_actors(self) -> None:
        for i, spec in enumerate(self.scenario.actors):
            shape = make_shape(spec.type, spec.subtype, self._rng(1, i))
            st = spec.start
            if st.lane is not None:
                pos = np.array([self._origin0[0] + st.s, self.geometry.lane_y(st.lane) + st.offset])
            elif st.impact is not None:  # % of the ego's width from its left side; 50 = centreline
                pos = self.to_world(np.array([st.x, (0.5 - st.impact / 100.0) * self.scenario.ego.width]))
            else:
                pos = self.to_world(np.array([st.x, st.y]))
            if st.ref != "centre":
                pos = pos + ref_to_centre(st.ref, np.radians(spec.heading), *shape.footprint)
            ident = Identity(i + 1, spec.id, spec.type, spec.subtype, shape)
            a = ScriptedActor(self.road, ident, spec, pos, np.radians(spec.heading), self.to_world)
            a.lane_y = self.geometry.lane_y
            self.road.vehicles.append(a)
            self.agents.append(a)

    # ------------------------------------------------------------------ state
    def ego_pose(self) -> tuple[float, float, float]:
        """World (x, y, yaw) of the ego frame origin (front bumper centre, on the ground)."""
        yaw = -float(self.ego.heading)
        half = self.ego.LENGTH / 2.0
        x = float(self.ego.position[0]) + half * np.cos(yaw)
        y = -float(self.ego.position[1]) + half * np.sin(yaw)
        return x, y, yaw

    def actor_poses(self, with_ego: bool = False) -> dict[int, tuple[float, float, float, float]]:
        """Actor id -> world (x, y, heading, gait phase) (m, rad): what the renderer poses; with
        ``with_ego``, the ego's body too (``EGO_ACTOR_ID``), for other cameras."""
        st = self.agent_states(with_ego)
        return {int(i): (float(x), float(y), float(h), pose)
                for i, (x, y), h, pose in zip(st.ids, st.xy, st.yaw, st.poses(), strict=True)}

    def viewed_agents(self, with_ego: bool = False) -> list:
        """The non-ego agents, and the ego last with ``with_ego`` (what another camera may see)."""
        return [*self.agents, self.ego] if with_ego else self.agents

    def viewpoint(self, actor_id: int) -> Viewpoint:
        """Where a camera on actor ``actor_id`` stands: the middle of its front edge on the
        ground, heading, speed and yaw rate (world; m, rad, m/s)."""
        st = self.agent_states()
        k = int(np.nonzero(st.ids == actor_id)[0][0])
        yaw, half = float(st.yaw[k]), float(st.length[k]) / 2.0
        pose = (float(st.xy[k, 0]) + half * np.cos(yaw), float(st.xy[k, 1]) + half * np.sin(yaw), yaw)
        return Viewpoint(pose, float(st.speed[k]), float(st.yaw_rate[k]), float(st.accel[k]), actor_id)

    def agent_states(self, with_ego: bool = False) -> AgentStates:
        """The agents' states (``viewed_agents``: with ``with_ego``, the ego's last, its
        acceleration and yaw rate from its odometry)."""
        a = self.viewed_agents(with_ego)
        ego_row = (np.array([self.odometry.accel]), np.array([self.odometry.yaw_rate])) if with_ego else ((), ())
        return AgentStates(
            ids=np.array([v.identity.actor_id for v in a], dtype=np.int64),
            xy=np.array([[v.position[0], -v.position[1]] for v in a], dtype=np.float64).reshape(-1, 2),
            yaw=np.array([-v.heading for v in a], dtype=np.float64),
            speed=np.array([v.speed for v in a], dtype=np.float64),
            accel=np.concatenate([self._accel, *ego_row[:1]]),
            yaw_rate=np.concatenate([self._yaw_rate, *ego_row[1:]]),
            gait_phase=np.array([getattr(v, "gait_phase", 0.0) for v in a], dtype=np.float64),
            arm=np.array([getattr(v, "arm", 0.0) for v in a], dtype=np.float64),
            body=np.array([getattr(v, "body", 0.0) for v in a], dtype=np.float64),
            gesture=np.array([getattr(v, "gesture_code", 0) for v in a], dtype=np.int64),
            length=np.array([v.LENGTH for v in a], dtype=np.float64),
            width=np.array([v.WIDTH for v in a], dtype=np.float64),
        )

    def relative(self, agent) -> tuple[float, float, float, float]:
        """(range, lateral, range_rate, lateral_rate) of one agent in the ego frame (footprint-based)."""
        ox, oy, oyaw = self.ego_pose()
        rel = ego_frame(np.array([ox, oy]), oyaw, np.array([[agent.position[0], -agent.position[1]]]))[0]
        ryaw = -agent.heading - oyaw
        rng = rel[0] - float(nearest_x_extent(np.array(ryaw), np.array(agent.LENGTH), np.array(agent.WIDTH)))
        v = agent.speed * np.array([np.cos(ryaw), np.sin(ryaw)]) - np.array([self.ego.speed, 0.0])
        w = self.odometry.yaw_rate
        return float(rng), float(rel[1]), float(v[0] + w * rel[1]), float(v[1] - w * rel[0])

    # ------------------------------------------------------------------ triggers
    def trigger_holds(self, trig: TriggerSpec, actor) -> bool:
        if trig.t is not None and self.t + 1e-9 < trig.t:
            return False
        if trig.ego_range_lt is not None or trig.ttc_lt is not None:
            rng, _, rr, _ = self.relative(actor)
            if trig.ego_range_lt is not None and not (0.0 <= rng < trig.ego_range_lt):
                return False
            if trig.ttc_lt is not None and not (rr < -1e-6 and max(rng, 0.0) / -rr < trig.ttc_lt):
                return False
        c = trig.actor
        if c is not None:
            other = self.by_name[c.id]
            if c.speed_gt is not None and not other.speed > c.speed_gt:
                return False
            if c.speed_lt is not None and not other.speed < c.speed_lt:
                return False
            if c.moving is not None and (other.speed > 0.1) != c.moving:
                return False
            if c.range_lt is not None and not (0.0 <= self.relative(other)[0] < c.range_lt):
                return False
        return True

    # ------------------------------------------------------------------ stepping
    def step(self) -> list[Collision]:
        """Advance one tick; returns the collisions of the ego that began in it."""
        for a in self.agents:
            if isinstance(a, ScriptedActor):
                a.update_script(self.t, self.trigger_holds)
        self.ego.t = self.t
        self.road.act()
        self.road.step(self.dt)
        self.t = (self.tick + 1) * self.dt
        self.tick += 1

        speed = np.fromiter((a.speed for a in self.agents), dtype=np.float64, count=len(self.agents))
        yaw = np.fromiter((-a.heading for a in self.agents), dtype=np.float64, count=len(self.agents))
        self._accel = (speed - self._prev_speed) / self.dt
        self._yaw_rate = ((yaw - self._prev_yaw + np.pi) % (2 * np.pi) - np.pi) / self.dt
        self._prev_speed, self._prev_yaw = speed, yaw
        es, eyaw = float(self.ego.speed), -float(self.ego.heading)
        self.odometry = EgoOdometry(
            speed=es, accel=(es - self._ego_prev[0]) / self.dt, yaw_rate=wrap(eyaw - self._ego_prev[1]) / self.dt
        )
        self._ego_prev = (es, eyaw)

        new: list[Collision] = []
        for other in self.ego.hits:
            ident = other.identity
            if ident.actor_id in self._hit_ids:
                continue
            self._hit_ids.add(ident.actor_id)
            ryaw = -other.heading - eyaw
            rel_v = es - other.speed * np.cos(ryaw)
            new.append(Collision(self.t, self.tick, ident.actor_id, ident.name, ident.cls, es, float(rel_v)))
        self.ego.hits.clear()
        self.collisions.extend(new)
        return new
