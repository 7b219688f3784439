"""Reference rows of the leaderboard: ground truth (upper) and mean / static /
random (lower). Registered as ``ground-truth``, ``mean``, ``static``, ``random``."""
