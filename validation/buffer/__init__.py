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
pairs
    What the 2D model is calibrated against: 3D meshes, or the 2D capsule model itself.
metrology
    A real instrument's metrology spread as a perturbation of the two robots.
calibrate
    :func:`calibrate_buffer`.
writer
    :func:`write_report`: markdown, JSON and figures.
comparison, comparison_writer
    :func:`compare_buffers` (several robots side by side) and :func:`write_comparison`.
"""
from rfp_twin.validation.buffer.calibrate import DEFAULT_BUFFERS_MM, calibrate_buffer
from rfp_twin.validation.buffer.comparison import (BufferComparison, compare_buffers,
                                                   describe_geometry)
from rfp_twin.validation.buffer.comparison_writer import write_comparison
from rfp_twin.validation.buffer.metrology import MetrologySpread, perturbed_configurations
from rfp_twin.validation.buffer.model2d import pair_segment_distances
from rfp_twin.validation.buffer.report import BufferCalibration
from rfp_twin.validation.buffer.sampling import neighbour_directions
from rfp_twin.validation.buffer.writer import write_report

__all__ = ["BufferCalibration", "BufferComparison", "MetrologySpread", "calibrate_buffer",
           "compare_buffers", "describe_geometry", "neighbour_directions",
           "pair_segment_distances", "perturbed_configurations", "write_comparison",
           "write_report", "DEFAULT_BUFFERS_MM"]
