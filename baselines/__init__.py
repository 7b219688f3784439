"""Baseline methods for the BlendVOCA benchmark (SAiD, FaceFormer, CodeTalker, CDFace, regression,
reference methods, mesh adapters); what they share is in :mod:`baselines.common`."""
