"""Gait Studio desktop application (PySide6). Depends on gaitcore, never the reverse."""
