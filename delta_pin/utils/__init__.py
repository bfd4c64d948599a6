"""Utilities every layer may use: atomic writes and one progress display."""
