"""Structure files used by the shipped scenes (package data)."""
