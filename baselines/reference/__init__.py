"""Reference rows of the leaderboard: ground truth and the corpus meshes (the floors
of the rig and mesh reference spaces) and mean / static / random (lower). Registered as
``ground-truth``, ``corpus-meshes``, ``mean``, ``static``, ``random``."""
