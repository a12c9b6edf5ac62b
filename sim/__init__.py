"""The simulator. Importing ``sim`` registers the gymnasium environments
``lookahead/ForwardCamera-v0`` (camera image in the observation) and
``lookahead/ForwardTracks-v0`` (tracks only, no rendering); the environment
module itself (``sim.gym_env``) is imported lazily by ``gymnasium.make``."""

try:
    import gymnasium as _gym
except ImportError:  # gymnasium is optional for the rest of sim
    _gym = None

if _gym is not None:
    for _id, _camera in (("lookahead/ForwardCamera-v0", True), ("lookahead/ForwardTracks-v0", False)):
        if _id not in _gym.registry:
            _gym.register(id=_id, entry_point="lookahead.sim.gym_env:LookaheadEnv",
                          kwargs={"render_camera": _camera})
