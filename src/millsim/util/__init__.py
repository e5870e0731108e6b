"""Helpers every layer may use: input validation and interval statistics (pure Python/numpy)."""
