"""autonomy subpackage."""
