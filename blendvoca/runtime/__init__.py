"""The runtime floor every stage stands on, one module each.

* :mod:`.processes`: :func:`~.processes.process_map`, the one process map (Ctrl-C and
  dying workers handled; :mod:`.lifetime` ties each worker to its parent);
* :mod:`.threads`: :func:`~.threads.limited_threads`, the one BLAS/OpenMP/torch thread limiter;
* :mod:`.progress`: the one progress switch, set once per CLI from ``--quiet``;
* :mod:`.staging`: :func:`~.staging.staged_folder`, a folder output written beside its
  place and moved there when complete (:func:`~.staging.process_staging` for one written
  over more than one block).
"""
