"""The experiment runner: run the loop on a plant, measure like a modal test, compare with the analysis.

With its results writer and its estimate of a run's memory and time.

Modules
-------
config
    The modal test of each structure (:data:`~vlab.experiment.config.TESTS`, Sec. 5.4.2) and
    the settings of one experiment (:class:`~vlab.experiment.config.ExperimentConfig`,
    :func:`~vlab.experiment.config.default_chain`: the hardware chain of Sec. 5.3).
runner
    :func:`~vlab.experiment.runner.run_experiment`: design, plant, the digital loop
    with its hardware chain (Sec. 5.3), the excitation and H1 measurement of Sec. 5.4,
    and the mode-by-mode comparison with the analysis (Tables 10, 19-21).
settling
    How many records the start-up transient needs to settle (Sec. 5.4.1).
checks
    Warnings about a finished run: under-resolved peaks, self-excited oscillations.
estimate
    The memory and time of a run, estimated before it starts, and the memory available for it.
results
    The experiment's output folder: ``results.json``, ``report.md``, UFF files, figures.
"""
