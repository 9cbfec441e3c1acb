"""Victoria Park, Sydney (ACFR; Guivant & Nebot): a utility car among trees.

Files (``.gz`` read as well):

- ``measurements.dat``: ``time range bearing diameter``, one tree per line. The file's
  bearing is in the LASER frame, 0..pi from the laser's right to its left with pi/2
  straight ahead. We return ``measurement_bearing = laser bearing - pi/2``: relative to
  the vehicle heading, counter-clockwise (left) positive, 0 ahead, the convention of
  the Rust ``slam`` crate's range-bearing model and of ``Ackermann::observe`` (measured
  from the laser, which sits ahead and left of the rear axle). The laser-frame value
  stays available as ``measurement_bearing_laser``.
- ``inputs.dat``: ``time speed steering`` (speed at the rear left wheel encoder, m/s;
  steering angle, rad).
- ``gps.dat``: ``time x y`` (local metric frame, intermittent).

Times are seconds from the start of the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rperc.datasets._table import data_file, non_negative, read_table

# Three times the top encoder speed of the run (6.6 m/s): a fix implying more is a glitch.
GPS_MAX_SPEED = 20.0

# Where the laser sits on the car (ahead of and left of the rear axle centre, m): the
# point Guivant and Nebot's filter estimates, and where the GPS is compared.
LASER_MOUNT = (3.78, 0.50)


@dataclass(frozen=True, repr=False)
class VictoriaPark:
    """The Victoria Park run as float64 arrays."""

    measurement_t: np.ndarray
    measurement_range: np.ndarray
    measurement_bearing: np.ndarray  # vehicle-relative, radians, left positive
    measurement_bearing_laser: np.ndarray  # as in the file, pi/2 ahead
    measurement_diameter: np.ndarray
    input_t: np.ndarray
    input_speed: np.ndarray
    input_steering: np.ndarray
    gps_t: np.ndarray
    gps_x: np.ndarray
    gps_y: np.ndarray
    nan_rows: int
    time_backwards: int

    def scans(self) -> int:
        """Number of laser scans (distinct measurement times)."""
        return int(np.unique(self.measurement_t).size)

    def gps_plausible(self, max_speed: float = GPS_MAX_SPEED) -> np.ndarray:
        """Boolean mask of the GPS fixes that at least one neighbouring fix can reach
        at ``max_speed`` (m/s): a fix that jumps away from both neighbours (the run has
        one 141 m off at t = 1223.3 s, between fixes 2.2 s and 4.4 s away) is a receiver
        glitch, not the car. Uses only the GPS itself, never an estimate."""
        if not max_speed > 0:
            raise ValueError(f"max_speed must be > 0, got {max_speed}")
        xy = np.c_[self.gps_x, self.gps_y]
        n = len(xy)
        if n < 2:
            return np.ones(n, dtype=bool)
        dt = np.maximum(np.diff(self.gps_t), 1e-9)
        speed = np.hypot(*np.diff(xy, axis=0).T) / dt
        ok_prev = np.r_[False, speed <= max_speed]
        ok_next = np.r_[speed <= max_speed, False]
        mask: np.ndarray = ok_prev | ok_next
        return mask

    def __repr__(self) -> str:
        return (
            f"VictoriaPark({len(self.measurement_t)} tree detections in {self.scans()} "
            f"scans, {len(self.input_t)} inputs, {len(self.gps_t)} GPS fixes over "
            f"{self.input_t[-1] - self.input_t[0]:.0f} s; {self.nan_rows} rows with NaN, "
            f"{self.time_backwards} times going backwards)"
        )


def load_victoria_park(
    directory: str | Path, *, allow_time_backwards: bool = False
) -> VictoriaPark:
    """Reads ``measurements.dat``, ``inputs.dat`` and ``gps.dat`` from ``directory``.

    Raises :class:`DatasetFormatError` with file and line for a malformed line, an
    empty file or (unless ``allow_time_backwards``, which counts them) a time going
    backwards.
    """
    folder = Path(directory)
    meas, inputs, gps = (
        read_table(data_file(folder, name), cols, allow_time_backwards=allow_time_backwards)
        for name, cols in (("measurements.dat", 4), ("inputs.dat", 3), ("gps.dat", 3))
    )
    # A range and a trunk's diameter have no negative values.
    non_negative(meas, {1: "range", 3: "diameter"})
    laser = meas.column(2)
    return VictoriaPark(
        measurement_t=meas.column(0),
        measurement_range=meas.column(1),
        measurement_bearing=laser - math.pi / 2,
        measurement_bearing_laser=laser,
        measurement_diameter=meas.column(3),
        input_t=inputs.column(0),
        input_speed=inputs.column(1),
        input_steering=inputs.column(2),
        gps_t=gps.column(0),
        gps_x=gps.column(1),
        gps_y=gps.column(2),
        nan_rows=meas.nan_rows + inputs.nan_rows + gps.nan_rows,
        time_backwards=meas.time_backwards + inputs.time_backwards + gps.time_backwards,
    )
