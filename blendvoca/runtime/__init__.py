"""The runtime floor every stage stands on: one progress switch (:mod:`.progress`).

Process maps, the BLAS thread limiter and staging folders for partial outputs live
here too, one module each; CLIs set the progress switch once from ``--quiet``.
"""
