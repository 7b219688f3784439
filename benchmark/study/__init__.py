"""The perceptual study kit: stimuli from stored runs, a study server, the analysis, and the
metrics held against people.

``python -m benchmark.study create | serve | export | analyze`` (:mod:`benchmark.study.__main__`).

A study is a folder::

    STUDY/
      study.json        the design (benchmark.study.design owns it): questions, stimuli with
                        their sha256, trials, each participant slot's trial order
      stimuli/          MP4 (H.264 + AAC) clips, a sound check clip
      answers.sqlite    the answers (benchmark.study.store owns it; --db URL for PostgreSQL)
      export/           answers.csv, answers.json, participants.csv (benchmark.study.answers)
      analysis/         tables (markdown, LaTeX), figure, analysis.json (benchmark.study.analysis)
"""
