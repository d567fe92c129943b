"""plants room."""
