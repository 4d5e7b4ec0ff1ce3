"""Files in and out: TOML and CSV readers, design files, run records."""
