"""isodesign."""
