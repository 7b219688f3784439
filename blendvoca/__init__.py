"""BlendVOCA: build the BlendVOCA dataset (ARKit blendshape rigs and coefficient
tracks for VOCASET) and the shared foundation of the benchmark."""

__version__ = "0.1.0"
