"""Files and the data types they hold: recordings, FRFs, UFF files, tables, safe writing.

Modules
-------
recording
    :class:`~vlab.io.recording.Recording`: sampled time histories of named channels.
frf
    :class:`~vlab.io.frf.FRF`: a frequency response function on a frequency grid.
uff, uff_time, uff_frf, uff55, uff_files, uff_units
    UFF datasets 58 (time histories, FRFs) and 55 (mode shapes); :mod:`vlab.io.uff` re-exports
    the readers and writers.
tabular
    A command's result rows as a table or CSV.
atomic, confine, manifest
    Output folders written atomically, input files confined to their folder, and
    the manifest of the files vlab wrote.
"""
