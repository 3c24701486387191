"""From configurations to collision-free, timed trajectories."""
