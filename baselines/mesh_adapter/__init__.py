"""``mesh-adapter``: scores vertex-based methods (VOCA, FaceFormer, MeshTalk,
CodeTalker ...) by fitting BlendVOCA coefficient tracks to their FLAME-topology
outputs with the temporally constrained QP, as the SAiD paper did."""
