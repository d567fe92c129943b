"""match_points: channels' points to model nodes by coordinates.

Oracle: distances worked out by hand on a small grid of nodes (3-4-5 triangles).
"""

from __future__ import annotations

import numpy as np
import pytest

from truthbench.errors import DataFormatError
from truthbench.measure import Channel, match_points

NODES = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0]])


def ch(label, xyz, point=None):
    return Channel(label, "acceleration", "z", point=point, coordinates_m=xyz)


def test_nearest_node_within_the_tolerance():
    chans = [ch("a", (0.0, 0.0, 0.0), 11), ch("b", (2.0, 0.003, 0.004), 12),  # 5 mm away
             ch("c", (1.0, 0.0, -0.001), 13), ch("d", (2.0, 0.999, 0.0), 14)]
    np.testing.assert_array_equal(match_points(chans, NODES, 0.005), [0, 2, 1, 3])
    assert match_points(chans, NODES, 0.005).dtype.kind == "i"
    # the tolerance is inclusive and exact: 5 mm passes at 5 mm, fails below
    with pytest.raises(DataFormatError, match=r"channel 'b' at point 12 \(2, 0\.003, 0\.004\) "
                                              r"m matches no model node within 0\.00499 m: the "
                                              r"nearest is node 2 at \(2, 0, 0\) m, 0\.005 m "
                                              r"away"):
        match_points(chans, NODES, 0.00499)


def test_equidistant_nodes_take_the_lower_index():
    assert match_points([ch("m", (1.5, 0.0, 0.0))], NODES, 0.5).tolist() == [1]


def test_errors_name_the_file_channel_point_and_nearest_node():
    far = ch("tip", (3.0, 4.0, 0.0), point=101)  # 5 m from node 0, sqrt(10) from node 3
    with pytest.raises(DataFormatError, match=r"^beam\.uff: channel 'tip' at point 101 \(3, 4, "
                                              r"0\) m matches no model node within 0\.01 m: "
                                              r"the nearest is node 3 at \(2, 1, 0\) m, 3\.16 m"):
        match_points([far], NODES, 0.01, where="beam.uff")
    with pytest.raises(DataFormatError, match=r"beam\.uff: channel 'x' \(point 7\) has no "
                                              r"coordinates"):
        match_points([Channel("x", "force", point=7)], NODES, 0.01, where="beam.uff")
    with pytest.raises(ValueError, match=r"'node_coordinates_m' must have shape \(n, 3\); got "
                                         r"\(4,\)"):
        match_points([far], NODES[:, 0], 0.01)
    with pytest.raises(ValueError, match=r"'tolerance_m' must be a finite number >= 0"):
        match_points([far], NODES, -1.0)
    with pytest.raises(ValueError, match=r"holds no node"):
        match_points([far], np.zeros((0, 3)), 1.0)


# ------------------------------------------------------------- FRFData and its Estimator


def _frfdata(**kw):
    from truthbench.measure import FRFData

    f = np.linspace(0.0, 8.0, 5)
    return FRFData("t", f, np.ones((5, 1, 1), complex),
                   (Channel("y", "acceleration", "z"),), (Channel("u", "force", "z"),), **kw)


def test_the_estimator_and_n_averages_are_one_number():
    """The estimate's averages live in its Estimator; n_averages is the same number, a
    missing one filled from the other, two different ones refused."""
    from truthbench.measure.leakage import Estimator

    est = Estimator("hann", 8, 16.0)
    d = _frfdata(estimator=est, n_averages=4)
    assert d.estimator.averages == 4 and d.n_averages == 4
    d = _frfdata(estimator=Estimator("hann", 8, 16.0, averages=6))
    assert d.n_averages == 6
    assert _frfdata(n_averages=3).estimator is None
    with pytest.raises(ValueError, match=r"'n_averages' \(3\) and the estimator's averages "
                                         r"\(6\) must agree"):
        _frfdata(estimator=Estimator("hann", 8, 16.0, averages=6), n_averages=3)
    with pytest.raises(ValueError, match="'estimator' must be an Estimator; got dict"):
        _frfdata(estimator={"window": "hann"})
    # lines() keeps the estimator (a model is compared through it on any subset)
    assert d.lines(d.freq_hz > 0).estimator == d.estimator
