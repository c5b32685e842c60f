"""scenario subpackage."""
