"""Sweeps and labelled sonar datasets at scale, on Ray (``uhrisim sweep``, ``uhrisim
dataset``). Ray, pyarrow and pycocotools come with the ``batch`` extra and are imported
only inside this package (docs/design.md)."""
