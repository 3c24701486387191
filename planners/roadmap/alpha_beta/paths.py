"""Per-robot breakpoint paths on the planner's step clock: :class:`PathSet`.

The search (:mod:`rfp_twin.planners.deadlocks.search.resolve`) reads the stepwise plan as a
PathSet, replaces the paths of the groups it re-plans and hands it back as CSR arrays
(:meth:`PathSet.to_csr`, the layout of :class:`rfp_twin.planners.plan.Plan`). Linear
interpolation between breakpoints on the step clock is the motion.

Units: angles in deg, time in planner steps (float step indices).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rfp_twin.models.errors import SpecError, field_error


@dataclass
class PathSet:
    """Per-robot breakpoint paths on the step clock, in the planner's frame.

    steps[i] : (k,) float64 step index (non-decreasing); angles[i] : (k, 2) deg.
    Before the first / after the last breakpoint a robot holds its first / last angles.
    """

    steps: list
    angles: list
    #: robot -> (its steps, its angles, motion end): paths are replaced, never changed in
    #: place, so an entry holds while both arrays are the ones stored
    _ends: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_csr(cls, ptr: np.ndarray, steps: np.ndarray, angles: np.ndarray) -> PathSet:
        n = len(ptr) - 1
        return cls([steps[ptr[i]:ptr[i + 1]].copy() for i in range(n)],
                   [angles[ptr[i]:ptr[i + 1]].copy() for i in range(n)])

    def to_csr(self, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CSR arrays (ptr, steps, angles) with every path ending at ``n_steps``.

        Breakpoints after ``n_steps`` are dropped; a path must not move after it."""
        st, an = [], []
        for i, (s, a) in enumerate(zip(self.steps, self.angles)):
            if s[-1] > n_steps:
                if self.motion_end(i) > n_steps:
                    raise field_error(SpecError, "n_steps", n_steps,
                                      f">= {self.motion_end(i)} (robot index {i} still moves)",
                                      "PathSet.to_csr")
                keep = s < n_steps
                s = np.append(s[keep], float(n_steps))
                a = np.vstack([a[keep], a[-1:]])
            if s[-1] < n_steps:
                s = np.append(s, float(n_steps))
                a = np.vstack([a, a[-1:]])
            st.append(s)
            an.append(a)
        ptr = np.zeros(len(st) + 1, dtype=np.int64)
        ptr[1:] = np.cumsum([len(s) for s in st])
        return ptr, np.concatenate(st), np.concatenate(an)

    def motion_end(self, i: int) -> float:
        """Step of robot i's last motion (its last breakpoint that changes the angles)."""
        st, a = self.steps[i], self.angles[i]
        held = self._ends.get(i)
        if held is not None and held[0] is st and held[1] is a:
            return held[2]
        moved = np.flatnonzero(np.any(np.abs(np.diff(a, axis=0)) > 1e-12, axis=1))
        end = 0.0 if moved.size == 0 else float(st[moved[-1] + 1])
        self._ends[i] = (st, a, end)
        return end

    def signature(self, i: int) -> bytes:
        """Robot i's path up to its last motion, as bytes (equal paths, equal bytes)."""
        a = self.angles[i]
        moved = np.flatnonzero(np.any(np.abs(np.diff(a, axis=0)) > 1e-12, axis=1))
        k = 1 if moved.size == 0 else int(moved[-1]) + 2
        return self.steps[i][:k].tobytes() + a[:k].tobytes()

    def sample(self, i: int, k: np.ndarray) -> np.ndarray:
        """Robot i's angles at steps k: (len(k), 2) deg."""
        s, a = self.steps[i], self.angles[i]
        return np.column_stack([np.interp(k, s, a[:, 0]), np.interp(k, s, a[:, 1])])

    def prefix(self, i: int, cut: float) -> tuple[np.ndarray, np.ndarray]:
        """Robot i's path up to step ``cut`` (its breakpoints before, and the point at cut)."""
        st, an = self.steps[i], self.angles[i]
        keep = st < cut
        end = self.sample(i, np.array([cut]))
        return np.append(st[keep], cut), np.vstack([an[keep], end])
