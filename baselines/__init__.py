"""Baseline methods for the BlendVOCA benchmark (SAiD, regression, mesh adapters)."""
