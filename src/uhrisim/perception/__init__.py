"""perception subpackage."""
