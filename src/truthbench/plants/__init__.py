"""Parametric plants (test articles): the free-free beam and the hub-beam.

``make_plant(kind, n_elements=..., n_groups=..., stations=...)`` gives a builder;
``plant.build(params, actuators, sensors)`` gives a
:class:`~truthbench.model.StructuralModel`.
"""

from truthbench.plants import free_free_beam, hub_beam  # noqa: F401  (registration)
from truthbench.plants.base import (
    PLANTS,
    Actuator,
    Plant,
    Sensor,
    make_plant,
    register_plant,
)

__all__ = ["PLANTS", "Actuator", "Plant", "Sensor", "make_plant", "register_plant"]
