"""Vector quantization shared by the codebook-based baselines (CodeTalker, CDFace)."""

from .quantizer import VectorQuantizer, nearest_code_indices

__all__ = ["VectorQuantizer", "nearest_code_indices"]
