"""Frames, errors, seeded randomness: the pieces every other subpackage uses."""
