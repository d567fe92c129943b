"""simulate room."""
