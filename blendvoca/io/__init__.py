"""File formats at the edges of the pipeline: meshes, audio, coefficient CSVs."""
