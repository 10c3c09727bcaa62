"""Robustness of the controllers to modelling errors (the conclusion of Sec. 7).

- :mod:`vlab.robust.uncertainty`: the distributions (defaults with sources, or a TOML), one seeded draw per sample;
- :mod:`vlab.robust.sampled_loop`: the exact linearised sampled-data closed loop (poles, damping, FRF, energy index);
- :mod:`vlab.robust.study`: the Monte Carlo study in independent chunks, in this process or on Dask;
- :mod:`vlab.robust.scheduler`: the ``--scheduler`` address checked and reached in bounded time, run-time estimates;
- :mod:`vlab.robust.simulate`: chosen samples run in time on the batched MuJoCo lab, self-excitation detected;
- :mod:`vlab.robust.limit_cycle`: what moves the limit cycle of a loop unstable on MuJoCo at nominal;
- :mod:`vlab.robust.plants`: the numbers per plant (FE sampled loop, MuJoCo), probabilities with Wilson intervals;
- :mod:`vlab.robust.pipeline`: the whole study as ``vlab robustness`` runs it;
- :mod:`vlab.robust.report`, :mod:`vlab.robust.markdown`, :mod:`vlab.robust.figures`: JSON, per-sample arrays,
  pictures, a rerun file and the Markdown verdict.

The command is ``vlab robustness bcc|grid``.
"""
