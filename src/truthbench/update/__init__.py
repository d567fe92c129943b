"""update room."""
