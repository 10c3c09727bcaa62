"""``python -m vlab.grid_fit [--check | --global]``: the grid fit from the command line (:func:`vlab.grid_fit.fit.main`)."""

from .fit import main

if __name__ == "__main__":
    raise SystemExit(main())
