"""Inward per-face offset surfaces (shells) of closed triangle meshes.

Lengths are millimetres; points are ``(x, y, z)``; signed distance is negative inside.
This package never imports :mod:`pipeline` or :mod:`voxel`.
"""
