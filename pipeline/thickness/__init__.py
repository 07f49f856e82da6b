"""thickness."""
