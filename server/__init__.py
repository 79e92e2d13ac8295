"""weft server package."""
