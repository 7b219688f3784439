"""What the baselines share, one module per job.

A baseline package (``said``, ``faceformer``, ``codetalker``, ``cdface``,
``regression``, ``reference``, ``mesh_adapter``) imports its own modules, this
package and the shared models :mod:`baselines.vq` and :mod:`baselines.wav2vec2`;
it never imports another baseline. Importing this package imports nothing: each
module is imported where it is needed.

===========================  ======================================================
module                       holds
===========================  ======================================================
``attention_bias``           additive biases and boolean masks of the attention
                             layers (SAiD's alignment band, FaceFormer's periodic
                             causal bias and its encoder-decoder mask)
``chunking``                 long audio in overlapping, crossfaded chunks (the
                             chunk plan, the blend, the seam measurement)
``checkpoint``               reading and writing torch checkpoint files (safe
                             loads only, the converter hint), the authors' state
                             dicts (``module.`` prefixes, wav2vec 2.0 layouts,
                             required keys, layer counts)
``dataset``                  reading a benchmark dataset's sentences (16 kHz audio)
``device``                   the torch device of a ``--device`` option
``encoders``                 speech encoders: the frozen ones at the coefficient
                             frame rate (log-mel, wav2vec 2.0) and the trainable
                             front ends of FaceFormer and CodeTalker
``npz_file``                 a method's ``.npz`` file, read without pickle
``mel``                      the HTK mel scale and its triangular filter bank
``motion_decoder``           FaceFormer's biased causal transformer decoder, which
                             CodeTalker's stage 2 reuses
``positional``               the periodic positional encoding
``presets``                  presets with flat overrides, paths in presets
``sequences``                vertex training sequences, 30 <-> 60 fps
``threads``                  a scoped torch thread count
``track_lookup``             methods that return a stored track per sentence
``training``                 the one-sentence-per-step training loop
``vertex_method``            the benchmark side of the style-conditioned vertex
                             methods (FaceFormer, CodeTalker)
===========================  ======================================================
"""
