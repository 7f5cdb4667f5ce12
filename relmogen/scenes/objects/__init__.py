"""Movable and articulated task objects built from PyBullet primitives (one module per object)."""
