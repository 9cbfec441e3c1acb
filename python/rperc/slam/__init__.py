"""EKF-SLAM (paper [000], section 2.2): the filter core and the monobot study.

- :class:`Ekf`: robot block plus landmark blocks, O(n) prediction and an O(n^2)
  Joseph-form update that exploits the sparse observation Jacobian;
- :mod:`rperc.slam.monobot`: the 1-D robot with the relative, anchor and external
  measurement models, Fisher information, observability and Monte Carlo consistency;
- :mod:`rperc.slam.evaluation`: ATE with and without SE(2) alignment, heading error,
  landmark RMSE, pose NEES and distance to GPS fixes, against ground truth;
- :class:`PlanarSlam` (:mod:`rperc.slam.planar`): whole recordings in one native call,
  with known, nearest-neighbour or JCBB association, the anchor (eqs. 24-25), the
  external sensor (eqs. 26-27) and landmark freezing; walls as a second landmark
  kind (:class:`WallMap`);
- :mod:`rperc.slam.wallslam`: wall SLAM on a laser log, paper [000]'s Fig. 7 experiment.
"""

from rperc._rperc import nees_bounds
from rperc.slam import evaluation, monobot
from rperc.slam.ekf import Ekf, EkfUpdate
from rperc.slam.planar import PlanarSlam, SlamResult, WallMap

__all__ = [
    "Ekf",
    "EkfUpdate",
    "PlanarSlam",
    "SlamResult",
    "WallMap",
    "evaluation",
    "monobot",
    "nees_bounds",
]
