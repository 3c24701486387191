"""Potential-field planners: Makarem et al. 2014 (APF) and Macktoobian et al. 2019 (CAPF).

Each robot descends its own navigation function (attraction to its target, sign-corrected
repulsion from its neighbours; CAPF adds its neighbours' remaining errors), integrated
by Euler steps of 10 ms from any start straight to the targets. Units: mm, deg, s.

Modules: :mod:`~rfp_twin.planners.fields.settings` (parameters, resolved distances),
:mod:`~rfp_twin.planners.fields.capf` (the cooperative weight), :mod:`~rfp_twin.planners.fields.field` (distances
and gradients), :mod:`~rfp_twin.planners.fields.kernel` (the numba integration loop),
:mod:`~rfp_twin.planners.fields.driver` (plan_apf, the CLI-shaped entry),
:mod:`~rfp_twin.planners.fields.result` (ApfResult, its Plan), :mod:`~rfp_twin.planners.fields.tips` (random
tip-model configurations).
"""
from rfp_twin.planners.fields.capf import DEFAULT_LAMBDA3, CapfSettings
from rfp_twin.planners.fields.driver import (apf_target_margin_mm, nearest_spacing_mm, plan_apf,
                                 plan_apf_reconfiguration)
from rfp_twin.planners.fields.kernel import run_apf
from rfp_twin.planners.fields.result import STOP_REASONS, ApfResult, apf_plan
from rfp_twin.planners.fields.settings import (MODELS, SEGMENT_ENVELOPE_MM, TIP_D_MM, TIP_ENVELOPE_MM,
                                   ApfSettings, default_margin_mm)
from rfp_twin.planners.fields.tips import random_tip_configs

__all__ = [
    "ApfResult", "ApfSettings", "CapfSettings", "DEFAULT_LAMBDA3", "MODELS",
    "SEGMENT_ENVELOPE_MM", "STOP_REASONS", "TIP_D_MM", "TIP_ENVELOPE_MM", "apf_plan",
    "apf_target_margin_mm", "default_margin_mm", "nearest_spacing_mm", "plan_apf",
    "plan_apf_reconfiguration", "random_tip_configs", "run_apf",
]
