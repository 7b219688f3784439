"""``regression``: the end2end_AU_speech idea (log-mel spectrogram -> CNN + GRU ->
blendshape coefficients, least-squares training) re-implemented in PyTorch."""
