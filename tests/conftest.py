"""Test-suite settings: property tests are derandomized (the same examples every run, on
every machine) and have no per-example deadline (CI machines are shared and slow)."""

from hypothesis import settings

settings.register_profile("uhrisim", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("uhrisim")
