"""Campaigns: spec parsing and validation, the Monte Carlo runner, the results store."""
