"""Independent 2D check of probe-arm plans (MIRADAS, Sabater et al. 2018).

:func:`check_probe_plan` samples a plan densely and checks contacts between the arms'
capsules, the ZoA and joint ranges, joint speeds and start-stop cycles, with its own
kinematics and the validation package's own segment distance; it imports nothing of
``planners``; :func:`check_probe_plan_3d` measures the arms' capsules in 3D with FCL.
Units: mm, deg, s.
"""
from rfp_twin.validation.probe.check import ProbeCheckReport, check_probe_plan, start_stop_cycles
from rfp_twin.validation.probe.check3d import ProbeCheck3DReport, check_probe_plan_3d

__all__ = ["ProbeCheck3DReport", "ProbeCheckReport", "check_probe_plan", "check_probe_plan_3d",
           "start_stop_cycles"]
