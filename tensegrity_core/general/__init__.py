"""General tensegrity with rigid bodies (placeholder)."""
