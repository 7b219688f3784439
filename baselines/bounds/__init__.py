"""The bounds of the leaderboard, shown as reference rows and never ranked: ground truth and
the corpus meshes (the floors of the rig and mesh reference spaces), the synthetic corpus's
oracles, and mean / static / random (lower bounds). Registered as ``ground-truth``,
``corpus-meshes``, ``oracle-sample``, ``oracle-mean``, ``mean``, ``static``, ``random``."""
