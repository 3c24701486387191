"""The instrument as it is: robot specs, layouts, kinematics and 2D collision geometry."""
