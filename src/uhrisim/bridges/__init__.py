"""bridges subpackage."""
