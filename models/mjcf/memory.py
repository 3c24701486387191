"""The size of MuJoCo's per-MjData arena (``<size memory=...>``), from the grid's own counts.

Why it is set here
------------------
Left to itself (``memory = -1``), MuJoCo's compiler picks the arena from a heuristic that
grows with the square of the degrees of freedom: 115 MB for 547 robots, 840 MB for
2,016, ~27 GB for 12,871 — more than the machine has, so compiling (which makes an
MjData) failed with "Could not allocate memory". The arena is sized here from what a
step of *this* model uses instead:

- the collision driver's stack: ``mj_collision`` reserves one 4-byte int per body pair,
  ``nbody (nbody - 1) / 2`` of them, every step (the broadphase candidates), and the
  broadphase about 8 bytes per pair of kinematic trees (measured: 8.2 - 8.9 ntree^2,
  ntree = robots); both are bounded by :data:`BODY_PAIR_BYTES` * nbody^2 in all. This is
  address space: only the pairs that overlap are written, so the resident memory stays
  linear in the robots (a 4.5 GB arena for 12,852 robots costs ~0 MB until used);
- the rest of a step's stack, linear in the bodies (measured < 400 bytes per body; we
  reserve :data:`STACK_BYTES_PER_BODY`);
- the contacts and their constraint rows: :data:`CONTACT_BYTES` each (measured 1.67 -
  1.71 kB with ``condim`` 3 and the pyramidal cone), for ``contacts_per_robot`` contacts
  per robot (:class:`rfp_twin.models.mjcf.ModelOptions`; uniformly random angles, every
  arm through its neighbours, give 0.4 - 0.85 contacts per robot). When a run has more,
  MuJoCo drops the extra contacts and counts ``mjWARN_CONTACTFULL``, which the
  simulation report lists as a warning.

Limit
-----
``mj_collision`` computes ``nbody * (nbody - 1)`` in a 32-bit C ``int`` and packs body ids
in 16 bits: above :data:`MAX_BODIES` bodies (15,446 robots at 3 bodies each) it cannot
run. :func:`check_body_count` refuses such a model with a :class:`SpecError` that says so,
instead of a crash at the first step.

Units: bytes; counts of bodies, trees, robots, contacts.
"""
from __future__ import annotations

import math

from rfp_twin.models.errors import SpecError

#: Collision-driver stack per body pair (4-byte pair ids over nbody^2 / 2 pairs, plus the
#: broadphase's ~8 bytes per tree pair <= 1 byte per body pair^2), bytes per nbody^2.
BODY_PAIR_BYTES = 3
#: The rest of a step's stack (kinematics, forces, integrator), bytes per body.
STACK_BYTES_PER_BODY = 1024
#: One contact with its constraint rows (``mjContact`` + efc arrays), bytes.
CONTACT_BYTES = 2048
#: Arena floor (small grids), bytes.
BASE_BYTES = 1 << 20
#: Largest body count MuJoCo's collision driver handles: nbody (nbody - 1) < 2^31.
MAX_BODIES = 46341
#: Bodies per robot (base, alpha, beta).
BODIES_PER_ROBOT = 3


def body_count(n_robots: int, n_obstacles: int) -> int:
    """Bodies of the grid model: the world, 3 per robot, 1 per obstacle."""
    return 1 + BODIES_PER_ROBOT * int(n_robots) + int(n_obstacles)


def arena_bytes(n_robots: int, n_obstacles: int, contacts_per_robot: float) -> int:
    """Arena size for the grid model of ``n_robots`` robots and ``n_obstacles`` obstacles
    with room for ``contacts_per_robot`` contacts per robot (see the module docstring),
    bytes, rounded up to a whole MiB."""
    nbody = body_count(n_robots, n_obstacles)
    contacts = math.ceil(max(0.0, float(contacts_per_robot)) * n_robots) + 16
    total = (BASE_BYTES + BODY_PAIR_BYTES * nbody * nbody + STACK_BYTES_PER_BODY * nbody
             + CONTACT_BYTES * contacts)
    mib = 1 << 20
    return -(-total // mib) * mib


def check_body_count(layout_name: str, n_robots: int, n_obstacles: int) -> None:
    """Raise :class:`SpecError` when the grid has more bodies than MuJoCo's collision
    driver can pair (:data:`MAX_BODIES`)."""
    nbody = body_count(n_robots, n_obstacles)
    if nbody > MAX_BODIES:
        most = (MAX_BODIES - 1 - n_obstacles) // BODIES_PER_ROBOT
        raise SpecError(
            f"layout {layout_name!r}: {n_robots:,} robots and {n_obstacles:,} obstacles make "
            f"{nbody:,} MuJoCo bodies; allowed: at most {MAX_BODIES:,} bodies (here "
            f"{most:,} robots) in one model, since MuJoCo's collision driver counts body pairs "
            "in a 32-bit int; simulate a part of the layout")

