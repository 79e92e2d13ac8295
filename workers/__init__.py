"""weft workers package."""
