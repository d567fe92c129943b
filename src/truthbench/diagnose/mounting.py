"""Off-axis mounting, modelled in the comparison with one real amplitude per path.

No accelerometer sits on a beam's axis and no stinger drives through it: a sensor
offset ``e_s`` from the axis reads ``e_s`` times the section's rotation besides its own
direction, and reads a fraction ``c`` of the motion across it; a force line offset
``e_a`` applies the torque ``e_a F`` and, tilted by ``a``, the transverse force
``F sin(a)`` (:mod:`truthbench.effects.mounting` puts these into a truth). A test on a
beam bent in z then also sees its torsion, its roll as a rigid body and its lateral
bending, which a model with ideal channels cannot show.

For a section symmetric about both axes the beam's bending in the channel's plane, its
torsion and its bending across are uncoupled, so what the mounting adds to the FRF of
sensor ``o`` and actuator ``i`` is

    k_oi H_rot(o, i) + l_oi H_across(o, i),    k_oi = e_s e_a,  l_oi = c sin(a),

with ``H_rot`` the model's FRF from a torque about the rotation axis ``p x d`` at the
actuator to the rotation at the sensor, and ``H_across`` from a force along ``p`` to the
motion along ``p`` (``d`` the channel's direction, ``p`` the transverse direction across
it, :data:`~truthbench.effects.mounting.PERPENDICULAR`).

The comparison models in the rotation path (:data:`PATHS`; why not the transverse one
is said there): the torsion modes and, on a free article, the roll as a rigid body,
which no effect of the catalogue moves and which an ideal channel cannot see. Each
amplitude is real and linear, so it is eliminated as the modes the model lacks are
(:class:`~.fit.ExtraModes`): each transfer function's weighted residual loses its part
in the span of its weighted column. The column is the model's own, at its current
parameters and effects (held during a fit and refreshed with the estimator's offsets),
so one real number per transfer function carries every torsion mode and the roll at
once, where a mode modelled in with free residues takes a complex number per mode and
transfer function.

The amplitudes are free per transfer function (``k_oi`` rather than the product of a
sensor's and an actuator's offsets), which costs one parameter per transfer function
against thousands of lines and keeps the elimination linear. The columns are exact
FRFs, without the estimator's leakage: the mounting's share of a peak is a few percent
of it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from truthbench.effects.mounting import PERPENDICULAR
from truthbench.plants.base import Actuator, Sensor
from truthbench.update.predictor import FRFPredictor, PredictedTest

ROTATION = {"z": "rx", "y": "rx", "x": "ry"}
"""The rotation an offset sensor reads (and an offset force turns) for each direction:
the axis of ``p x d``."""

TWINS = {"rotation": ROTATION, "across": PERPENDICULAR}
"""The channel direction each mounting path reads and drives, by the direction of the
channel: the rotation an offset turns, the transverse direction a cross-axis reading
and a misaligned force act along."""

PATHS = ("rotation",)
"""The paths modelled in. The transverse path is left out: a round tube's bending
across has the frequencies and shapes of its bending in the channels' plane, so its
column is the in-plane FRF but for the suspension's modes, and its amplitude takes up
a channel's gain error or an attachment's change of a peak (found so on study trials:
an amplitude ten times the largest a sensor and a shaker can have, ``c sin(a)`` of
0.04). A lateral mode that shows apart from its in-plane twin (where an effect moves
one of them) is found as a mode the model lacks instead."""


def _mounted(direction: str, quantity: str | None = None) -> bool:
    return direction in PERPENDICULAR and quantity != "strain"


def _twins(t: PredictedTest, paths: tuple[str, ...]) -> PredictedTest:
    """``t`` with each mounted channel replaced by its twin of each path (sensors and
    actuators path by path, in ``paths``' order)."""
    sens = [Sensor(s.station, TWINS[p][s.direction], s.quantity) for p in paths
            for s in t.sensors if _mounted(s.direction, s.quantity)]
    acts = [Actuator(a.station, TWINS[p][a.direction]) for p in paths
            for a in t.actuators if _mounted(a.direction)]
    return replace(t, sensors=tuple(sens), actuators=tuple(acts), kernel=None)


def mounting_columns(predictor: FRFPredictor, theta: Mapping[str, float],
                     paths: tuple[str, ...] = PATHS) -> tuple[np.ndarray, ...]:
    """The mounting's FRF columns of every transfer function at ``theta``.

    Parameters
    ----------
    predictor : FRFPredictor
        The model (its plant, effects and tests) the data are compared with.
    theta : mapping
        Its parameters.
    paths : tuple of str
        Paths of :data:`TWINS`, in order (default :data:`PATHS`).

    Returns
    -------
    tuple of ndarray, complex, shape (n_lines, n_out, n_in, len(paths))
        Per test: ``H_rot`` (per unit ``k``: the sensor's units per newton times metres
        squared) and ``H_across`` (per unit ``l``: per newton) of each sensor and
        actuator; zero for a strain or rotation channel, which has no such path.
    """
    twins = tuple(_twins(t, paths) for t in predictor.tests)
    usable = [t for t in twins if t.sensors and t.actuators]
    frfs = iter(FRFPredictor(predictor.plant, predictor.nominal, usable, predictor.effects,
                             predictor.mode_tolerance, predictor.reduced).predict(theta)
                if usable else ())
    out = []
    for t, twin in zip(predictor.tests, twins, strict=True):
        cols = np.zeros((t.freq_hz.size, len(t.sensors), len(t.actuators), len(paths)),
                        complex)
        if twin.sensors and twin.actuators:
            H = next(frfs)
            rows = [o for o, s in enumerate(t.sensors) if _mounted(s.direction, s.quantity)]
            inputs = [i for i, a in enumerate(t.actuators) if _mounted(a.direction)]
            n, m = len(rows), len(inputs)
            for k in range(len(paths)):
                block = H[:, k * n:(k + 1) * n, k * m:(k + 1) * m]
                cols[np.ix_(np.arange(t.freq_hz.size), rows, inputs, [k])] = block[..., None]
        out.append(cols)
    return tuple(out)


@dataclass(frozen=True)
class MountingCheck:
    """What the mounting modelled in took up at the final fit.

    Attributes
    ----------
    chi2_without : float
        The final fit's chi2 with the mounting's columns taken out of the comparison
        (modes the model lacks kept), noise units.
    chi2_with : float
        The final fit's chi2, noise units.
    n : int
        Real values compared.
    paths : tuple of (str, str, str, float)
        Per transfer function: test, sensor, actuator and the rotation path's amplitude
        ``k`` (m^2: the product of the sensing point's and the force line's offsets),
        its least-squares value at the final fit.
    """

    chi2_without: float
    chi2_with: float
    n: int
    paths: tuple[tuple[str, str, str, float], ...]

    @property
    def drop(self) -> float:
        return self.chi2_without - self.chi2_with

    def summary(self) -> str:
        if not self.paths:
            return "not modelled: no translational sensor and shaker pair"
        k = max(self.paths, key=lambda p: abs(p[3]))
        return (f"modelled in (every sensor and shaker off the axis, reading and driving "
                f"the beam's torsion and roll): it takes {self.drop:.4g} of the chi2 "
                f"({100 * self.drop / self.n:.3g} % of the noise over {self.n} values); "
                f"the largest path k = {k[3]:.3g} m^2 ({k[1]} from {k[2]}: e.g. both "
                f"offsets {1e3 * np.sqrt(abs(k[3])):.2g} mm)")


def mounting_check(problem, current, noise: float) -> MountingCheck | None:
    """The :class:`MountingCheck` of ``current`` on ``problem`` (None when the mounting
    is not modelled in); chi2 in units of the noise variance ``noise``."""
    extra = problem.extra
    if extra is None or not extra.mounted:
        return None
    from truthbench.diagnose.fit import _POWERS, ExtraModes, pole_columns

    poles = extra.poles
    plain = replace(problem, extra=ExtraModes.build(poles, problem.tests, problem.weights)
                    if poles else None)
    G = np.asarray(plain.predict(current.terms)(current.theta))
    columns = mounting_columns(problem.predictor(current.terms), current.theta)
    out, start = [], 0
    for t, cols in zip(problem.tests, columns, strict=True):
        shape = cols.shape[:3]
        size = int(np.prod(shape))
        W = problem.weights[start:start + size].reshape(shape)
        # the residual of the model with the modes it lacks but without the mounting:
        # the paths' amplitudes are fitted to it beside those modes' residues
        R = W * (problem.data - G)[start:start + size].reshape(shape)
        start += size
        s = 2j * np.pi * t.freq_hz + t.decay_rad_s
        for o, x in enumerate(t.sensors):
            g = pole_columns(s, poles, _POWERS[x.quantity])
            for i, a in enumerate(t.actuators):
                if not np.any(cols[:, o, i]):
                    continue
                A = W[:, o, i, None] * np.hstack([cols[:, o, i], g, 1j * g])
                coef, *_ = np.linalg.lstsq(np.vstack([A.real, A.imag]),
                                           np.concatenate([R[:, o, i].real,
                                                           R[:, o, i].imag]), rcond=None)
                out.append((t.name, x.label, a.label, float(coef[0])))
    without = plain.chi2(G)
    return MountingCheck(float(without / noise), float(current.chi2 / noise), problem.n,
                         tuple(out))


__all__ = ["PATHS", "ROTATION", "TWINS", "MountingCheck", "mounting_check",
           "mounting_columns"]
