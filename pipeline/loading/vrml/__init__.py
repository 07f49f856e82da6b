"""vrml."""
