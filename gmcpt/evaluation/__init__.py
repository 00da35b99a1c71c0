"""The evaluation suite behind ``python -m gmcpt eval`` and ``docs/results.md``.

Data flow: :mod:`~gmcpt.evaluation.config` (what to measure, as data) ->
:mod:`~gmcpt.evaluation.measure` (renders, completions, timings -> plain rows)
-> :mod:`~gmcpt.evaluation.report` (tables and crossovers, pure functions of
the rows) and :mod:`~gmcpt.evaluation.plots` -> :mod:`~gmcpt.evaluation.document`
(``results.md``, the README section); :mod:`~gmcpt.evaluation.cli` drives it.
Baselines that are not completion methods (path tracing, path tracing + OIDN)
are in :mod:`~gmcpt.evaluation.baselines`; the scenes it runs on in
:mod:`~gmcpt.evaluation.scenes`, their cached high-spp references in
:mod:`~gmcpt.evaluation.reference`.
"""
