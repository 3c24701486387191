"""The physics twin: drive a MuJoCo grid model along a Trajectory and report what happened.

Each robot's two position servos follow the trajectory with a velocity feed-forward; the
simulator records, per robot, the joint angles and the tracking error (true angle minus
the nominal trajectory), and every contact between two robots (and between a robot and a
fiducial): time, ids, penetration depth. Faults change what one robot is commanded or
measures. The parts:

- :mod:`~rfp_twin.twin.sim.faults`: :class:`Stuck`, :class:`Slow`, :class:`EncoderOffset`
- :mod:`~rfp_twin.twin.sim.control`: commanded angles, servo targets, tracking error
- :mod:`~rfp_twin.twin.sim.contacts`: :class:`ContactLog` of robot-robot / robot-fiducial contacts
- :mod:`~rfp_twin.twin.sim.report`: :class:`SimRecord` (sampled history), :class:`SimReport`
- :mod:`~rfp_twin.twin.sim.simulator`: :class:`SimSettings`, :class:`Simulator`, :func:`simulate`

All public numbers: mm, degrees, seconds; arrays over n robots in layout order.
"""
from rfp_twin.twin.sim.contacts import ContactLog
from rfp_twin.twin.sim.faults import EncoderOffset, Fault, Slow, Stuck
from rfp_twin.twin.sim.report import SimRecord, SimReport
from rfp_twin.twin.sim.simulator import Callback, SimSettings, Simulator, mujoco_warnings, simulate

__all__ = ["Callback", "ContactLog", "EncoderOffset", "Fault", "SimRecord", "SimReport",
           "SimSettings", "Simulator", "Slow", "Stuck", "mujoco_warnings", "simulate"]
