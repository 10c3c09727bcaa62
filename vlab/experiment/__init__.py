"""The experiment runner: run the loop on a plant, measure like a modal test, compare with the analysis.

Modules
-------
runner
    :func:`~vlab.experiment.runner.run_experiment`: design, plant, the digital loop
    with its hardware chain (Sec. 5.3), the excitation and H1 measurement of Sec. 5.4,
    and the mode-by-mode comparison with the analysis (Tables 10, 19-21).
results
    The experiment's output folder: ``results.json``, ``report.md``, UFF files, figures.
"""
