"""The rig: joint hierarchies and forward kinematics, rotations, and the ellipsoid renderer."""
