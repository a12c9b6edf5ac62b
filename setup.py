"""The one thing pyproject.toml cannot say: the top-level folders install under one name.

``perception/``, ``intent/``, ``sim/`` and ``tools/`` become ``lookahead.perception`` … and
``models/`` and ``scenarios/`` travel as the data packages ``lookahead.models`` and
``lookahead.scenarios`` (found with ``importlib.resources``, see ``lookahead.sim.catalogue``).
Every sub-package with an ``__init__.py`` is found, so a new one cannot be left out of the wheel.
"""

from setuptools import find_packages, setup

CODE = ("perception", "intent", "sim", "tools")
DATA = ("models", "scenarios")

setup(
    packages=[f"lookahead.{p}" for p in find_packages(include=[f"{t}*" for t in CODE])]
    + [f"lookahead.{d}" for d in DATA],
    package_dir={f"lookahead.{t}": t for t in CODE + DATA},
)
