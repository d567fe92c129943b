"""The package version (a room of its own, so every room can name it without importing
the package's public API)."""

__version__ = "0.1.0"
