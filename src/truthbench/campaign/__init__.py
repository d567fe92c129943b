"""Campaigns: spec parsing and validation, the Monte Carlo runner, the results store.

:func:`reference` lists every key of the campaign and model files (type, default, unit,
constraint, description) from the schemas themselves
(:mod:`truthbench.campaign.file_reference`).
"""


def __getattr__(name: str):
    # imported on first use: importing a module of this package stays as light as it is
    if name in ("reference", "ReferenceRow"):
        from truthbench.campaign import file_reference

        return getattr(file_reference, name)
    raise AttributeError(f"module 'truthbench.campaign' has no attribute {name!r}")


__all__ = ["ReferenceRow", "reference"]
