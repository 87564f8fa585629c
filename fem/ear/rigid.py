"""Rigid bodies with six dofs at a reference point: the FE ear's name for :mod:`isj.kinematics`.

The point maps, grounded springs, rigid masses and axis of rotation live in
:mod:`isj.kinematics`, shared with the lumped ear; this module keeps the old
import path working.
"""

from isj.kinematics import axis_of_rotation, grounded_springs, point_map, rigid_mass, skew

__all__ = ["axis_of_rotation", "grounded_springs", "point_map", "rigid_mass", "skew"]
