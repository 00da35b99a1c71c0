"""The evaluation suite behind ``python -m gmcpt eval`` and ``docs/results.md``.

Data flow: :mod:`~gmcpt.evaluation.config` (what to measure, as data) ->
:mod:`~gmcpt.evaluation.measure` (renders, completions, timings -> plain rows)
-> :mod:`~gmcpt.evaluation.report` (tables and crossovers, pure functions of
the rows) and :mod:`~gmcpt.evaluation.plots` -> :mod:`~gmcpt.evaluation.document`
(``results.md`` opening with :mod:`~gmcpt.evaluation.glance`, the README's results and limits);
:mod:`~gmcpt.cli.eval` drives it. ``gmcpt compare`` (:mod:`~gmcpt.cli.compare`, its figures in
:mod:`~gmcpt.evaluation.compare_report`) runs the same equal-time measurement on one user scene.
Baselines that are not completion methods (path tracing, path tracing + OIDN)
are in :mod:`~gmcpt.evaluation.baselines`; the scenes it runs on in
:mod:`~gmcpt.evaluation.scenes`, their cached high-spp references in
:mod:`~gmcpt.evaluation.reference`.
"""
