"""Test systems for the simulate room, built from first principles (M, C, K)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import scipy.linalg


@dataclass(frozen=True)
class System:
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float
    name: str


def second_order(m, c, k, b_force):
    """First-order form of ``M q'' + C q' + K q = b_force u``; state ``[q, q']``."""
    n = m.shape[0]
    m_inv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ k, -m_inv @ c]])
    b = np.vstack([np.zeros((n, b_force.shape[1])), m_inv @ b_force])
    return a, b


def three_mode() -> System:
    """Lightly damped 3-DOF chain, non-proportional (discrete) damping, 1 in, 2 out.

    Outputs: displacement of mass 3 (m) and acceleration of mass 1 (m/s^2), the latter
    with a direct feedthrough D != 0. Modes near 5.7, 21.4 and 27.1 Hz with damping
    ratios 1.3 %, 0.35 % and 0.19 %.
    """
    m = np.diag([1.0, 2.0, 1.5])
    k = np.array([[2e4, -1e4, 0.0], [-1e4, 3e4, -2e4], [0.0, -2e4, 2e4]])
    c = np.diag([0.5, 0.0, 3.0])  # dampers to ground at masses 1 and 3: not Rayleigh
    a, b = second_order(m, c, k, np.array([[1.0], [0.0], [0.0]]))
    cc = np.vstack([np.eye(6)[2], a[3]])
    d = np.vstack([[0.0], b[3]])
    return System(a, b, cc, d, 1e-3, "three_mode")


def free_free() -> System:
    """Free-free pair of masses joined by a spring and a damper: a rigid-body mode.

    ``A`` has a defective double eigenvalue at 0 (rigid displacement and velocity).
    Outputs: both displacements and the velocity of mass 2.
    """
    m = np.diag([1.0, 2.0])
    k = 1e3 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    c = 2.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    a, b = second_order(m, c, k, np.array([[1.0], [0.0]]))
    cc = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])
    return System(a, b, cc, np.zeros((3, 1)), 1e-3, "free_free")


def random_stable(seed: int = 3, n: int = 6) -> System:
    """Random dense stable A (spectral abscissa -0.2 1/s), 2 inputs, 3 outputs, D != 0."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    a -= (np.max(np.linalg.eigvals(a).real) + 0.2) * np.eye(n)
    return System(
        a,
        rng.standard_normal((n, 2)),
        rng.standard_normal((3, n)),
        rng.standard_normal((3, 2)),
        0.05,
        "random_stable",
    )


def free_free_chain(n_mass: int = 6, seed: int = 4) -> System:
    """Free-free spring-damper chain: rigid-body mode plus n_mass - 1 flexible modes."""
    rng = np.random.default_rng(seed)
    m = np.diag(rng.uniform(0.5, 2.0, n_mass))
    k = np.zeros((n_mass, n_mass))
    c = np.zeros((n_mass, n_mass))
    for i in range(n_mass - 1):
        e = np.zeros(n_mass)
        e[i], e[i + 1] = 1.0, -1.0
        k += 1e5 * (1 + i) * np.outer(e, e)
        c += 3.0 * np.outer(e, e)
    a, b = second_order(m, c, k, np.eye(n_mass)[:, [0, n_mass // 2]])
    n = 2 * n_mass
    cc = np.eye(n)[[0, n_mass - 1, n - 1]]
    return System(a, b, cc, np.zeros((3, 2)), 5e-4, "free_free_chain")


def modal_rigid(seed: int = 6) -> System:
    """Modal-coordinate model with two rigid-body modes (exact ``[[0, 1], [0, 0]]``
    Jordan blocks) and eight 1 %-damped flexible modes from 5 to 500 Hz; 1 in, 3 out."""
    rng = np.random.default_rng(seed)
    omega = np.r_[0.0, 0.0, 2 * np.pi * np.geomspace(5.0, 500.0, 8)]
    zeta = np.r_[0.0, 0.0, np.full(8, 0.01)]
    blocks = [
        np.array([[0.0, 1.0], [-(w**2), -2 * z * w]]) for w, z in zip(omega, zeta, strict=True)
    ]
    a = scipy.linalg.block_diag(*blocks)
    n = a.shape[0]
    b = np.zeros((n, 1))
    b[1::2, 0] = rng.standard_normal(omega.size)
    c = np.zeros((3, n))
    c[:, 0::2] = rng.standard_normal((3, omega.size))
    return System(a, b, c, np.zeros((3, 1)), 2.5e-4, "modal_rigid")


SYSTEMS = {
    s.name: s
    for s in (three_mode(), free_free(), random_stable(), free_free_chain(), modal_rigid())
}


@pytest.fixture(params=sorted(SYSTEMS))
def system(request) -> System:
    return SYSTEMS[request.param]


def relative_error(y, ref) -> float:
    """Largest ``max_t |y - ref| / rms(ref)`` over the output channels."""
    rms = np.sqrt(np.mean(ref**2, axis=-1))
    return float(np.max(np.max(np.abs(y - ref), axis=-1) / rms))


@pytest.fixture
def systems() -> dict[str, System]:
    return SYSTEMS


@pytest.fixture
def rel_err():
    return relative_error
