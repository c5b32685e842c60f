"""record subpackage."""
