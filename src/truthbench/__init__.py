"""truthbench: synthetic test campaigns with known truth for FE model updating.

The objects a user starts from (imported on first use, so ``truthbench --help`` and
``import truthbench`` stay fast):

=====================  ===================================================================
``load_campaign``      read and validate a campaign TOML file -> ``CampaignSpec``
``run_campaign``       run its Monte Carlo trials -> ``CampaignResult``
``CampaignResult``     a run's results; ``CampaignResult.load(path)`` reads a results file
``make_plant``         a plant by name ("free_free_beam", "hub_beam"); ``FreeFreeBeam``,
                       ``HubBeam`` the classes; ``Actuator``, ``Sensor`` their channels
``StructuralModel``    M, C, K with inputs and outputs: modes, FRF, state space
``Hardware``           a plant with realised effects: exact ``.frf()``, ``.simulate()``;
                       ``realise(plant, parameters, effects)`` builds one
``FRFPredictor``       model FRFs at measured lines for updating
``estimate_frf``       H1/H2/Hv FRFs and coherence from time histories
``FRFData``            the FRF data type (channels, units, coherence, averages)
``load_frf``           FRFData from a file: UFF 58 (+ 164, 2411), LVM, our HDF5
``load_measurements``  FRFData from several files: coherence-only UFF files paired,
                       excitation levels by data-set name
``load_model``         read a model file (the user's article) -> ``ModelSpec``
``diagnose``           the effects a model lacks, from measured FRFs -> ``Diagnosis``
=====================  ===================================================================

The package is organised in rooms, lowest first (docs/internals/architecture.md):
``settings``, ``presentation``; ``fe``, ``model``, ``measure``, ``simulate``; ``plants``,
``io``, ``identify``; ``effects``, ``uncertainty``, ``placement``; ``update``;
``studies``; ``campaign``; ``report``; ``cli``. A room imports only rooms below it.
"""

from __future__ import annotations

import importlib

from truthbench._version import __version__

_EXPORTS = {
    "load_campaign": "truthbench.campaign.spec",
    "CampaignSpec": "truthbench.campaign.spec",
    "run_campaign": "truthbench.campaign.runner",
    "CampaignResult": "truthbench.campaign.results",
    "make_plant": "truthbench.plants",
    "FreeFreeBeam": "truthbench.plants.free_free_beam",
    "HubBeam": "truthbench.plants.hub_beam",
    "Actuator": "truthbench.plants",
    "Sensor": "truthbench.plants",
    "StructuralModel": "truthbench.model",
    "Hardware": "truthbench.effects",
    "realise": "truthbench.effects",
    "FRFPredictor": "truthbench.update",
    "estimate_frf": "truthbench.measure",
    "FRFData": "truthbench.measure.frfdata",
    "Channel": "truthbench.measure.frfdata",
    "load_frf": "truthbench.io",
    "load_measurements": "truthbench.io",
    "load_model": "truthbench.campaign.model_file",
    "diagnose": "truthbench.diagnose",
    "Diagnosis": "truthbench.diagnose",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    """Import the public objects on first use (PEP 562)."""
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'truthbench' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(__all__)
