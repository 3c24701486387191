"""Collision-buffer calibration: the 2D capsule model against the 3D meshes (FCL).

For two neighbouring robots, compares "safe in 2D at buffer b" (Sayres et al. 2021,
Eq. 3) with "safe in 3D" (the exact solid distance of the collision meshes) and reports
the smallest safe buffer, the configuration space the 2D model wastes, and the buffer
angular errors call for (Monte Carlo). Units: mm and degrees at the public boundary.

Modules
-------
report
    :class:`BufferCalibration`.
model2d
    The 2D model's distance (:func:`pair_segment_distances`) and required buffer.
sampling
    Neighbour directions, Sobol samples, the local search.
montecarlo
    The buffer angular errors call for, per draw of the errors.
calibrate
    :func:`calibrate_buffer`.
writer
    :func:`write_report`: markdown, JSON and figures.
"""
from rfp_twin.validation.buffer.calibrate import DEFAULT_BUFFERS_MM, calibrate_buffer
from rfp_twin.validation.buffer.model2d import pair_segment_distances
from rfp_twin.validation.buffer.report import BufferCalibration
from rfp_twin.validation.buffer.sampling import neighbour_directions
from rfp_twin.validation.buffer.writer import write_report

__all__ = ["BufferCalibration", "calibrate_buffer", "neighbour_directions", "write_report",
           "pair_segment_distances", "DEFAULT_BUFFERS_MM"]
