"""Model files for ``truthbench diagnose``: the user's article and what they distrust.

A model file is a TOML file with the campaign file's ``[plant]`` table (the article:
type, mesh, section, material, suspension, what supports it (``supports``), stations;
parameters in SI with units in the keys), optionally ``[update] parameters`` (what the
user trusts the model to get wrong: fitted first, as the baseline) and ``[diagnose]``
(candidates, band, point map, ...: docs/reference/model_file.md). It needs no ``[[tests]]`` or
``[[sensors]]``: the data say where they were measured. A campaign file is a model file
too; its test tables are then not used.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from pydantic import Field, ValidationError

from truthbench.campaign.spec import _format_validation_error
from truthbench.campaign.spec_tables import DiagnoseSpec, PlantSpec, UpdateSpec, _Strict
from truthbench.errors import CampaignError, ModelError

CAMPAIGN_ONLY = ("sensors", "tests", "truth", "identify", "uncertainty", "output")
"""Tables of a campaign file that a model file does not use."""


class ModelMeta(_Strict):
    """``[campaign]`` of a model file: only a name is used (a campaign file's table is
    accepted as it is)."""

    name: str = "model"
    """Names the diagnosis's output."""
    description: str = ""
    """One line shown in the report."""
    seed: int = 0
    """Not used by a model file (a campaign file's seed)."""
    trials: int = 1
    """Not used by a model file (a campaign file's trials)."""


class ModelSpec(_Strict):
    """A validated model file (frozen)."""

    campaign: ModelMeta = Field(default_factory=ModelMeta)
    plant: PlantSpec
    update: UpdateSpec = Field(default_factory=UpdateSpec)
    diagnose: DiagnoseSpec = Field(default_factory=DiagnoseSpec)
    source: str = "<memory>"
    ignored: tuple[str, ...] = ()
    """Campaign tables present in the file and not used."""

    def make_plant(self):
        from truthbench.plants import make_plant

        return make_plant(self.plant.type, **self.plant.plant_options())

    def nominal_parameters(self) -> dict[str, float]:
        return self.make_plant().resolve(self.plant.parameters)


def parse_model(data: dict[str, Any], source: str = "<memory>") -> ModelSpec:
    """Validate a model file given as a dict (the parsed TOML).

    Raises
    ------
    CampaignError
        Naming ``source``, the key, what was expected and what was received.
    """
    ignored = tuple(k for k in CAMPAIGN_ONLY if k in data)
    kept = {k: v for k, v in data.items() if k not in CAMPAIGN_ONLY}
    try:
        spec = ModelSpec.model_validate({**kept, "source": source, "ignored": ignored})
    except ValidationError as err:
        raise CampaignError(_format_validation_error(source, err).replace(
            "campaign file", "model file")) from None
    try:
        plant = spec.make_plant()
        plant.resolve(spec.plant.parameters)
    except ModelError as exc:
        raise CampaignError(f"{source}: key 'plant': {exc}") from None
    from truthbench.effects import EFFECTS
    from truthbench.update import APPENDED_PARAMETERS

    known = set(plant.parameter_names()) | set(APPENDED_PARAMETERS)
    bad = [p for p in spec.update.parameters if p not in known]
    if bad:
        raise CampaignError(f"{source}: key 'update.parameters': expected parameters of "
                            f"{spec.plant.type} or {sorted(APPENDED_PARAMETERS)}; got {bad}")
    diagnosable = sorted(n for n, c in EFFECTS.items() if c.diagnosis is not None)
    bad = [c for c in spec.diagnose.candidates or () if c not in diagnosable]
    if bad:
        raise CampaignError(f"{source}: key 'diagnose.candidates': expected effects from "
                            f"{diagnosable}; got {bad}")
    bad = [k for k in spec.diagnose.map if not k.strip().lstrip("-").isdigit()]
    if bad:
        raise CampaignError(f"{source}: key 'diagnose.map': expected point numbers "
                            f"(integers) as keys; got {bad}")
    return spec


def load_model(path: str | Path) -> ModelSpec:
    """Read and validate a model file (or a campaign file used as one).

    Raises
    ------
    CampaignError
        A missing, non-UTF-8 or non-TOML file, or a bad key (named).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CampaignError(f"{path}: model file not found") from None
    except IsADirectoryError:
        raise CampaignError(f"{path}: is a folder; expected a model TOML file") from None
    except UnicodeDecodeError as exc:
        raise CampaignError(f"{path}: not a text (UTF-8) file ({exc.reason} at byte "
                            f"{exc.start}); expected a model TOML file") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{path}: not valid TOML: {exc}") from None
    return parse_model(data, str(path))
