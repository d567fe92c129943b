"""identify room."""
