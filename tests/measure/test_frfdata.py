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
