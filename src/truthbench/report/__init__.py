"""Reports: tables (pandas) and figures (matplotlib) from results files only."""
