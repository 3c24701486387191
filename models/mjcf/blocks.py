"""Building large grids in blocks: an MjSpec add costs O(spec size), so add into small specs.

MuJoCo's spec re-lists its whole body tree (``ResetTreeLists`` + ``MakeTreeLists``) and
recomputes its signature on every ``add_geom`` / ``add_joint`` / ``add_site``: building
n robots one element at a time into one spec costs O(n^2) (a 12,871-robot grid spent
minutes there before compiling; MuJoCo's XML parser does the same). An attach costs
O(size of the spec attached to), whatever the size of the part attached.

So :func:`add_in_blocks` builds the robots (or obstacles) into small *leaf* specs of
:data:`BLOCK_ROBOTS` each (an add re-lists only its leaf), then merges them pairwise,
level by level (binary merging costs least: a level of fan-in F costs ~(F - 1) / 2 * n,
and there are log_F(n / BLOCK_ROBOTS) levels), and attaches the result to the grid's
spec: O(n log n) element visits instead of O(n^2). The grid's spec is the first leaf, so
the last merge attaches the second half of the grid into it (measured at 12,852 robots:
5.2 s of adds, 4.7 s of merges instead of O(n^2) minutes; MuJoCo's compile, which follows,
is O(n^2) itself, see :mod:`rfp_twin.models.mjcf.memory`).

Attached elements keep their names (empty prefix) and resolve their mesh, material and
default-class references in the grid's spec by name: block geoms are created with the
grid's own default classes (their values are copied at creation, the class name is
resolved at attach), so the exported XML has each class once. MuJoCo warns that an
attach with an empty prefix "may prevent the model from being saved correctly" (names
could clash); ours cannot clash (``r<id>``, ``fid<id>``, unique layout ids), so that one
message is filtered (:func:`quiet_attach`); any other warning passes through.
"""
from __future__ import annotations

import contextlib
import warnings
from typing import Callable

import mujoco

from rfp_twin.models.mjcf.options import collect_mujoco_warnings

#: Robots (or obstacles) per leaf spec: an add into a leaf re-lists at most this many
#: robots; an attach has a fixed cost of ~0.3 ms, so leaves of one robot would cost more.
BLOCK_ROBOTS = 32
#: The MuJoCo warning an attach with an empty prefix raises (see the module docstring).
EMPTY_PREFIX_WARNING = "Attaching a spec with an empty prefix"


def block_spec(grid: mujoco.MjSpec) -> mujoco.MjSpec:
    """A new, empty block spec with the grid's compiler angle unit (radians)."""
    blk = mujoco.MjSpec()
    blk.compiler.degree = grid.compiler.degree
    return blk


def attach_block(grid: mujoco.MjSpec, blk: mujoco.MjSpec) -> None:
    """Attach every body and actuator of ``blk`` to the grid's world body, names kept."""
    with quiet_attach():
        grid.attach(blk, frame=grid.worldbody.add_frame(), prefix="")


@contextlib.contextmanager
def quiet_attach():
    """Context manager: drop MuJoCo's empty-prefix attach warning (printed by MuJoCo and
    raised again as a Python ``UserWarning`` by ``MjSpec.compile``); any other MuJoCo
    warning raised inside is passed on to the handler that was installed before."""
    previous = mujoco.get_mju_user_warning()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=EMPTY_PREFIX_WARNING, category=UserWarning)
        with collect_mujoco_warnings() as messages:
            yield
    for msg in messages:
        if EMPTY_PREFIX_WARNING in msg:
            continue
        if previous is not None:
            previous(msg)
        else:  # pragma: no cover - MuJoCo's own handler is a C function
            warnings.warn(f"MuJoCo: {msg}", RuntimeWarning, stacklevel=3)


def blocks(n: int, size: int | None = None) -> list[range]:
    """Index ranges ``[0, size), [size, 2 size), ...`` covering ``range(n)`` (default size
    :data:`BLOCK_ROBOTS`)."""
    size = BLOCK_ROBOTS if size is None else size
    return [range(k, min(n, k + size)) for k in range(0, n, size)]


def add_in_blocks(grid: mujoco.MjSpec, count: int, add: Callable[[mujoco.MjSpec, int], None],
                  progress: Callable[[int], None] | None = None, grid_first: bool = True) -> int:
    """Call ``add(spec, k)`` for k = 0 .. count - 1: the first :data:`BLOCK_ROBOTS` into
    ``grid`` itself (``grid_first``: only while the grid is small), the others into leaf
    specs of that many; then merge pairwise, level by level (the second of each pair
    attached to the first), so that everything ends in ``grid``. Bodies and actuators keep
    the order of k. ``progress(k)`` is called after each leaf with the number of items
    added so far. Returns the number of attaches."""
    level = [] if grid_first else [grid]
    for j, rows in enumerate(blocks(count)):
        leaf = grid if grid_first and j == 0 else block_spec(grid)
        for k in rows:
            add(leaf, k)
        level.append(leaf)
        if progress is not None:
            progress(rows.stop)
    attaches = 0
    while len(level) > 1:
        for first, second in zip(level[0::2], level[1::2]):
            attach_block(first, second)
            attaches += 1
        level = level[0::2]
    return attaches
