"""Shared fixtures of the measure tests."""

import numpy as np
import pytest


@pytest.fixture
def rng():
    """A fixed-seed generator, so every test is reproducible."""
    return np.random.default_rng(20240611)
