"""Reproduce the dissertation: its tables, figures and the Sec. 6.1 limit cycle, next to the published numbers.

- :mod:`vlab.reproduce.results`: :class:`Row`, :class:`TableResult`, :class:`ReproduceResult`;
- :mod:`vlab.reproduce.context`: models, designs, the laboratory structure, the virtual modal test;
- :mod:`vlab.reproduce.closedloop`: controllers applied to any model (damping, performance indices);
- :mod:`vlab.reproduce.tables`: one function per table group of Tables 1-9 (frequencies, reduction, BCC designs),
  :mod:`vlab.reproduce.grid_tables` of Tables 11-18 (grid designs) and :mod:`vlab.reproduce.ratio_tables` of
  Tables 10, 19-21 (peak-level ratios), with what they share in :mod:`vlab.reproduce.table_rows`;
- :mod:`vlab.reproduce.experiments`: virtual experiments for the peak-level ratios (Tables 10, 19-21);
- :mod:`vlab.reproduce.limit_cycle`: the LQG limit cycle of Sec. 6.1 (the exact modes of the digital loop in
  :mod:`vlab.reproduce.sampled_modes`);
- :mod:`vlab.reproduce.peakratios`: Table 10's published peak level ratios diagnosed as real data (the analysis
  side in :mod:`vlab.reproduce.peakanalysis`, the table and results in :mod:`vlab.reproduce.peaktable`, the fits
  in :mod:`vlab.reproduce.peakfits`);
- :mod:`vlab.reproduce.run`: :func:`reproduce` (report.md, reproduce.json, figures) and :func:`print_summary`.
"""

from .results import ReproduceResult, Row, TableResult
from .run import GROUPS, print_summary, reproduce

__all__ = ["GROUPS", "ReproduceResult", "Row", "TableResult", "print_summary", "reproduce"]
