"""Import path kept for callers: the cooperative field lives in :mod:`planners.apf.capf`."""
from planners.apf.capf import DEFAULT_LAMBDA3, CapfSettings

__all__ = ["CapfSettings", "DEFAULT_LAMBDA3"]
