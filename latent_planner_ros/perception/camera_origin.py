"""Which camera origin goes with a cloud: the newest `camera/pose`, if its stamp is close to the cloud's. No ROS.

The collision network's visibility channels need the point the cloud was seen from (models/visibility.py).
Without one (no pose yet, a pose too far in time from the cloud, or a refused pose) the cloud is encoded with
the origin unknown: the network then works from the points alone, as trained for a tenth of its clouds.
"""

from __future__ import annotations

import numpy as np


class CameraOrigin:
    """The newest camera origin (3,) [m] in `world` and its stamp [s].

    Args:
        max_age_s: a pose whose stamp is more than this from the cloud's stamp [s] is not used with it;
            0 = any pose is used (a fixed camera whose pose was published once).
        topic: the pose topic's name, for the status words.
    """

    def __init__(self, max_age_s: float, topic: str = "camera/pose"):
        self.max_age_s = float(max_age_s)
        self.topic = topic
        self.position: np.ndarray | None = None
        self.stamp_s = 0.0

    def on_pose(self, position: np.ndarray, stamp_s: float) -> None:
        """A camera pose arrived: its optical centre (3,) [m] in `world` (finite) and header stamp [s]."""
        self.position = np.asarray(position, dtype=np.float64).reshape(3).copy()
        self.stamp_s = float(stamp_s)

    def for_cloud(self, cloud_stamp_s: float) -> tuple[np.ndarray | None, str]:
        """The origin (3,) to encode a cloud stamped cloud_stamp_s [s] with, or None, and a status word."""
        if self.position is None:
            return None, f"unknown: no {self.topic} received"
        gap = abs(cloud_stamp_s - self.stamp_s)
        if self.max_age_s > 0.0 and gap > self.max_age_s:
            return None, f"unknown: newest {self.topic} is {gap:.2f} s from the cloud's stamp"
        return self.position, "known"
