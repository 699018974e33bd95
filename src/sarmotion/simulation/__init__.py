"""Simulated acquisitions: scenes and their files, the forward model, pulse signals.

- :mod:`~sarmotion.simulation.scene` — :class:`Scene` and :class:`PointTarget`, the
  ``sarmotion.scene/1`` TOML schema, the built-in scenes (``scenes/*.toml``);
- :mod:`~sarmotion.simulation.forward` — the traces of a scene (``eq:MOD1``), noise,
  injection of targets into measured data;
- :mod:`~sarmotion.simulation.paths` — movers on piecewise-straight paths (turns,
  stops), with a constant acceleration or a constant turn rate, and radars with a
  longer range window, for long acquisitions;
- :mod:`~sarmotion.simulation.signals` — chirps, Gaussian pulses, range compression;
- :mod:`~sarmotion.simulation.collection` — large constant-density scenes computed a
  block of pulses at a time (:class:`CollectionScene`), never held whole;
- :mod:`~sarmotion.simulation.echoes` — the summed echoes of many straight-moving
  points in one compiled pass (:func:`point_echoes`), which those blocks use.
"""

from .collection import CollectionScene, collection_acquisition, random_collection
from .echoes import point_echoes
from .forward import Simulation, add_noise, inject, simulate, simulate_phase_history
from .paths import AcceleratingTarget, PathTarget, TurningTarget, radar_with_range_window
from .scene import (
    PointTarget,
    Scene,
    SceneError,
    builtin_scene_names,
    check_aliasing,
    load_scene,
    random_scene,
)

__all__ = [
    "CollectionScene",
    "collection_acquisition",
    "random_collection",
    "AcceleratingTarget",
    "PathTarget",
    "PointTarget",
    "TurningTarget",
    "Scene",
    "SceneError",
    "Simulation",
    "add_noise",
    "builtin_scene_names",
    "check_aliasing",
    "inject",
    "load_scene",
    "radar_with_range_window",
    "random_scene",
    "simulate",
    "simulate_phase_history",
    "point_echoes",
]
