"""Robots: embodiment specs (YAML data) and the PyBullet ``Robot`` wrapper."""
