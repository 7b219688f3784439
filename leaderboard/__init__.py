"""Leaderboard tables rendered from stored result files (``python -m leaderboard.build``)."""
