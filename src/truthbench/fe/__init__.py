"""fe room."""
