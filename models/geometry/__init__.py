"""Geometry shared by every solver: rotations and quaternions, box features, the paper's
spherical angles, and the approach of two boxes to first contact.

May import NumPy only (no other impactnet wing).
"""
