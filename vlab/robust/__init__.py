"""Robustness of the controllers to modelling errors (issue 29; the conclusion of Sec. 7).

- :mod:`vlab.robust.uncertainty`: the distributions (defaults with sources, or a TOML), one seeded draw per sample;
- :mod:`vlab.robust.sampled_loop`: the exact linearised sampled-data closed loop (poles, damping, FRF, energy index);
- :mod:`vlab.robust.study`: the Monte Carlo study in independent chunks, in this process or on Dask;
- :mod:`vlab.robust.simulate`: the worst samples run in time on the batched MuJoCo lab;
- :mod:`vlab.robust.report`: JSON, per-sample arrays, box plots, a rerun file and the Markdown verdict.

The command is ``vlab robustness bcc|grid``.
"""
