"""Reproductions of the paper's experiments (open loop, Figs 5-8)."""
