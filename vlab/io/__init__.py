"""File input/output: UFF datasets 58/55 (:mod:`vlab.io.uff`)."""
